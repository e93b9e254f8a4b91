#pragma once
// exo_controller's loop over LCM (the thin main parses options; this is the library part): EXO_STATE (tick k)
// through a MessageGate -> BalanceController::tick -> EXO_COMMAND (tick k + 1) and EXO_CONTROLLER_STATUS, every
// tick, inside the receive callback (allocation-free after construction). A state that fails the checks with a
// new tick is answered by the fallback command; duplicate and out-of-order states are counted, not answered.
// EXO_ESTIMATE goes to BalanceController::setEstimate, the plates to its disturbance observer (when configured).
// Lockstep (wait_estimate_ms > 0): the state of tick k is answered only once an estimate with tick >= k -
// estimate.lag_ticks has arrived (LCM keeps the order, so every estimate the controller applies at tick k is in);
// the plates arriving meanwhile are held and given after the answer, as without the wait. A wait that times out
// ends the waiting for the rest of the run (counted, said once: the run is no longer reproducible).
// On udpm:// EXO_ESTIMATE comes from the node's own socket (lcmwire::UdpmReceiver, 64 MiB kernel buffer), not
// through LCM's receive path, whose default buffer lost bursts of estimates in lockstep runs (sim/src/plugin_link.hpp).
#include <chrono>
#include <csignal>
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/lcm_endpoint.hpp>
#include <exoid/lcm/message_gate.hpp>
#include <memory>
#include <string>
#include <vector>

#include "lcm_wire.hpp"

#include "exoid/controller/balance_controller.hpp"

namespace exoid::controller {

/// What the summary line reports (no allocation per tick).
struct ControllerNodeStats {
  long long ticks = 0, answered_bad = 0, unanswered = 0, publish_errors = 0;
  long long estimate_waits = 0;     ///< states whose estimate had not arrived yet (answered after a wait)
  double estimate_wait_s = 0.0;     ///< wall seconds those states waited
  long long estimate_timeouts = 0;  ///< waits that ended without it (then no more waiting)
  long long estimate_wait_stopped_tick = -1;  ///< the state tick of that timeout
  double se_com = 0.0, max_com_err = 0.0, tick_sum = 0.0, tick_max = 0.0;
  long long com_samples = 0;  ///< ticks of the CoM moves under torque control (the RMSE's samples)
};

class ControllerNode {
 public:
  /// Subscribes on `lcm`; `ctrl` (built on `model` with `config`) and `lcm` must outlive the node.
  /// wait_estimate_ms > 0 (lockstep, with use_estimate): the wait for the estimate above, at most this long.
  ControllerNode(LcmEndpoint& lcm, const Model& model, BalanceController& ctrl, const ControllerConfig& config,
                 bool use_estimate, int wait_estimate_ms = 0);
  ControllerNode(const ControllerNode&) = delete;
  ControllerNode& operator=(const ControllerNode&) = delete;

  /// Why run() returned.
  enum class Outcome { Done, Interrupted, IdleTimeout, LcmError };
  /// Receives and answers until the trajectory and its final hold are over (or it failed), *stop is set, or no
  /// state arrived for idle_timeout_ms (reported on stderr); LCM errors are reported on stderr.
  Outcome run(int64_t idle_timeout_ms, const volatile std::sig_atomic_t* stop);

  const ControllerStatus& status() const { return status_; }
  const ControllerNodeStats& stats() const { return stats_; }

 private:
  void answer(const RobotStateSample& s);
  void onState(const void* data, int size);
  void onEstimate(const void* data, int size);
  /// Waits up to timeout_ms for a message on LCM or the own socket and dispatches what both hold. < 0: failure.
  int receive(int timeout_ms);
  // The lockstep wait for the estimate:
  /// The state of tick k must wait: no estimate with tick >= k - lag_ticks yet (and still waiting at all).
  bool mustWait(int64_t tick) const;
  /// Answers the held state, then gives the plates held meanwhile.
  void answerHeld();
  /// Called by run(): a held state waiting longer than wait_estimate_ms is answered and the waiting ends.
  void checkWaitTimeout();

  LcmEndpoint& lcm_;
  BalanceController& ctrl_;
  const ControllerConfig& config_;
  const std::vector<std::string>& joint_names_;
  std::vector<std::string> param_names_, coord_names_;
  MessageGate gate_;
  int ch_state_ = 0, ch_estimate_ = 0, ch_plate_[2] = {0, 0};
  RobotStateSample state_, bad_state_;
  EstimatorOutputSample estimate_;
  ForcePlateSample plate_;
  exoid_lcm::force_plate_t plate_msg_;
  exoid_lcm::robot_state_t state_msg_;
  exoid_lcm::estimator_output_t estimate_msg_;
  exoid_lcm::joint_command_t command_msg_;
  exoid_lcm::controller_status_t status_msg_;
  JointCommandSample command_;
  ControllerStatus status_;
  ControllerNodeStats stats_;
  std::string err_;
  int reported_ = 0;  ///< rejected states reported on stderr (the first few)
  std::unique_ptr<lcmwire::UdpmReceiver> estimate_rx_;  ///< EXO_ESTIMATE's own socket (udpm://)
  lcmwire::UdpmReceiver::Handler estimate_handler_;
  int wait_estimate_ms_ = 0;
  int64_t newest_estimate_tick_ = -1;  ///< of the estimates received (decoded, names checked)
  bool holding_ = false;               ///< held_state_ waits for its estimate
  RobotStateSample held_state_;
  bool plate_held_[2] = {false, false};
  ForcePlateSample held_plate_[2];
  std::chrono::steady_clock::time_point held_since_;
  bool done_ = false;
  std::chrono::steady_clock::time_point last_state_ = std::chrono::steady_clock::now();
};

}  // namespace exoid::controller
