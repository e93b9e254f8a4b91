#include "exoid/tools/run_table.hpp"

#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/measurement.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/tools/state_columns.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::tools {

namespace {
const char* const kSides[2] = {"right", "left"};

using common::fail;

/// The columns both tables end with: tau_<actuated joint>, then fp_<side>_fx..nz.
void appendTauPlates(const Model& model, const std::vector<int>& actuated, std::vector<std::string>& h) {
  for (int j : actuated) h.push_back("tau_" + model.joint_names[j]);
  for (const char* side : kSides)
    for (const char* c : {"fx", "fy", "fz", "nx", "ny", "nz"}) h.push_back(std::string("fp_") + side + "_" + c);
}

/// --truth: the simulator's exact state, applied torques and contact wrenches on the feet, one row per message.
bool truthTable(const Model& model, const intake::RunLog& log, const ExportOptions& opt,
                const std::vector<int>& actuated, RunTable& table, std::string* error) {
  if (opt.filter_hz > 0.0) return fail(error, "--filter applies to sensor data only (the truth has exact derivatives)");
  if (log.truth.empty()) return fail(error, "the log has no ground-truth (EXO_TRUTH) messages");
  // A wearer's trunk (lumbar hinges) is in every message of a run or in none: a log that mixes both is not one run.
  const bool trunk = log.truth.front().has_trunk;
  for (const GroundTruthSample& t : log.truth)
    if (t.has_trunk != trunk)
      return fail(error, "EXO_TRUTH tick " + std::to_string(t.tick) + ": has_trunk " + (t.has_trunk ? "true" : "false") +
                             ", the log's first message " + (trunk ? "true" : "false") + " (two runs in one log?)");
  table.header = {"t"};
  for (const std::string& n : StateColumns::names(model, true)) table.header.push_back(n);
  appendTauPlates(model, actuated, table.header);
  for (const char* c : {"com_x", "com_y", "com_z"}) table.header.push_back(c);
  if (trunk)
    for (const char* g : {"trunk_angle_", "trunk_rate_", "trunk_com_"})
      for (const char* c : {"x", "y", "z"}) table.header.push_back(std::string(g) + c);
  for (const GroundTruthSample& t : log.truth) {
    std::vector<double> row{t.utime * 1e-6};
    StateColumns::write(model, stateFromTruth(model, t), row, true);
    for (int j : actuated) row.push_back(t.tau_applied[j]);
    for (int side = 0; side < 2; ++side) {
      row.insert(row.end(), {t.foot_force[side].x(), t.foot_force[side].y(), t.foot_force[side].z()});
      row.insert(row.end(), {t.foot_moment[side].x(), t.foot_moment[side].y(), t.foot_moment[side].z()});
    }
    row.insert(row.end(), {t.com.x(), t.com.y(), t.com.z()});
    if (trunk)
      for (const Eigen::Vector3d* v : {&t.trunk_angle, &t.trunk_rate, &t.trunk_com})
        row.insert(row.end(), {v->x(), v->y(), v->z()});
    table.rows.push_back(std::move(row));
  }
  return true;
}

/// The sensors table's header: q, (with a filter) v and a, the IMU, (with a filter) the base's angular
/// acceleration, the base's classical acceleration, torques and plates.
void sensorHeader(const Model& model, const std::vector<int>& actuated, bool derive, std::vector<std::string>& h) {
  h = {"t"};
  for (const std::string& j : model.joint_names) h.push_back("q_" + j);
  if (derive) {
    for (const std::string& j : model.joint_names) h.push_back("v_" + j);
    for (const std::string& j : model.joint_names) h.push_back("a_" + j);
  }
  for (const char* c : {"base_qw", "base_qx", "base_qy", "base_qz", "base_wx", "base_wy", "base_wz"}) h.push_back(c);
  if (derive) for (const char* c : {"base_dwx", "base_dwy", "base_dwz"}) h.push_back(c);
  for (const char* c : {"base_ax", "base_ay", "base_az"}) h.push_back(c);
  appendTauPlates(model, actuated, h);
}

/// Sensors: encoders, IMU, joint torque sensors, plates. Ticks missing a plate message are skipped.
bool sensorTable(const Model& model, const intake::RunLog& log, const ExportOptions& opt,
                 const std::vector<int>& actuated, RunTable& table, std::string* error) {
  if (log.states.empty()) return fail(error, "the log has no robot state (EXO_STATE) messages");
  if (opt.filter_hz < 0.0) return fail(error, "--filter must be positive");
  estimator::TickAssemblyCounts counts;
  const std::vector<estimator::AlignedTick> ticks = estimator::alignByTick(
      log.states, log.plates[0], log.plates[1], log.truth, {true, true, false}, &table.skipped_ticks, &counts);
  table.repeated_messages = counts.duplicates;
  table.out_of_order_messages = counts.out_of_order;
  if (ticks.empty()) return fail(error, "no tick has both the robot state and both plate messages");
  const int n = static_cast<int>(ticks.size()), nj = model.njoints;
  const bool derive = opt.filter_hz > 0.0;
  Eigen::MatrixXd q(n, nj), gyro(n, 3), v, a, dw;
  for (int i = 0; i < n; ++i) {
    q.row(i) = ticks[i].state->q.transpose();
    gyro.row(i) = ticks[i].state->imu_gyro.transpose();
  }
  if (derive) {
    // Thesis section III-E: filter, differentiate, filter again; the same for the body angular velocity.
    const double dt = n > 1 ? (ticks[n - 1].state->utime - ticks[0].state->utime) * 1e-6 / (n - 1) : 1e-3;
    if (opt.filter_hz >= 0.5 / dt)
      return fail(error, "--filter must be below the Nyquist frequency " + std::to_string(0.5 / dt) + " Hz");
    estimator::filterAndDifferentiate(q, dt, opt.filter_hz, nullptr, &v, &a);
    estimator::filterAndDifferentiate(gyro, dt, opt.filter_hz, &gyro, &dw, nullptr);
  }
  sensorHeader(model, actuated, derive, table.header);
  for (int i = 0; i < n; ++i) {
    const RobotStateSample& s = *ticks[i].state;
    std::vector<double> row{s.utime * 1e-6};
    for (int j = 0; j < nj; ++j) row.push_back(s.q[j]);  // positions themselves stay unfiltered
    if (derive) {
      for (int j = 0; j < nj; ++j) row.push_back(v(i, j));
      for (int j = 0; j < nj; ++j) row.push_back(a(i, j));
    }
    const Eigen::Quaterniond& o = s.imu_orientation;
    row.insert(row.end(), {o.w(), o.x(), o.y(), o.z(), gyro(i, 0), gyro(i, 1), gyro(i, 2)});
    if (derive) row.insert(row.end(), {dw(i, 0), dw(i, 1), dw(i, 2)});
    // Accelerometer = R^T (a - g): the classical acceleration of the base origin is R^T a = accel + R^T g.
    const Eigen::Vector3d acc = s.imu_accel + o.conjugate() * model.gravity;
    row.insert(row.end(), {acc.x(), acc.y(), acc.z()});
    for (int j : actuated) row.push_back(s.tau[j]);
    for (const ForcePlateSample* p : {ticks[i].plate[0], ticks[i].plate[1]}) {
      Eigen::Vector3d f, m;
      footWrenchFromPlate(*p, f, m);
      row.insert(row.end(), {f.x(), f.y(), f.z(), m.x(), m.y(), m.z()});
    }
    table.rows.push_back(std::move(row));
  }
  return true;
}
}  // namespace

bool buildRunTable(const Model& model, const intake::RunLog& log, const ExportOptions& opt, RunTable& table,
                   std::string* error) {
  table = RunTable();
  std::vector<int> actuated;
  for (int j = 0; j < model.njoints; ++j)
    if (model.effort_limit[j] > 0.0) actuated.push_back(j);
  return opt.truth ? truthTable(model, log, opt, actuated, table, error)
                   : sensorTable(model, log, opt, actuated, table, error);
}

bool eomResidual(const Model& model, const Eigen::VectorXd& phi, const intake::RunLog& log, EomResidual& out,
                 std::string* error) {
  out = EomResidual();
  const int feet[2] = {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")};
  if (feet[0] < 0 || feet[1] < 0 || !model.floating_base) {
    if (error) *error = "the EoM residual needs a floating-base model with right_foot and left_foot links";
    return false;
  }
  const std::vector<estimator::AlignedTick> ticks =
      estimator::alignByTick(log.states, log.plates[0], log.plates[1], log.truth, {true, true, true}, nullptr);
  Data kin(model);
  Eigen::VectorXd y(model.nv), tau(model.njoints);
  Eigen::VectorXd sum_sq = Eigen::VectorXd::Zero(model.nv);
  double max_error = 0.0, max_y = 0.0;
  for (const estimator::AlignedTick& a : ticks) {
    const GroundTruthSample& t = *a.truth;
    const State state = stateFromTruth(model, t);
    computeJointTorqueRegressor(model, kin, state);
    ExternalWrench w[2];
    for (int side = 0; side < 2; ++side) {
      w[side].body = feet[side];
      footWrenchFromPlate(*a.plate[side], w[side].force, w[side].moment_world_origin);
    }
    for (int j = 0; j < model.njoints; ++j) tau[j] = a.state->has_tau[j] ? a.state->tau[j] : 0.0;
    generalizedForceFromMeasurements(model, kin, state, tau, w, 2, y);
    const Eigen::VectorXd e = kin.K * phi - y;
    max_error = std::max(max_error, e.cwiseAbs().maxCoeff());
    max_y = std::max(max_y, y.cwiseAbs().maxCoeff());
    sum_sq += e.cwiseAbs2();
    ++out.ticks;
  }
  if (out.ticks == 0) {
    if (error) *error = "no tick has ground truth, robot state and both plates";
    return false;
  }
  out.max_relative = max_error / std::max(max_y, 1e-300);
  out.rms_per_row.resize(model.nv);
  for (int i = 0; i < model.nv; ++i) out.rms_per_row[i] = std::sqrt(sum_sq[i] / out.ticks);
  out.rms_absolute = std::sqrt(sum_sq.sum() / (out.ticks * model.nv));
  return true;
}

}  // namespace exoid::tools
