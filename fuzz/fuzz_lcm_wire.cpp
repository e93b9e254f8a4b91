// Reassembly of LCM UDP datagrams (exoid_logger's receive side) from arbitrary datagrams. Input: records
// [sender: 1 byte][length: 2 bytes big-endian][datagram]. Properties: no memory error on any datagram
// sequence (each datagram is an exact-size copy, so a read past its end is caught); counters stay >= 0.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "fuzz_support.hpp"
#include "lcm_wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  exoid::lcmwire::Reassembler reassembler;
  exoid::lcmwire::Message message;
  size_t pos = 0;
  while (size - pos >= 3) {
    const uint64_t sender = data[pos];
    const size_t len = std::min<size_t>((size_t{data[pos + 1]} << 8) | data[pos + 2], size - pos - 3);
    pos += 3;
    // A copy of exactly `len` bytes, so that reading past the datagram is an ASan error.
    const std::vector<uint8_t> datagram(data + pos, data + pos + len);
    pos += len;
    reassembler.feed(sender, datagram.data(), datagram.size(), &message);
  }
  EXOID_FUZZ_CHECK(reassembler.incomplete() >= 0 && reassembler.malformed() >= 0, "counters are non-negative");
  return 0;
}
