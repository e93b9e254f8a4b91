#include "exoid/intake/log_events.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace exoid::intake {

namespace {
// lcm-logger event framing (LCM's eventlog.c): big-endian sync word, event number (i64), timestamp (i64),
// channel length (i32), data length (i32), channel bytes, data bytes.
constexpr uint32_t kSync = 0xEDA1DA01u;
constexpr size_t kHeader = 4 + 8 + 8 + 4 + 4;
constexpr int32_t kMaxChannel = 256;            // LCM limits channel names to 63 characters; be generous
constexpr int32_t kMaxData = 64 * 1024 * 1024;  // far above any exoid message (a few kB)

uint32_t be32(const uint8_t* p) { return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | p[3]; }

enum class Frame { Ok, Bad, Short };
// Checks the event starting at `at` (its sync word already matched). Short: the header or body runs past the
// end of the file (a truncated tail, or a damaged length); Bad: impossible lengths or a non-printable channel.
Frame frameAt(const uint8_t* b, size_t size, size_t at, LogEvent* e, size_t* end) {
  if (size - at < kHeader) return Frame::Short;
  const int32_t clen = static_cast<int32_t>(be32(b + at + 20));
  const int32_t dlen = static_cast<int32_t>(be32(b + at + 24));
  if (clen <= 0 || clen > kMaxChannel || dlen < 0 || dlen > kMaxData) return Frame::Bad;
  const size_t total = kHeader + static_cast<size_t>(clen) + static_cast<size_t>(dlen);
  if (size - at < total) return Frame::Short;
  const char* ch = reinterpret_cast<const char*>(b + at + kHeader);
  for (int32_t i = 0; i < clen; ++i)
    if (ch[i] < 0x21 || ch[i] > 0x7e) return Frame::Bad;
  *e = {ch, clen, b + at + kHeader + clen, dlen, static_cast<int64_t>(at)};
  *end = at + total;
  return Frame::Ok;
}

// Offset of the next sync word that starts a complete valid event, at or after `from`; `size` if none.
size_t nextValidEvent(const uint8_t* b, size_t size, size_t from) {
  LogEvent e;
  size_t end = 0;
  for (size_t i = from; i + 4 <= size; ++i)
    if (be32(b + i) == kSync && frameAt(b, size, i, &e, &end) == Frame::Ok) return i;
  return size;
}
}  // namespace

bool frameLogEvents(const uint8_t* b, size_t size, const LogEventSink& sink, LogDamage& damage) {
  damage = LogDamage();
  damage.file_bytes = static_cast<int64_t>(size);
  size_t at = 0;
  while (at < size) {
    LogEvent e;
    size_t end = 0;
    const Frame f = size - at >= 4 && be32(b + at) == kSync ? frameAt(b, size, at, &e, &end) : Frame::Bad;
    if (f == Frame::Ok) {
      ++damage.events;
      damage.readable_end = static_cast<int64_t>(end);
      at = end;
      if (!sink(e)) return false;
      continue;
    }
    // Damaged here: resume at the next valid event; none left and the bytes could be the start of one: the
    // file was cut off in the middle of its last event.
    const size_t next = nextValidEvent(b, size, at + 1);
    if (next == size && (f == Frame::Short || size - at < 4)) {
      damage.truncated = true;
      break;
    }
    ++damage.corrupt_events;
    damage.corrupt_bytes += static_cast<long>(next - at);
    if (damage.first_corrupt_offset < 0) damage.first_corrupt_offset = static_cast<int64_t>(at);
    at = next;
  }
  return true;
}

bool readLogEvents(const std::string& path, const LogEventSink& sink, LogDamage& damage, std::string* error) {
  damage = LogDamage();
  const int fd = ::open(path.c_str(), O_RDONLY);
  struct stat st {};
  if (fd < 0 || ::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    if (error) *error = "cannot open LCM log '" + path + "'" + (fd < 0 ? std::string(": ") + std::strerror(errno) : "");
    if (fd >= 0) ::close(fd);
    return false;
  }
  const size_t size = static_cast<size_t>(st.st_size);
  void* map = size > 0 ? ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0) : nullptr;
  ::close(fd);
  if (size > 0 && map == MAP_FAILED) {
    if (error) *error = "cannot read LCM log '" + path + "': " + std::strerror(errno);
    return false;
  }
  frameLogEvents(static_cast<const uint8_t*>(map), size, sink, damage);
  if (map) ::munmap(map, size);
  if (damage.events == 0) {
    if (error) *error = "'" + path + "' holds no LCM events (empty or not an LCM log)";
    return false;
  }
  return true;
}

std::string printable(const std::string& text) {
  std::string out;
  static const char hex[] = "0123456789abcdef";
  for (const unsigned char c : text) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

std::string damageReport(const LogDamage& d, long rejected, const std::string& first_rejection, int64_t last_tick) {
  if (d.intact() && rejected == 0) return "";
  std::string r;
  auto add = [&](const std::string& s) { r += (r.empty() ? "" : "; ") + s; };
  if (d.corrupt_events > 0)
    add(std::to_string(d.corrupt_events) + " damaged stretch" + (d.corrupt_events == 1 ? "" : "es") + " skipped (" +
        std::to_string(d.corrupt_bytes) + " bytes, first at byte " + std::to_string(d.first_corrupt_offset) + ")");
  if (rejected > 0) add(std::to_string(rejected) + " events rejected (first: " + first_rejection + ")");
  if (d.truncated) add("cut off: the last event is incomplete");
  add("readable part ends at byte " + std::to_string(d.readable_end) + " of " + std::to_string(d.file_bytes) +
      (last_tick >= 0 ? ", tick " + std::to_string(last_tick) : std::string()));
  return r;
}

}  // namespace exoid::intake
