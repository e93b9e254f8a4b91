#include "lcm_wire.hpp"

#include <arpa/inet.h>
#include <poll.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "exoid/common/strict_number.hpp"

namespace exoid::lcmwire {

namespace {
uint32_t be32(const uint8_t* p) { return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3]; }
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }
}  // namespace

bool Reassembler::feed(uint64_t sender, const uint8_t* p, size_t n, Message* out) {
  if (n < 8) return ++malformed_, false;
  const uint32_t magic = be32(p), seq = be32(p + 4);
  if (magic == kMagicShort) {
    const void* nul = std::memchr(p + 8, 0, n - 8);
    if (!nul) return ++malformed_, false;
    const uint8_t* payload = static_cast<const uint8_t*>(nul) + 1;
    out->channel.assign(reinterpret_cast<const char*>(p + 8));
    out->data.assign(payload, p + n);
    return true;
  }
  if (magic != kMagicLong || n < 20) return ++malformed_, false;
  const uint32_t size = be32(p + 8), offset = be32(p + 12);
  const uint16_t index = be16(p + 16), count = be16(p + 18);
  if (count == 0 || index >= count || size > (64u << 20)) return ++malformed_, false;
  const uint8_t* data = p + 20;
  size_t len = n - 20;
  const auto key = std::make_pair(sender, seq);
  auto it = partial_.find(key);
  if (it == partial_.end()) {
    it = partial_.emplace(key, Partial()).first;
    it->second.data.resize(size);
    it->second.have.assign(count, false);
  }
  Partial& m = it->second;
  if (m.have.size() != count || m.data.size() != size) return ++malformed_, false;
  if (index == 0) {
    const void* nul = std::memchr(data, 0, len);
    if (!nul) return ++malformed_, false;
    m.channel.assign(reinterpret_cast<const char*>(data));
    const size_t skip = static_cast<const uint8_t*>(nul) + 1 - data;
    data += skip;
    len -= skip;
  }
  if (offset + len > size) return ++malformed_, false;
  if (!m.have[index]) {
    if (len > 0) std::memcpy(m.data.data() + offset, data, len);  // an empty message has no buffer (null)
    m.have[index] = true;
    ++m.received;
  }
  if (m.received < count) return false;
  out->channel = std::move(m.channel);
  out->data = std::move(m.data);
  partial_.erase(it);
  // Older partial messages of this sender can no longer complete (LCM sends fragments in order).
  for (auto p2 = partial_.begin(); p2 != partial_.end();) {
    if (p2->first.first == sender && p2->first.second < seq) {
      ++incomplete_;
      p2 = partial_.erase(p2);
    } else {
      ++p2;
    }
  }
  return true;
}

bool parseUdpmUrl(const std::string& url, in_addr* group, uint16_t* port, std::string* why, std::string* address) {
  if (url.rfind("udpm://", 0) != 0) {
    if (why) *why = "must be udpm://GROUP:PORT (got '" + url + "')";
    return false;
  }
  const size_t q = url.find('?');
  const std::string hostport = url.substr(7, q == std::string::npos ? std::string::npos : q - 7);
  const size_t colon = hostport.rfind(':');
  int64_t p = 0;
  if (colon == std::string::npos || !exoid::common::parseInt(hostport.substr(colon + 1), 1, 65535, p) ||
      hostport[colon + 1] == '+' || inet_aton(hostport.substr(0, colon).c_str(), group) == 0 ||
      !IN_MULTICAST(ntohl(group->s_addr))) {
    if (why) *why = "'" + hostport + "' is not a multicast GROUP:PORT";
    return false;
  }
  *port = static_cast<uint16_t>(p);
  if (address) *address = hostport;
  return true;
}

std::unique_ptr<UdpmReceiver> UdpmReceiver::open(const std::string& url, size_t buffer_bytes, std::string* why) {
  in_addr group{};
  uint16_t port = 0;
  std::string address;
  if (!parseUdpmUrl(url, &group, &port, why, &address)) return nullptr;
  std::unique_ptr<UdpmReceiver> r(new UdpmReceiver());
  r->fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  const int one = 1;
  const int bytes = static_cast<int>(std::min<size_t>(buffer_bytes, size_t{1} << 30));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  ip_mreq mreq{};
  mreq.imr_multiaddr = group;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (r->fd_ < 0 || setsockopt(r->fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) < 0 ||
      (setsockopt(r->fd_, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) < 0 &&
       setsockopt(r->fd_, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes) < 0) ||
      bind(r->fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0 ||
      setsockopt(r->fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) < 0) {
    if (why)
      *why = "cannot join " + address + ": " + std::strerror(errno) +
             " (a network namespace needs 'ip route add 224.0.0.0/4 dev lo')";
    return nullptr;  // the destructor closes the socket
  }
  r->buffers_.resize(size_t{kBatch} * kMaxPacket);
  r->msgs_.resize(kBatch);
  r->iovs_.resize(kBatch);
  r->from_.resize(kBatch);
  r->message_.data.reserve(kMaxPacket);
  return r;
}

UdpmReceiver::~UdpmReceiver() {
  if (fd_ >= 0) close(fd_);
}

long UdpmReceiver::drain(const Handler& handler, long max_datagrams) {
  long total = 0;
  while (max_datagrams <= 0 || total < max_datagrams) {
    for (int i = 0; i < kBatch; ++i) {
      iovs_[i] = {buffers_.data() + static_cast<size_t>(i) * kMaxPacket, kMaxPacket};
      msgs_[i].msg_hdr = {};
      msgs_[i].msg_hdr.msg_iov = &iovs_[i];
      msgs_[i].msg_hdr.msg_iovlen = 1;
      msgs_[i].msg_hdr.msg_name = &from_[i];
      msgs_[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
    }
    const int n = recvmmsg(fd_, msgs_.data(), kBatch, MSG_DONTWAIT, nullptr);
    if (n <= 0) return total;
    timeval tv;
    gettimeofday(&tv, nullptr);
    const int64_t t = int64_t{tv.tv_sec} * 1000000 + tv.tv_usec;
    for (int i = 0; i < n; ++i) {
      const uint64_t sender = (uint64_t{from_[i].sin_addr.s_addr} << 16) | from_[i].sin_port;
      if (!reassembler_.feed(sender, static_cast<const uint8_t*>(iovs_[i].iov_base), msgs_[i].msg_len, &message_))
        continue;
      ++messages_;
      handler(message_.channel, message_.data.data(), message_.data.size(), t);
    }
    total += n;
  }
  return total;
}

long UdpmReceiver::poll(int timeout_ms, const Handler& handler, long max_datagrams) {
  pollfd pfd{fd_, POLLIN, 0};
  const int r = ::poll(&pfd, 1, timeout_ms);
  if (r < 0) return errno == EINTR ? 0 : -1;
  return r > 0 ? drain(handler, max_datagrams) : 0;
}

}  // namespace exoid::lcmwire
