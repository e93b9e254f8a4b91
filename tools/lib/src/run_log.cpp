#include "exoid/tools/run_log.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/safe_decode.hpp"

namespace exoid::tools {

namespace {
// lcm-logger event framing (LCM's eventlog.c): big-endian sync word, event number (i64), timestamp (i64),
// channel length (i32), data length (i32), channel bytes, data bytes.
constexpr uint32_t kSync = 0xEDA1DA01u;
constexpr size_t kHeader = 4 + 8 + 8 + 4 + 4;
constexpr int32_t kMaxChannel = 256;          // LCM limits channel names to 63 characters; be generous
constexpr int32_t kMaxData = 64 * 1024 * 1024;  // far above any exoid message (a few kB)

uint32_t be32(const uint8_t* p) { return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | p[3]; }

struct Event {
  const char* channel;
  int32_t channellen;
  const uint8_t* data;
  int32_t datalen;
};

enum class Frame { Ok, Bad, Short };
// Checks the event starting at `at` (its sync word already matched). Short: the header or body runs past the
// end of the file (a truncated tail, or a damaged length); Bad: impossible lengths or a non-printable channel.
Frame frameAt(const uint8_t* b, size_t size, size_t at, Event* e, size_t* end) {
  if (size - at < kHeader) return Frame::Short;
  const int32_t clen = static_cast<int32_t>(be32(b + at + 20));
  const int32_t dlen = static_cast<int32_t>(be32(b + at + 24));
  if (clen <= 0 || clen > kMaxChannel || dlen < 0 || dlen > kMaxData) return Frame::Bad;
  const size_t total = kHeader + static_cast<size_t>(clen) + static_cast<size_t>(dlen);
  if (size - at < total) return Frame::Short;
  const char* ch = reinterpret_cast<const char*>(b + at + kHeader);
  for (int32_t i = 0; i < clen; ++i)
    if (ch[i] < 0x21 || ch[i] > 0x7e) return Frame::Bad;
  *e = {ch, clen, b + at + kHeader + clen, dlen};
  *end = at + total;
  return Frame::Ok;
}

// Offset of the next sync word that starts a complete valid event, at or after `from`; `size` if none.
size_t nextValidEvent(const uint8_t* b, size_t size, size_t from) {
  Event e;
  size_t end = 0;
  for (size_t i = from; i + 4 <= size; ++i)
    if (be32(b + i) == kSync && frameAt(b, size, i, &e, &end) == Frame::Ok) return i;
  return size;
}

// A reason quotes bytes from the (possibly damaged) message: keep the report one line of plain text.
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

template <class Msg, class Sample, class Convert>
void take(const Event& e, const std::string& channel, std::vector<Sample>& out, RunLog& log, Convert convert) {
  Msg msg;
  Sample sample;
  std::string why;
  if (!safeDecode(e.data, e.datalen, msg)) {
    why = "undecodable bytes";
  } else if (convert(msg, sample, &why)) {
    log.last_tick = std::max<int64_t>(log.last_tick, sample.tick);
    out.push_back(std::move(sample));
    return;
  }
  ++log.rejected;
  if (log.first_rejection.empty()) log.first_rejection = printable(channel + ": " + why);
}

void dispatch(const Event& e, const std::vector<std::string>& joints, RunLog& log) {
  const std::string channel(e.channel, static_cast<size_t>(e.channellen));
  ++log.events[channel];
  if (channel == channels::kState) {
    take<exoid_lcm::robot_state_t>(e, channel, log.states, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
  } else if (channel == channels::kPlateRight || channel == channels::kPlateLeft) {
    const int plate = channel == channels::kPlateRight ? 0 : 1;
    take<exoid_lcm::force_plate_t>(e, channel, log.plates[plate], log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, plate, s, w); });
  } else if (channel == channels::kTruth) {
    take<exoid_lcm::ground_truth_t>(e, channel, log.truth, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
  } else if (channel == channels::kCommand) {
    take<exoid_lcm::joint_command_t>(e, channel, log.commands, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, joints, s, w); });
  } else if (channel == channels::kControllerStatus) {
    take<exoid_lcm::controller_status_t>(e, channel, log.status, log, [&](auto& m, auto& s, auto* w) { return fromLcm(m, s, w); });
  } else if (channel == channels::kEstimate) {
    // The reader does not know the estimator's model: the message is checked against its own names (sizes
    // agree, values valid); the summary checks the parameter count against its model.
    take<exoid_lcm::estimator_output_t>(e, channel, log.estimates, log, [&](auto& m, auto& s, auto* w) {
      return fromLcm(m, m.param_names, kAnyNumBase, m.coord_names, s, w);
    });
  } else {
    ++log.unknown_channel;
  }
}
}  // namespace

std::string RunLog::damageReport() const {
  if (intact()) return "";
  std::string r;
  auto add = [&](const std::string& s) { r += (r.empty() ? "" : "; ") + s; };
  if (corrupt_events > 0)
    add(std::to_string(corrupt_events) + " damaged stretch" + (corrupt_events == 1 ? "" : "es") + " skipped (" +
        std::to_string(corrupt_bytes) + " bytes, first at byte " + std::to_string(first_corrupt_offset) + ")");
  if (rejected > 0) add(std::to_string(rejected) + " events rejected (first: " + first_rejection + ")");
  if (truncated) add("cut off: the last event is incomplete");
  add("readable part ends at byte " + std::to_string(readable_end) + " of " + std::to_string(file_bytes) +
      (last_tick >= 0 ? ", tick " + std::to_string(last_tick) : std::string()));
  return r;
}

bool readRunLog(const std::string& path, const std::vector<std::string>& joints, RunLog& log, std::string* error) {
  log = RunLog();
  const int fd = ::open(path.c_str(), O_RDONLY);
  struct stat st {};
  if (fd < 0 || ::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    if (error) *error = "cannot open LCM log '" + path + "'" + (fd < 0 ? std::string(": ") + std::strerror(errno) : "");
    if (fd >= 0) ::close(fd);
    return false;
  }
  const size_t size = static_cast<size_t>(st.st_size);
  log.file_bytes = static_cast<int64_t>(size);
  void* map = size > 0 ? ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0) : nullptr;
  ::close(fd);
  if (size > 0 && map == MAP_FAILED) {
    if (error) *error = "cannot read LCM log '" + path + "': " + std::strerror(errno);
    return false;
  }
  const uint8_t* b = static_cast<const uint8_t*>(map);
  long events = 0;
  size_t at = 0;
  auto skipTo = [&](size_t next) {
    ++log.corrupt_events;
    log.corrupt_bytes += static_cast<long>(next - at);
    if (log.first_corrupt_offset < 0) log.first_corrupt_offset = static_cast<int64_t>(at);
    at = next;
  };
  while (at < size) {
    Event e;
    size_t end = 0;
    const Frame f = size - at >= 4 && be32(b + at) == kSync ? frameAt(b, size, at, &e, &end) : Frame::Bad;
    if (f == Frame::Ok) {
      dispatch(e, joints, log);
      ++events;
      log.readable_end = static_cast<int64_t>(end);
      at = end;
      continue;
    }
    // Damaged here: resume at the next valid event; none left and the bytes could be the start of one: the
    // file was cut off in the middle of its last event.
    const size_t next = nextValidEvent(b, size, at + 1);
    if (next == size && (f == Frame::Short || size - at < 4)) {
      log.truncated = true;
      break;
    }
    skipTo(next);
  }
  if (map) ::munmap(map, size);
  if (events == 0) {
    if (error) *error = "'" + path + "' holds no LCM events (empty or not an LCM log)";
    return false;
  }
  return true;
}

}  // namespace exoid::tools
