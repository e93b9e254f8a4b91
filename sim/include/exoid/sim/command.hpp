#pragma once
// Which command the sim applies at tick k (transport-free, so it is tested without LCM).
//
// The arbiter keeps the latest VALID command (already admitted by the LCM MessageGate). At tick k:
//  - fresh:  the latest command is for tick >= k -> apply it;
//  - stale:  otherwise (late or missing): hold the latest valid command for up to hold_ticks consecutive
//            ticks, then apply zero torque until a fresh command arrives. Each stale tick is counted as
//            held or zeroed.
// Tick 0 applies the initial command (zero torque) and is not counted as stale: no state was out yet.
// Lockstep waits (bounded) for a fresh command before asking; realtime asks at the 1 kHz deadline.
#include <cstdint>

#include "exoid/samples.hpp"
#include "exoid/sim/sim.hpp"

namespace exoid::sim {

enum class SimMode { Lockstep, Realtime };

struct CommandArbiter {
  JointCommandSample latest;  ///< last valid command received ([nj] vectors sized once)
  JointCommandSample zero;    ///< zero torque ([nj])
  bool has_latest = false;
  int hold_ticks = 50;        ///< stale ticks on the held command before falling back to zero torque
  int64_t stale_run = 0;      ///< consecutive stale ticks so far
  // counters
  int64_t received = 0;       ///< commands offered
  int64_t fresh_ticks = 0;    ///< ticks that applied a fresh command
  int64_t held_ticks = 0;     ///< stale ticks that held the latest valid command
  int64_t zero_ticks = 0;     ///< stale ticks that applied zero torque
  int64_t fallbackTicks() const { return held_ticks + zero_ticks; }
};

/// Sizes the arbiter for `model` (allocates: setup only).
void arbiterInit(CommandArbiter& arb, const SimModel& model, int hold_ticks);
/// Records a valid command (sizes must match the model; no allocation).
void arbiterOffer(CommandArbiter& arb, const JointCommandSample& command);
/// True once a command for tick >= `tick` has been offered.
bool arbiterHasFresh(const CommandArbiter& arb, int64_t tick);
/// The command to apply at `tick` (see above); updates the counters. Allocation-free.
const JointCommandSample& arbiterSelect(CommandArbiter& arb, int64_t tick);

}  // namespace exoid::sim
