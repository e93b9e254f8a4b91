#pragma once
// The gate's order rule, written once: where a message's tick stands against the last tick its channel
// accepted. MessageGate (lcmtypes/adapters: the LCM receivers) and the tick assembly (tick_assembly.hpp:
// streamRunLog, alignByTick, OnlineEstimator::admit) both decide a channel's Duplicate with it. Real-time safe: no allocation, no exception.
#include <cstdint>

namespace exoid {

enum class TickOrder {
  Newer,      ///< after the last accepted tick (or none accepted yet): in order; skipped ticks are allowed
  Duplicate,  ///< the last accepted tick again
  Older,      ///< before the last accepted tick
};

/// Order of `tick` on a channel whose last accepted tick is `last` (has_last false: none yet).
constexpr TickOrder tickOrder(bool has_last, int64_t last, int64_t tick) {
  return !has_last || tick > last ? TickOrder::Newer : tick == last ? TickOrder::Duplicate : TickOrder::Older;
}

}  // namespace exoid
