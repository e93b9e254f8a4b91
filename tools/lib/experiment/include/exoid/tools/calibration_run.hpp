#pragma once
// A calibration run (`exoid calibrate`, docs/diagnose.md "Calibration run"): the simulated exoskeleton with its
// pelvis held in a harness (sim::Harness), the legs swinging through large angles under the computed-torque law
// of controller/leg_swing.hpp, in process (sim and drive law in one loop, no LCM traffic), written to an LCM log
// in the format of `exoid experiment` (EXO_STATE, EXO_PLATE_RIGHT/LEFT, EXO_TRUTH, EXO_COMMAND), so that
// `exoid diagnose --calibration LOG` (and `exoid export`) read it like any run.
#include <cstdint>
#include <string>

#include "exoid/controller/leg_swing.hpp"
#include "exoid/model/model.hpp"
#include "exoid/sim/config.hpp"

namespace exoid::tools {

struct CalibrationRunOptions {
  std::string mjcf;             ///< simulated robot (config/exo.xml)
  std::string log_path;         ///< LCM log written (overwritten)
  double duration_s = 40.0;     ///< s of simulated time
  controller::LegSwingOptions swing;
};

struct CalibrationRunResult {
  int64_t ticks = 0;
  double base_drift_m = 0.0;        ///< largest distance of the pelvis from its start position
  double base_tilt_rad = 0.0;       ///< largest rotation of the pelvis from its start orientation
  double tracking_rms_rad = 0.0;    ///< RMS of q_d - q over the actuated joints and ticks (ground truth)
  double tracking_max_rad = 0.0;
  double plate_force_max_n = 0.0;   ///< largest |force| either plate read (ground contact: the feet must stay free)
  Eigen::VectorXd q_min, q_max;     ///< [nj] range each joint swept (ground truth)
  long mujoco_warnings = 0, clamped_commands = 0;
  long events = 0;                  ///< written to the log
};

/// Runs the calibration of `scenario` (its effects and noise; the harness is switched on with its lift, the
/// default 0.2 m when the file has none) with the joint torques of `model` (the declared URDF: the drives'
/// computed torque). False with *error on a load failure, a log that cannot be written, or a run in which a
/// foot touched a plate (then the swing is too wide for the lift).
bool runCalibration(const Model& model, const sim::Scenario& scenario, const sim::SensorConfig& noise,
                    const CalibrationRunOptions& options, CalibrationRunResult& result, std::string* error);

}  // namespace exoid::tools
