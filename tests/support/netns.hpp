#pragma once
// Moves the calling test process (and the processes it starts) into a private network namespace with only a
// loopback interface, multicast routed to it: udpm:// traffic between test processes can never leave it.
#include <sched.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>

namespace exoid::test {

inline bool enterPrivateNetworkNamespace(std::string* why) {
  if (::unshare(CLONE_NEWNET) != 0) {
    if (why) *why = std::string("unshare(CLONE_NEWNET) failed (needs root): ") + std::strerror(errno);
    return false;
  }
  if (std::system("ip link set lo up") != 0 || std::system("ip route add 224.0.0.0/4 dev lo") != 0) {
    if (why) *why = "cannot configure the namespace's loopback (iproute2)";
    return false;
  }
  return true;
}

}  // namespace exoid::test
