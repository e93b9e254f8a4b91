#include "lcm_wire.hpp"

#include <cstring>

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

}  // namespace exoid::lcmwire
