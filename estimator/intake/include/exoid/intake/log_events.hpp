#pragma once
// The one reader of lcm-logger files (docs/data-formats.md "Run logs"): every byte is accounted for. The file
// is mapped and walked event by event; an event is framed by LCM's header (sync word 0xEDA1DA01, event number,
// timestamp, channel length, data length, all big-endian) and is valid when its lengths are possible (channel
// 1..256 bytes of printable ASCII, data 0..64 MiB) and it lies inside the file. A damaged stretch (bad sync
// word, impossible lengths) is skipped up to the next valid event and counted; a last event that runs past
// the end of the file is a cut-off tail. LCM's own reader (lcm_eventlog_read_next_event) stops silently at
// the first damaged event, or trusts a damaged length (a 2 GiB allocation, then a crash).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace exoid::intake {

/// One event, pointing into the mapped file (valid during the sink's call only).
struct LogEvent {
  const char* channel;
  int32_t channel_length;
  const uint8_t* data;
  int32_t data_length;
  int64_t offset;  ///< byte offset of its sync word
};

/// Damage to a log's framing. Bytes: [0, readable_end) framed (valid events and skipped stretches),
/// [readable_end, file_bytes) a cut-off tail when truncated.
struct LogDamage {
  long events = 0;                    ///< valid events
  long corrupt_events = 0;            ///< damaged stretches skipped (each held at least one event)
  long corrupt_bytes = 0;             ///< bytes in them
  int64_t first_corrupt_offset = -1;  ///< byte offset of the first one
  bool truncated = false;             ///< the file ends inside an event (cut off while being written)
  int64_t readable_end = 0;           ///< byte offset where the last complete valid event ends
  int64_t file_bytes = 0;

  bool intact() const { return corrupt_events == 0 && !truncated; }
};

/// Called for each valid event in file order; false stops the walk.
using LogEventSink = std::function<bool(const LogEvent&)>;

/// Frames `size` bytes of a log (file contents) and hands on its valid events. Returns false when the sink
/// stopped the walk.
bool frameLogEvents(const uint8_t* bytes, size_t size, const LogEventSink& sink, LogDamage& damage);

/// Maps the file and frames it (frameLogEvents). False with *error ("cannot open ..." or "... holds no LCM
/// events") when it cannot be read or holds no valid event; a stopped walk is not an error here.
bool readLogEvents(const std::string& path, const LogEventSink& sink, LogDamage& damage, std::string* error);

/// Text quoted from a (possibly damaged) message as one line of plain ASCII: other bytes as \xNN.
std::string printable(const std::string& text);

/// One line on the damage ("" when nothing is wrong): damaged stretches (count, bytes, first bad byte), events
/// the adapters rejected (count, the first's reason), a cut-off tail, and where the readable part ends (byte of
/// the file, last tick read when last_tick >= 0).
std::string damageReport(const LogDamage& damage, long rejected, const std::string& first_rejection, int64_t last_tick);

}  // namespace exoid::intake
