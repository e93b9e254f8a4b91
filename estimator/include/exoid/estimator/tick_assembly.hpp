#pragma once
// The tick assembly, written once: groups the messages of one control tick (state, right plate, left plate,
// truth: whichever channels the user feeds) and releases the ticks in tick order, complete or declared
// incomplete. The offline intake (intake::streamRunLog, window kLogLagWindow), alignByTick (the same window,
// over a run already decoded) and the online estimator (window 0) all assemble with it.
// Real-time safe: fixed capacity chosen at construction, no allocation after it, no exception.
#include <array>
#include <cstdint>
#include <vector>

namespace exoid::estimator {

/// Channels of a tick (bit i of a mask is channel i).
enum TickChannel { kTickState = 0, kTickPlateRight = 1, kTickPlateLeft = 2, kTickTruth = 3, kTickChannels = 4 };

/// Ticks a channel may lag behind the newest tick before an older tick is declared incomplete, for recorded
/// logs (LCM's logger writes each channel as it arrives; 200 ms at 1 kHz covers any publisher's jitter).
constexpr long kLogLagWindow = 200;

/// What became of one message offered to the assembly.
enum class TickPlacement {
  Accepted,    ///< held in its tick's slot (slot index returned)
  Duplicate,   ///< this channel already gave this tick (the first message is kept)
  OutOfOrder,  ///< its tick was already released or dropped, lies more than the window behind the newest, or < 0
  Overflow,    ///< a new tick, but every slot is held (capacity < window + 2, or release() not called)
};

/// Counts since construction (or restart()); exact, each message or tick counted once.
struct TickAssemblyCounts {
  long accepted = 0;       ///< messages held
  long duplicates = 0;     ///< messages refused as Duplicate
  long out_of_order = 0;   ///< messages refused as OutOfOrder
  long overflow = 0;       ///< messages refused as Overflow
  long complete = 0;       ///< ticks released with every needed channel
  long incomplete = 0;     ///< ticks dropped: a needed channel still missing when the window closed (or at flush)
};

/// One tick leaving the assembly. `slot` indexes the user's payload storage (valid until the next place()).
struct ReleasedTick {
  int64_t tick = -1;
  int slot = -1;
  unsigned present = 0;  ///< mask of the channels that gave this tick
  bool complete = false;
};

class TickAssembly {
 public:
  /// needed: mask of the channels a complete tick has; window >= 0 (see kLogLagWindow; 0: a newer tick closes
  /// every older one); capacity: slots (ticks held at once), window + 2 never overflows when release() is
  /// drained after each place(). Allocates here only.
  TickAssembly(unsigned needed, long window, int capacity);

  /// Where a message of `channel` for `tick` would go; changes nothing (lets a caller check order before the
  /// message's values, as the gate does).
  TickPlacement check(int channel, int64_t tick) const;
  /// check(), then on Accepted holds it: *slot is where the caller stores the payload. Counted either way.
  TickPlacement place(int channel, int64_t tick, int* slot);
  /// Next tick to leave, in tick order: the oldest held tick if it is complete, or if it is more than the
  /// window behind the newest (or `flush`: end of input) — then incomplete. False when none may leave yet.
  bool release(ReleasedTick& out, bool flush = false);

  /// Resumes as if `tick` had been accepted on every channel and released (a checkpoint restart): older
  /// ticks and `tick` itself are refused; the counts are set to `counts`.
  void restart(int64_t tick, const TickAssemblyCounts& counts);

  const TickAssemblyCounts& counts() const { return counts_; }
  int capacity() const { return static_cast<int>(slots_.size()); }
  long window() const { return window_; }

 private:
  struct Slot {
    int64_t tick = -1;
    unsigned present = 0;
  };
  int find(int64_t tick) const;  // slot holding `tick`, or -1

  unsigned needed_;
  long window_;
  std::vector<Slot> slots_;
  std::vector<int> order_;  // [held_] slots of the held ticks, oldest first (few are held: linear is fast)
  std::vector<int> free_;   // [capacity] free slots, a stack of free_count_
  int held_ = 0, free_count_ = 0;
  int64_t newest_ = -1;         // newest tick accepted (-1: none)
  int64_t last_released_ = -1;  // newest tick released or dropped (-1: none)
  std::array<int64_t, kTickChannels> last_{{-1, -1, -1, -1}};  // newest tick accepted per channel
  TickAssemblyCounts counts_;
};

}  // namespace exoid::estimator
