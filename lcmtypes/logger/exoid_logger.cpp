// exoid_logger: records every LCM message on a udpm:// group into an lcm-logger format file, without loss.
// Debian's lcm-logger (LCM 1.3.1) drops bursts in its user-space receive ring when a lockstep simulation
// publishes ~30k messages/s (the kernel had delivered every datagram); this receiver reads the socket in
// batches (recvmmsg) straight into the event log, with a large kernel buffer, and drains it before exiting.
#include <arpa/inet.h>
#include <lcm/eventlog.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "exoid/common/cli.hpp"
#include "exoid/lcm/channels.hpp"
#include "lcm_wire.hpp"

namespace {

using exoid::channels::kDefaultUrl;

volatile sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

int bad(const std::string& m) {
  std::fprintf(stderr, "exoid_logger: error: %s\n", m.c_str());
  return 2;
}

int64_t nowUs() {
  timeval tv;
  gettimeofday(&tv, nullptr);
  return int64_t{tv.tv_sec} * 1000000 + tv.tv_usec;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url = std::getenv("LCM_DEFAULT_URL") ? std::getenv("LCM_DEFAULT_URL") : kDefaultUrl;
  std::string out;
  bool force = false, quiet = false;
  int64_t buf_mb = 64;
  CLI::App app{
      "Records every message published on an LCM udpm:// multicast group (all channels) into FILE in the\n"
      "lcm-logger event-log format (readable by lcm-logplayer, lcm-spy, exoid export). Runs until SIGINT or\n"
      "SIGTERM, then drains what the kernel still holds and prints per-channel counts. Small and fragmented LCM\n"
      "messages are both reassembled; malformed datagrams and messages with missing fragments are counted.",
      "exoid_logger"};
  exoid::common::configureCli(app);
  app.add_option("--lcm-url", url, "udpm://GROUP:PORT[?ttl=0...]; the default is $LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--out", out, "event-log file to write")->required()->type_name("FILE");
  app.add_flag("--force", force, "overwrite FILE if it exists");
  app.add_option("--recv-buf-mb", buf_mb, "kernel receive buffer in MiB (as root it may exceed net.core.rmem_max)")
      ->transform(exoid::common::strictInteger(1, 1024))->type_name("N");
  app.add_flag("--quiet", quiet, "print only errors and the final summary");
  app.footer("exit codes: 0 success, 1 socket or file error, 2 bad input.");
  if (const int code = exoid::common::parseCli(app, argc, argv); code >= 0) return code;
  if (out.empty()) return bad("--out FILE is required");
  // udpm://GROUP:PORT?params
  if (url.rfind("udpm://", 0) != 0) return bad("--lcm-url must be udpm://GROUP:PORT (got '" + url + "')");
  const std::string hostport = url.substr(7, url.find('?') == std::string::npos ? std::string::npos : url.find('?') - 7);
  const size_t colon = hostport.rfind(':');
  in_addr group{};
  char* end = nullptr;
  const long port = colon == std::string::npos ? 0 : std::strtol(hostport.c_str() + colon + 1, &end, 10);
  if (colon == std::string::npos || *end || port < 1 || port > 65535 ||
      inet_aton(hostport.substr(0, colon).c_str(), &group) == 0 || !IN_MULTICAST(ntohl(group.s_addr)))
    return bad("--lcm-url: '" + hostport + "' is not a multicast GROUP:PORT");
  if (!force && access(out.c_str(), F_OK) == 0) return bad("'" + out + "' exists (use --force to overwrite)");

  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  const int one = 1;
  int bytes = static_cast<int>(buf_mb << 20);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  ip_mreq mreq{};
  mreq.imr_multiaddr = group;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) < 0 ||
      (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) < 0 &&
       setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes) < 0) ||
      bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0 ||
      setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) < 0) {
    std::fprintf(stderr, "exoid_logger: error: cannot join %s: %s (a network namespace needs 'ip route add "
                         "224.0.0.0/4 dev lo')\n", hostport.c_str(), std::strerror(errno));
    return 1;
  }
  lcm_eventlog_t* log = lcm_eventlog_create(out.c_str(), "w");
  if (!log) {
    std::fprintf(stderr, "exoid_logger: error: cannot write '%s'\n", out.c_str());
    return 1;
  }
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  if (!quiet) std::fprintf(stderr, "exoid_logger: recording %s -> %s\n", hostport.c_str(), out.c_str());

  constexpr int kBatch = 64, kMaxPacket = 65536;
  std::vector<uint8_t> buffers(size_t{kBatch} * kMaxPacket);
  std::vector<mmsghdr> msgs(kBatch);
  std::vector<iovec> iovs(kBatch);
  std::vector<sockaddr_in> from(kBatch);
  exoid::lcmwire::Reassembler reassembler;
  exoid::lcmwire::Message message;
  std::map<std::string, long> per_channel;
  long events = 0;
  bool write_error = false;
  // Reads everything available now; returns the number of datagrams read.
  auto drain = [&]() {
    int total = 0;
    for (;;) {
      for (int i = 0; i < kBatch; ++i) {
        iovs[i] = {buffers.data() + size_t{static_cast<size_t>(i)} * kMaxPacket, kMaxPacket};
        msgs[i].msg_hdr = {};
        msgs[i].msg_hdr.msg_iov = &iovs[i];
        msgs[i].msg_hdr.msg_iovlen = 1;
        msgs[i].msg_hdr.msg_name = &from[i];
        msgs[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
      }
      const int n = recvmmsg(fd, msgs.data(), kBatch, MSG_DONTWAIT, nullptr);
      if (n <= 0) return total;
      const int64_t t = nowUs();
      for (int i = 0; i < n; ++i) {
        const uint64_t sender = (uint64_t{from[i].sin_addr.s_addr} << 16) | from[i].sin_port;
        if (!reassembler.feed(sender, static_cast<const uint8_t*>(iovs[i].iov_base), msgs[i].msg_len, &message)) continue;
        lcm_eventlog_event_t e{};
        e.timestamp = t;
        e.channellen = static_cast<int32_t>(message.channel.size());
        e.channel = message.channel.data();
        e.datalen = static_cast<int32_t>(message.data.size());
        e.data = message.data.data();
        if (lcm_eventlog_write_event(log, &e) != 0) write_error = true;
        ++per_channel[message.channel];
        ++events;
      }
      total += n;
    }
  };
  pollfd pfd{fd, POLLIN, 0};
  while (!g_stop && !write_error) {
    if (poll(&pfd, 1, 200) > 0) drain();
  }
  drain();  // what arrived before the stop request
  lcm_eventlog_destroy(log);
  close(fd);
  std::fprintf(stderr, "exoid_logger: %ld events written to %s; malformed datagrams %ld, incomplete messages %ld\n",
               events, out.c_str(), reassembler.malformed(), reassembler.incomplete());
  for (const auto& [channel, count] : per_channel) std::fprintf(stderr, "  %-24s %ld\n", channel.c_str(), count);
  if (write_error) {
    std::fprintf(stderr, "exoid_logger: error: writing '%s' failed\n", out.c_str());
    return 1;
  }
  return 0;
}
