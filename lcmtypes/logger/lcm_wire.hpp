#pragma once
// LCM's UDP multicast wire protocol (lcm-proj's "UDP Multicast Protocol Description"), receive side:
// small messages ("LC02": magic, sequence number, channel\0, payload) and fragmented ones ("LC03": magic,
// sequence number, payload size, fragment offset, fragment number, fragment count; fragment 0 carries the
// channel). All integers big-endian.
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
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

/// GROUP and PORT of a udpm://GROUP:PORT[?params] URL, and the "GROUP:PORT" text (address, optional). False with
/// *why naming the problem (not udpm://, not a multicast group, a bad port).
bool parseUdpmUrl(const std::string& url, in_addr* group, uint16_t* port, std::string* why,
                  std::string* address = nullptr);

/// A receiver of every message on one udpm:// group, straight from its own socket: a large kernel buffer
/// (bursts while the process is descheduled wait there, where LCM 1.3.1's user-space ring of lcm_handle drops
/// them: docs/lcm.md), read in batches (recvmmsg), reassembled (Reassembler). Used by exoid_logger and by
/// exo_estimator on udpm://. Not thread-safe; one per thread.
class UdpmReceiver {
 public:
  /// channel, payload, payload size, receive time (microseconds since the epoch). A handler may run for a while:
  /// the rest of the batch waits in the receiver's buffers.
  using Handler = std::function<void(const std::string& channel, const uint8_t* data, size_t size, int64_t utime)>;
  /// Joins the group of `url` with a kernel receive buffer of buffer_bytes (SO_RCVBUFFORCE as root, else
  /// SO_RCVBUF up to net.core.rmem_max). nullptr and *why (one line, errno text) on failure.
  static std::unique_ptr<UdpmReceiver> open(const std::string& url, size_t buffer_bytes, std::string* why);
  ~UdpmReceiver();
  UdpmReceiver(const UdpmReceiver&) = delete;
  UdpmReceiver& operator=(const UdpmReceiver&) = delete;

  int fd() const { return fd_; }
  /// Reads the datagrams the kernel holds now (non-blocking), at most about max_datagrams (whole batches; <= 0:
  /// until the socket is empty), and hands each completed message to `handler`. Returns the number read. A bound
  /// keeps a caller's loop turning (checkpoints, signals) while a sender outpaces it.
  long drain(const Handler& handler, long max_datagrams = 0);
  /// Waits up to timeout_ms (0: no wait) for a datagram, then drains (max_datagrams as there). Returns datagrams
  /// read, -1 if poll failed.
  long poll(int timeout_ms, const Handler& handler, long max_datagrams = 0);
  long messages() const { return messages_; }
  long malformed() const { return reassembler_.malformed(); }
  long incomplete() const { return reassembler_.incomplete(); }

 private:
  UdpmReceiver() = default;
  static constexpr int kBatch = 64;
  static constexpr size_t kMaxPacket = 65536;
  int fd_ = -1;
  std::vector<uint8_t> buffers_;   // [kBatch * kMaxPacket]
  std::vector<mmsghdr> msgs_;      // [kBatch]
  std::vector<iovec> iovs_;        // [kBatch]
  std::vector<sockaddr_in> from_;  // [kBatch]
  Reassembler reassembler_;
  Message message_;
  long messages_ = 0;
};

}  // namespace exoid::lcmwire
