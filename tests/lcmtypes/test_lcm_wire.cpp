// Reassembly of LCM's UDP multicast wire protocol, with datagrams built by hand from the protocol
// description: small messages, fragmented messages in and out of order, duplicates, losses, garbage.
#include <gtest/gtest.h>

#include "lcm_wire.hpp"

namespace exoid::lcmwire {
namespace {

void put32(std::vector<uint8_t>& v, uint32_t x) {
  for (int s = 24; s >= 0; s -= 8) v.push_back(static_cast<uint8_t>(x >> s));
}
void put16(std::vector<uint8_t>& v, uint16_t x) {
  v.push_back(static_cast<uint8_t>(x >> 8));
  v.push_back(static_cast<uint8_t>(x));
}

std::vector<uint8_t> small(uint32_t seq, const std::string& channel, const std::vector<uint8_t>& data) {
  std::vector<uint8_t> p;
  put32(p, kMagicShort);
  put32(p, seq);
  p.insert(p.end(), channel.begin(), channel.end());
  p.push_back(0);
  p.insert(p.end(), data.begin(), data.end());
  return p;
}

std::vector<std::vector<uint8_t>> fragments(uint32_t seq, const std::string& channel, const std::vector<uint8_t>& data,
                                            size_t chunk) {
  std::vector<std::vector<uint8_t>> out;
  const uint16_t count = static_cast<uint16_t>((data.size() + chunk - 1) / chunk);
  for (uint16_t i = 0; i < count; ++i) {
    std::vector<uint8_t> p;
    put32(p, kMagicLong);
    put32(p, seq);
    put32(p, static_cast<uint32_t>(data.size()));
    put32(p, static_cast<uint32_t>(i * chunk));
    put16(p, i);
    put16(p, count);
    if (i == 0) p.insert(p.end(), channel.begin(), channel.end()), p.push_back(0);
    const size_t end = std::min(data.size(), (i + 1) * chunk);
    p.insert(p.end(), data.begin() + i * chunk, data.begin() + end);
    out.push_back(p);
  }
  return out;
}

std::vector<uint8_t> payload(size_t n) {
  std::vector<uint8_t> d(n);
  for (size_t i = 0; i < n; ++i) d[i] = static_cast<uint8_t>(i * 31 + 7);
  return d;
}

TEST(LcmWire, SmallMessage) {
  Reassembler r;
  Message m;
  const auto d = payload(300);
  const auto p = small(5, "EXO_STATE", d);
  ASSERT_TRUE(r.feed(1, p.data(), p.size(), &m));
  EXPECT_EQ(m.channel, "EXO_STATE");
  EXPECT_EQ(m.data, d);
}

TEST(LcmWire, FragmentsInAnyOrderWithDuplicates) {
  Reassembler r;
  Message m;
  const auto d = payload(5000);
  auto f = fragments(9, "EXO_ESTIMATE", d, 1400);
  ASSERT_EQ(f.size(), 4u);
  EXPECT_FALSE(r.feed(1, f[2].data(), f[2].size(), &m));
  EXPECT_FALSE(r.feed(1, f[0].data(), f[0].size(), &m));
  EXPECT_FALSE(r.feed(1, f[0].data(), f[0].size(), &m));  // duplicate
  EXPECT_FALSE(r.feed(2, f[3].data(), f[3].size(), &m));  // another sender's stream: separate
  EXPECT_FALSE(r.feed(1, f[3].data(), f[3].size(), &m));
  ASSERT_TRUE(r.feed(1, f[1].data(), f[1].size(), &m));
  EXPECT_EQ(m.channel, "EXO_ESTIMATE");
  EXPECT_EQ(m.data, d);
  EXPECT_EQ(r.malformed(), 0);
  EXPECT_EQ(r.incomplete(), 1);  // sender 2's lone fragment
}

TEST(LcmWire, LostFragmentIsCountedWhenANewerMessageCompletes) {
  Reassembler r;
  Message m;
  auto a = fragments(1, "A", payload(3000), 1400);
  auto b = fragments(2, "B", payload(3000), 1400);
  r.feed(7, a[0].data(), a[0].size(), &m);  // a[1], a[2] lost
  for (auto& p : b) r.feed(7, p.data(), p.size(), &m);
  EXPECT_EQ(m.channel, "B");
  EXPECT_EQ(r.incomplete(), 1);
}

TEST(LcmWire, GarbageIsCountedNotCrashing) {
  Reassembler r;
  Message m;
  const std::vector<uint8_t> junk = {1, 2, 3};
  EXPECT_FALSE(r.feed(1, junk.data(), junk.size(), &m));
  std::vector<uint8_t> no_nul;
  put32(no_nul, kMagicShort);
  put32(no_nul, 1);
  no_nul.push_back('X');
  EXPECT_FALSE(r.feed(1, no_nul.data(), no_nul.size(), &m));
  auto f = fragments(3, "C", payload(3000), 1400);
  f[1][12] = 0xFF;  // fragment offset (bytes 12-15, big-endian) far beyond the message
  EXPECT_FALSE(r.feed(1, f[1].data(), f[1].size(), &m));
  EXPECT_EQ(r.malformed(), 3);
}

// Found by fuzz_lcm_wire: a fragmented message announcing 0 bytes made memcpy copy 0 bytes into a null
// buffer (undefined behaviour, reported by the sanitizer build). It completes as an empty message.
TEST(LcmWire, EmptyFragmentedMessage) {
  Reassembler r;
  Message m;
  const auto f = fragments(9, "EXO_STATE", {}, 100);
  ASSERT_TRUE(f.empty());  // the helper makes no fragment for no data: build the single one by hand
  std::vector<uint8_t> p;
  put32(p, kMagicLong);
  put32(p, 9);
  put32(p, 0);  // size
  put32(p, 0);  // offset
  put16(p, 0);  // index
  put16(p, 1);  // count
  for (char c : std::string("EXO_STATE")) p.push_back(static_cast<uint8_t>(c));
  p.push_back(0);
  ASSERT_TRUE(r.feed(1, p.data(), p.size(), &m));
  EXPECT_EQ(m.channel, "EXO_STATE");
  EXPECT_TRUE(m.data.empty());
  EXPECT_EQ(r.malformed(), 0);
}

}  // namespace
}  // namespace exoid::lcmwire
