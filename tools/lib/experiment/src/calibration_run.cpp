#include "exoid/tools/calibration_run.hpp"

#include <lcm/eventlog.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/sim/sim.hpp"

namespace exoid::tools {

namespace {
// A foot resting on a plate would read ~200 N; the plates' noise is below 1 N.
constexpr double kContactForce = 5.0;

struct LogWriter {
  lcm_eventlog_t* log = nullptr;
  std::vector<uint8_t> buffer;
  long events = 0;
  bool failed = false;
  ~LogWriter() {
    if (log) lcm_eventlog_destroy(log);
  }
  template <class Msg>
  void write(const char* channel, const Msg& msg, int64_t utime) {
    const int size = msg.getEncodedSize();
    if (buffer.size() < static_cast<size_t>(size)) buffer.resize(static_cast<size_t>(size));
    if (msg.encode(buffer.data(), 0, size) != size) {
      failed = true;
      return;
    }
    lcm_eventlog_event_t e{};
    e.timestamp = utime;
    e.channellen = static_cast<int32_t>(std::strlen(channel));
    e.channel = const_cast<char*>(channel);
    e.datalen = size;
    e.data = buffer.data();
    if (lcm_eventlog_write_event(log, &e) != 0) failed = true;
    ++events;
  }
  /// One tick's five channels, in the format of `exoid experiment`.
  void writeTick(const sim::SimModel& sm, const sim::SimData& sd, const JointCommandSample& cmd) {
    const int64_t utime = sd.state.utime;
    toLcm(sd.state, sm.joint_names, state_msg);
    write(channels::kState, state_msg, utime);
    toLcm(sd.plates[0], plate_msg);
    write(channels::kPlateRight, plate_msg, utime);
    toLcm(sd.plates[1], plate_msg);
    write(channels::kPlateLeft, plate_msg, utime);
    toLcm(sd.truth, sm.joint_names, truth_msg);
    write(channels::kTruth, truth_msg, utime);
    toLcm(cmd, sm.joint_names, command_msg);
    write(channels::kCommand, command_msg, utime);
  }
  exoid_lcm::robot_state_t state_msg;
  exoid_lcm::force_plate_t plate_msg;
  exoid_lcm::ground_truth_t truth_msg;
  exoid_lcm::joint_command_t command_msg;
};

/// The run's figures, tick by tick: joint range, tracking error of the driven joints against the reference this
/// tick's command tracked, base drift and tilt from tick 0, the largest plate force.
struct Figures {
  CalibrationRunResult& res;
  double sse = 0.0;
  long nse = 0;
  Eigen::Vector3d p0 = Eigen::Vector3d::Zero();  ///< the pelvis at tick 0 (the truth's pose, recorded before the step)
  Eigen::Quaterniond R0 = Eigen::Quaterniond::Identity();
  void add(int64_t k, const sim::SimData& sd, const controller::LegSwingTrajectory& traj,
           const controller::LegSwingData& swing) {
    const Eigen::VectorXd& q = sd.truth.q;
    for (int j = 0; j < q.size(); ++j) {
      res.q_min[j] = std::min(res.q_min[j], q[j]);
      res.q_max[j] = std::max(res.q_max[j], q[j]);
      if (!traj.driven[static_cast<size_t>(j)]) continue;
      const double e = swing.qd[j] - q[j];
      sse += e * e, ++nse;
      res.tracking_max_rad = std::max(res.tracking_max_rad, std::abs(e));
    }
    if (k == 0) p0 = sd.truth.base_position, R0 = sd.truth.base_orientation;
    res.base_drift_m = std::max(res.base_drift_m, (sd.truth.base_position - p0).norm());
    res.base_tilt_rad =
        std::max(res.base_tilt_rad, Eigen::AngleAxisd(R0.conjugate() * sd.truth.base_orientation).angle());
    for (const ForcePlateSample& pl : sd.plates) res.plate_force_max_n = std::max(res.plate_force_max_n, pl.force.norm());
  }
};
}  // namespace

bool runCalibration(const Model& model, const sim::Scenario& scenario_in, const sim::SensorConfig& noise,
                    const CalibrationRunOptions& o, CalibrationRunResult& res, std::string* error) {
  auto fail = [&](const std::string& m) { return (error ? *error = m : std::string()), false; };
  if (!model.floating_base) return fail("a calibration run needs the exoskeleton's floating-base model");
  if (!(o.duration_s > 0.0 && o.duration_s <= 3600.0)) return fail("the calibration duration must be in (0, 3600] s");
  sim::Scenario scenario = scenario_in;
  scenario.harness.enabled = true;
  sim::SimModel sm;
  sim::SimData sd;
  std::string err;
  if (!sim::simLoad(o.mjcf, noise, scenario, sm, &err)) return fail(err);
  if (sm.joint_names != model.joint_names) return fail(o.mjcf + ": its joints are not the model's (same names, same order)");
  if (!sim::simMakeData(sm, sd, &err)) return fail(err);
  const int nj = sm.nj;
  Eigen::VectorXd q0(nj);
  for (int j = 0; j < nj; ++j) q0[j] = sm.qpos_init[static_cast<size_t>(sm.qpos_adr[static_cast<size_t>(j)])];
  controller::LegSwingTrajectory traj;
  if (!controller::makeLegSwingTrajectory(model, q0, o.swing, traj, &err)) return fail(err);
  controller::LegSwingData swing(model);

  LogWriter w;
  w.log = lcm_eventlog_create(o.log_path.c_str(), "w");
  if (!w.log) return fail("cannot write '" + o.log_path + "'");
  JointCommandSample cmd = sim::simZeroCommand(sm);
  cmd.tau_ff = Eigen::VectorXd::Zero(nj);
  Eigen::VectorXd q = q0, v = Eigen::VectorXd::Zero(nj);  // the drives' state: the last tick's (one tick late)
  const double dt = sm.m->opt.timestep;
  const int64_t ticks = static_cast<int64_t>(std::llround(o.duration_s / dt));
  res = CalibrationRunResult{};
  res.q_min = Eigen::VectorXd::Constant(nj, INFINITY);
  res.q_max = Eigen::VectorXd::Constant(nj, -INFINITY);
  Figures fig{res};
  for (int64_t k = 0; k < ticks; ++k) {
    const double t = static_cast<double>(k) * dt;
    controller::legSwingTorque(model, traj, swing, t, q, v, cmd.tau);
    cmd.tick = k;
    cmd.source_tick = k > 0 ? k - 1 : 0;
    cmd.utime = k * 1000;
    sim::simStep(sm, sd, cmd);
    q = sd.truth.q;
    v = sd.truth.v;
    fig.add(k, sd, traj, swing);
    w.writeTick(sm, sd, cmd);
    if (w.failed) return fail("writing '" + o.log_path + "' failed");
  }
  res.ticks = ticks;
  res.tracking_rms_rad = fig.nse > 0 ? std::sqrt(fig.sse / static_cast<double>(fig.nse)) : 0.0;
  res.mujoco_warnings = static_cast<long>(sd.stats.mujoco_warnings);
  res.clamped_commands = static_cast<long>(sd.stats.clamped_commands);
  res.events = w.events;
  if (res.plate_force_max_n > kContactForce)
    return fail("a foot touched a plate (" + std::to_string(res.plate_force_max_n) +
                " N): raise harness.lift or narrow the swing");
  return true;
}

}  // namespace exoid::tools
