// controllerFrame: where the controller's world puts the soles (docs/controller.md "Base state observer").
#include <algorithm>
#include <array>

#include "exoid/controller/base_state_observer.hpp"
#include "exoid/tools/experiment_run.hpp"

namespace exoid::tools {

ControllerFrame controllerFrame(const Model& controller_model, const controller::ControllerConfig& cc,
                                const std::vector<RobotStateSample>& states) {
  ControllerFrame frame;
  frame.latch_tick = cc.observer.latch_ticks - 1;  // the run's states start at tick 0
  frame.base_xy = cc.observer.initial_base_xy;
  frame.ground_height = cc.observer.ground_height;
  std::array<controller::SoleFrame, 2> soles;
  controller::SoleFrame imu;
  if (!controller::resolveObserverFrames(controller_model, cc.contact, soles, imu, nullptr)) return frame;
  controller::BaseStateObserver observer(controller_model, cc.observer, cc.loop.period, soles, imu);
  std::vector<const RobotStateSample*> order;
  order.reserve(states.size());
  for (const RobotStateSample& s : states) order.push_back(&s);
  std::stable_sort(order.begin(), order.end(), [](const auto* a, const auto* b) { return a->tick < b->tick; });
  int64_t last = 0;
  bool first = true;
  for (const RobotStateSample* s : order) {
    if (!first && s->tick <= last) continue;  // a repeated tick: the controller refuses it
    observer.update(*s, first ? 1 : s->tick - last);
    first = false;
    last = s->tick;
    if (observer.latched()) {
      for (int f = 0; f < 2; ++f) frame.sole_xy[f] = observer.solePosition(f).head<2>();
      frame.has_soles = true;
      break;
    }
  }
  return frame;
}

}  // namespace exoid::tools
