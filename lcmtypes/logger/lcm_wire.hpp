#pragma once
// LCM's UDP multicast wire protocol (lcm-proj's "UDP Multicast Protocol Description"), receive side:
// small messages ("LC02": magic, sequence number, channel\0, payload) and fragmented ones ("LC03": magic,
// sequence number, payload size, fragment offset, fragment number, fragment count; fragment 0 carries the
// channel). All integers big-endian.
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace exoid::lcmwire {

inline constexpr uint32_t kMagicShort = 0x4c433032;  // "LC02"
inline constexpr uint32_t kMagicLong = 0x4c433033;   // "LC03"

struct Message {
  std::string channel;
  std::vector<uint8_t> data;
};

/// Reassembles messages from datagrams. Fragments are keyed by (sender, sequence number); a message whose
/// fragments never all arrive is counted as incomplete when a newer message from the same sender completes
/// or at finish().
class Reassembler {
 public:
  /// Feeds one datagram from `sender`. Returns true and fills *out when it completes a message.
  bool feed(uint64_t sender, const uint8_t* packet, size_t size, Message* out);
  /// Messages still missing fragments (call at the end).
  long incomplete() const { return incomplete_ + static_cast<long>(partial_.size()); }
  long malformed() const { return malformed_; }

 private:
  struct Partial {
    std::string channel;
    std::vector<uint8_t> data;
    std::vector<bool> have;
    int received = 0;
  };
  std::map<std::pair<uint64_t, uint32_t>, Partial> partial_;
  long incomplete_ = 0, malformed_ = 0;
};

}  // namespace exoid::lcmwire
