// latchedControllerSoles: where the controller's world puts the soles (docs/controller.md "Base state observer").
#include <algorithm>
#include <array>

#include "exoid/controller/base_state_observer.hpp"
#include "exoid/tools/experiment_run.hpp"

namespace exoid::tools {

bool latchedControllerSoles(const Model& controller_model, const controller::ControllerConfig& cc,
                            const std::vector<RobotStateSample>& states, ControllerFrame& frame) {
  std::array<controller::SoleFrame, 2> soles;
  controller::SoleFrame imu;
  if (!controller::resolveSoleFrame(controller_model, cc.contact.right_sole_frame, soles[0], nullptr) ||
      !controller::resolveSoleFrame(controller_model, cc.contact.left_sole_frame, soles[1], nullptr))
    return false;
  if (controller_model.frameIndex("imu") >= 0) controller::resolveSoleFrame(controller_model, "imu", imu, nullptr);
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
      return true;
    }
  }
  return false;
}

}  // namespace exoid::tools
