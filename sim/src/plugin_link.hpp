#pragma once
// The LCM side of the plugin stage inside runSim (private to exoid_sim_runner): after each simStep it runs
// the plugin (state, then force plates), publishes its command (EXO_COMMAND) and status (EXO_CONTROLLER_STATUS) on the controller's
// ticks, and hands the command to the arbiter; EXO_ESTIMATE (through a MessageGate, names checked against
// the plugin's URDF) goes to the plugin's set_estimate. Allocation-free per tick once constructed (a fragmented
// EXO_ESTIMATE reassembled from the raw socket allocates, at the estimator's rate).
// On udpm:// the estimates come from the link's own socket (lcmwire::UdpmReceiver, 64 MiB kernel buffer), not
// through LCM's receive path: the loop's LCM socket, with the default buffer, lost bursts of estimates in lockstep
// (4 in a row), which the lockstep wait for the estimate cannot tell from estimates that never came.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "exoid/lcm/lcm_endpoint.hpp"
#include "lcm_wire.hpp"
#include "exoid/lcm/message_gate.hpp"
#include "exoid/sim/command.hpp"
#include "exoid/sim/controller_plugin.hpp"

namespace exoid::sim {

class PluginLink {
 public:
  /// Setup (allocates; loads the plugin's URDF for the parameter names of EXO_ESTIMATE).
  PluginLink(ControllerPlugin& plugin, LcmEndpoint& ep, const std::vector<std::string>& joint_names);
  ~PluginLink();
  PluginLink(const PluginLink&) = delete;
  PluginLink& operator=(const PluginLink&) = delete;

  /// After simStep of tick k: plugin stage, the plates of tick k [EXOID_PLUGIN_NUM_PLATES] to the plugin,
  /// publishing, arbiterOffer(command for k + 1). False on an LCM failure (*err).
  bool afterStep(const RobotStateSample& state, const ForcePlateSample* plates, CommandArbiter& arb,
                 std::string* err);
  /// Subscribed to EXO_ESTIMATE through the endpoint (else the loop has nothing to receive from LCM).
  bool listening() const { return subscription_ > 0; }
  /// Takes EXO_ESTIMATE at all (through the endpoint or its own socket).
  bool takesEstimates() const { return subscription_ > 0 || receiver_ != nullptr; }
  /// The own socket's descriptor (-1: none), and handing over what it holds. drain: false on a poll failure.
  int rawFd() const { return receiver_ ? receiver_->fd() : -1; }
  bool drain(std::string* err);
  /// The newest tick of the estimates received (decoded, names checked; -1 before the first): LCM on one host
  /// keeps the order, so every estimate up to it has been received (the lockstep wait, runner.cpp).
  int64_t newestEstimateTick() const { return newest_estimate_tick_; }
  /// The most CPU time (the loop thread's) one plugin call took, host stage included, us: against its wall time
  /// (PluginStats::call_us_max) it tells a slow call from a preempted one.
  double callCpuUsMax() const { return call_cpu_ns_max_ * 1e-3; }

 private:
  ControllerPlugin& plugin_;
  LcmEndpoint& ep_;
  const std::vector<std::string>& joint_names_;
  std::vector<std::string> param_names_, coord_names_;
  MessageGate gate_;
  int subscription_ = 0;
  int64_t newest_estimate_tick_ = -1;
  std::unique_ptr<lcmwire::UdpmReceiver> receiver_;
  lcmwire::UdpmReceiver::Handler raw_handler_;
  void onEstimate(const void* data, int size);
  EstimatorOutputSample estimate_;
  exoid_lcm::estimator_output_t estimate_msg_;
  exoid_lcm::joint_command_t command_msg_;
  exoid_lcm::controller_status_t status_msg_;
  int64_t call_cpu_ns_max_ = 0;
};

}  // namespace exoid::sim
