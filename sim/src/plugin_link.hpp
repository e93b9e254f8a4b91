#pragma once
// The LCM side of the plugin stage inside runSim (private to exoid_sim_runner): after each simStep it runs
// the plugin (state, then force plates), publishes its command (EXO_COMMAND) and status (EXO_CONTROLLER_STATUS) on the controller's
// ticks, and hands the command to the arbiter; EXO_ESTIMATE (through a MessageGate, names checked against
// the plugin's URDF) goes to the plugin's set_estimate. Allocation-free per tick once constructed.
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/lcm/lcm_endpoint.hpp"
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
  /// Subscribed to EXO_ESTIMATE (else the loop has nothing to receive).
  bool listening() const { return subscription_ > 0; }
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
  EstimatorOutputSample estimate_;
  exoid_lcm::estimator_output_t estimate_msg_;
  exoid_lcm::joint_command_t command_msg_;
  exoid_lcm::controller_status_t status_msg_;
  int64_t call_cpu_ns_max_ = 0;
};

}  // namespace exoid::sim
