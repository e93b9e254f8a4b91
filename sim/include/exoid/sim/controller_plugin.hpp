#pragma once
// The host side of the controller plugin ABI (interfaces/include/exoid/controller_plugin.h,
// docs/plugin.md): loads a plugin library (dlopen), checks its ABI, creates an instance, and runs it as a
// stage of the simulation loop. No LCM here (the runner publishes what this produces).
//
// Per physics tick k, after simStep: step(state_k). Every `divisor`-th tick the plugin's tick is called and
// its command for tick k + 1 is checked; in between, the last command is held (re-stamped for tick k + 1).
// A call that fails (error code, non-finite torque, wrong tick or mode, or longer than the time budget when
// one is set) is replaced by the fallback, counted: hold the last good torque for hold_ticks controller ticks,
// then damping (the simulator's drive damping) until the plugin answers well again. After step(state_k),
// setForcePlates(plates_k), every physics tick. Neither allocates nor throws (beyond what the plugin itself
// does: it runs in this process).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "exoid/controller_plugin.h"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::sim {

struct PluginOptions {
  std::string path;         ///< the plugin library (.so)
  std::string model_path;   ///< robot URDF given to the plugin ("" for none)
  std::string config_path;  ///< the plugin's configuration file ("" for none)
  uint64_t seed = 1;        ///< given to the plugin (balance: CoM move sequence)
  int moves = 0;            ///< given to the plugin (balance: number of moves, 0 = its configuration's)
  int divisor = 1;          ///< the plugin runs every `divisor` physics ticks: 1000 / divisor Hz
  double budget_us = 0.0;   ///< > 0: a call longer than this (wall clock) is discarded and counted
  int hold_ticks = 20;      ///< fallback: controller ticks on the last good torque before damping
  bool listen_estimate = true;  ///< feed EXO_ESTIMATE to the plugin's set_estimate (the runner subscribes)
};

struct PluginStats {
  int64_t calls = 0;           ///< plugin tick calls
  int64_t good = 0;            ///< calls whose command was applied
  int64_t failed = 0;          ///< calls that returned an error code
  int64_t non_finite = 0;      ///< calls with a NaN/Inf torque
  int64_t bad_output = 0;      ///< calls with a wrong tick, source tick, joint count or mode
  int64_t overruns = 0;        ///< calls longer than the budget (discarded only when a budget is set)
  int64_t hold_ticks = 0;      ///< controller ticks on the host's fallback: last good torque held
  int64_t damping_ticks = 0;   ///< controller ticks on the host's fallback: damping
  int64_t bad_status = 0;      ///< status samples with non-finite values or out-of-range fields (not published)
  int64_t estimates_accepted = 0, estimates_rejected = 0;  ///< set_estimate calls (none without the entry)
  int64_t plates_accepted = 0, plates_rejected = 0;  ///< set_force_plates calls (none without the entry)
  double call_us_max = 0.0, call_us_sum = 0.0;  ///< wall time of the tick calls
  int64_t fallbackTicks() const { return hold_ticks + damping_ticks; }
};

class ControllerPlugin {
 public:
  /// dlopen(options.path), ABI checks, create (allocates). nullptr and a one-line *err (naming the library
  /// and what is wrong) on failure. joint_names: the sample joint order; period_s: the physics period.
  static std::unique_ptr<ControllerPlugin> load(const PluginOptions& options,
                                                const std::vector<std::string>& joint_names, double period_s,
                                                std::string* err);
  ~ControllerPlugin();  ///< destroy, dlclose
  ControllerPlugin(const ControllerPlugin&) = delete;
  ControllerPlugin& operator=(const ControllerPlugin&) = delete;

  const char* name() const;
  const PluginOptions& options() const { return opt_; }
  /// The plugin's reset and the host stage's state (setup: may allocate).
  bool reset(std::string* err);

  /// The stage for physics tick k (state.tick = k). Returns true when the plugin ran this tick (its status
  /// is new). Afterwards command() is the command for tick k + 1. Allocation-free.
  bool step(const RobotStateSample& state);
  const JointCommandSample& command() const { return command_; }
  /// The plugin's last status (fallbacks include the host's fallback ticks). statusValid(): publishable.
  const ControllerStatusSample& status() const { return status_; }
  bool statusValid() const { return status_valid_; }
  /// The plugin reports its task over (balance: moves and final hold done).
  bool finished() const { return finished_; }
  /// The online estimate (EXO_ESTIMATE, in the plugin's model order) through set_estimate. False when the
  /// plugin has no set_estimate (not counted) or does not use this estimate (counted). Allocation-free.
  bool setEstimate(const EstimatorOutputSample& estimate);
  /// The force plates of physics tick k [num_plates = EXOID_PLUGIN_NUM_PLATES: right, left], after step(state_k)
  /// (process mode's EXO_STATE-then-EXO_PLATE_* order). False when the plugin has no set_force_plates
  /// (not counted) or refuses them (counted). Allocation-free.
  bool setForcePlates(const ForcePlateSample* plates, int num_plates);
  const PluginStats& stats() const { return stats_; }
  /// One line: calls, good, fallbacks by reason, call time.
  std::string formatStats() const;

 private:
  ControllerPlugin() = default;
  /// load's stages: dlopen and the ABI checks of the function table; create with the host's configuration.
  /// False and *what (one line) on failure.
  bool open(std::string* what);
  bool create(const std::vector<std::string>& joint_names, double period_s, std::string* what);
  /// step's stages: the plugin's tick on state k, timed and judged (true: its command may be applied; each
  /// refusal counted by reason); applying it; the host's counted fallback; reading the plugin's status.
  bool tickPlugin(const RobotStateSample& state);
  void acceptCommand();
  void fallback(int64_t k);
  void readStatus(int64_t utime, int64_t k);

  PluginOptions opt_;
  void* lib_ = nullptr;
  const exoid_controller_plugin_api* api_ = nullptr;
  void* self_ = nullptr;
  int nj_ = 0;
  exoid_plugin_state in_{};
  exoid_plugin_command out_{};
  exoid_plugin_status st_{};
  exoid_plugin_force_plate plates_[EXOID_PLUGIN_NUM_PLATES]{};
  JointCommandSample command_;    ///< [nj] what the host applies from tick k + 1
  JointCommandSample last_good_;  ///< [nj]
  bool has_good_ = false;
  int64_t bad_streak_ = 0;
  ControllerStatusSample status_;
  bool status_valid_ = false;
  bool finished_ = false;
  PluginStats stats_;
};

}  // namespace exoid::sim
