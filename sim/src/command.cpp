#include "exoid/sim/command.hpp"

namespace exoid::sim {

void arbiterInit(CommandArbiter& arb, const SimModel& model, int hold_ticks) {
  arb = CommandArbiter();
  arb.latest = simZeroCommand(model);
  arb.zero = simZeroCommand(model);
  arb.hold_ticks = hold_ticks < 0 ? 0 : hold_ticks;
}

void arbiterOffer(CommandArbiter& arb, const JointCommandSample& command) {
  arb.latest = command;  // same sizes: Eigen copies in place
  arb.has_latest = true;
  ++arb.received;
}

bool arbiterHasFresh(const CommandArbiter& arb, int64_t tick) { return arb.has_latest && arb.latest.tick >= tick; }

const JointCommandSample& arbiterSelect(CommandArbiter& arb, int64_t tick) {
  if (tick == 0 && !arbiterHasFresh(arb, tick)) return arb.zero;  // initial command
  if (arbiterHasFresh(arb, tick)) {
    arb.stale_run = 0;
    ++arb.fresh_ticks;
    return arb.latest;
  }
  ++arb.stale_run;
  if (arb.has_latest && arb.stale_run <= arb.hold_ticks) {
    ++arb.held_ticks;
    return arb.latest;
  }
  ++arb.zero_ticks;
  return arb.zero;
}

}  // namespace exoid::sim
