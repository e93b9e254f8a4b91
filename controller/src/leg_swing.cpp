#include "exoid/controller/leg_swing.hpp"

#include <cmath>
#include <algorithm>
#include <random>

#include "exoid/model/kinematics.hpp"

namespace exoid::controller {

namespace {
// Quintic smoothstep s(x) on [0, 1] with zero slope and curvature at both ends, and its derivatives in x.
void smoothstep(double x, double& s, double& ds, double& dds) {
  if (x <= 0.0) { s = ds = dds = 0.0; return; }
  if (x >= 1.0) { s = 1.0, ds = dds = 0.0; return; }
  const double x2 = x * x, x3 = x2 * x;
  s = x3 * (10.0 - 15.0 * x + 6.0 * x2);
  ds = 30.0 * x2 * (1.0 - 2.0 * x + x2);
  dds = 60.0 * x * (1.0 - 3.0 * x + 2.0 * x2);
}
}  // namespace

bool makeLegSwingTrajectory(const Model& model, const Eigen::VectorXd& q_start, const LegSwingOptions& o,
                            LegSwingTrajectory& out, std::string* error) {
  const int nj = model.njoints, nf = static_cast<int>(o.frequencies_hz.size());
  auto fail = [&](const std::string& m) { return (error ? *error = m : std::string()), false; };
  if (q_start.size() != nj) return fail("the start pose has " + std::to_string(q_start.size()) + " joints, the model " + std::to_string(nj));
  if (nf == 0) return fail("no swing frequency");
  for (double f : o.frequencies_hz)
    if (!(f > 0.0 && f < 5.0)) return fail("swing frequencies must be in (0, 5) Hz");
  if (!(o.ramp_s > 0.0) || !(o.fraction > 0.0 && o.fraction <= 1.0) || !(o.fraction_hip_aa >= 0.0 && o.fraction_hip_aa <= 1.0))
    return fail("ramp must be > 0 and the fractions in (0, 1]");
  out.q_start = q_start;
  out.centre = q_start;
  out.amplitude = Eigen::MatrixXd::Zero(nj, nf);
  out.phase = Eigen::MatrixXd::Zero(nj, nf);
  out.frequency = Eigen::Map<const Eigen::VectorXd>(o.frequencies_hz.data(), nf);
  out.ramp_s = o.ramp_s;
  out.driven.assign(static_cast<size_t>(nj), 0);
  Data fk(model);
  State fk_state = State::zero(model);
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> uni(0.0, 2.0 * M_PI);
  for (int j = 0; j < nj; ++j) {
    const bool actuated = model.effort_limit.size() == nj && model.effort_limit[j] > 0.0;
    for (int k = 0; k < nf; ++k) out.phase(j, k) = uni(rng);  // drawn for every joint: phases do not depend on which are driven
    if (!actuated) continue;
    const double lo = model.position_lower[j], hi = model.position_upper[j];
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo))
      return fail("joint '" + model.joint_names[j] + "' has no finite limits to swing within");
    const bool hip_aa = model.joint_names[j].find("hip_aa") != std::string::npos;
    const double peak = (hip_aa ? o.fraction_hip_aa : o.fraction) * 0.5 * (hi - lo);
    out.driven[static_cast<size_t>(j)] = 1;
    out.centre[j] = 0.5 * (lo + hi);
    if (hip_aa) {
      // Abduction only: centred one peak outward of the start, the side that moves the leg's last body away from
      // the base's sagittal plane (y = 0), so the soles never meet.
      const int leaf = model.subtree[static_cast<size_t>(model.joint_body[j])].back();
      fk_state.q = q_start;
      forwardKinematics(model, fk, fk_state);
      const double y0 = std::abs(fk.p[leaf].y());
      fk_state.q[j] += 1e-3;
      forwardKinematics(model, fk, fk_state);
      const double outward = std::abs(fk.p[leaf].y()) > y0 ? 1.0 : -1.0;
      out.centre[j] = std::clamp(q_start[j] + outward * peak, lo + peak, hi - peak);
    }
    for (int k = 0; k < nf; ++k) out.amplitude(j, k) = peak / nf;  // the sum never exceeds the peak
  }
  // Per-joint PD gains from the joint-space inertia at the centre, base at rest.
  if (!(o.bandwidth_hz > 0.0 && o.bandwidth_hz < 50.0) || !(o.damping_ratio > 0.0))
    return fail("the PD bandwidth must be in (0, 50) Hz and the damping ratio > 0");
  DynamicsData dyn(model);
  State st = State::zero(model);
  st.q = out.centre;
  crba(model, dyn, st);
  const double w = 2.0 * M_PI * o.bandwidth_hz;
  out.kp = Eigen::VectorXd::Zero(nj);
  out.kd = Eigen::VectorXd::Zero(nj);
  for (int j = 0; j < nj; ++j) {
    const double mjj = dyn.M(model.jointRow(j), model.jointRow(j));
    out.kp[j] = mjj * w * w;
    out.kd[j] = 2.0 * o.damping_ratio * mjj * w;
  }
  return true;
}

void legSwingReference(const LegSwingTrajectory& tr, double t, Eigen::VectorXd& q, Eigen::VectorXd& v,
                       Eigen::VectorXd& a) {
  const int nj = static_cast<int>(tr.centre.size()), nf = static_cast<int>(tr.frequency.size());
  double s, ds, dds;  // move to the centres
  smoothstep(t / tr.ramp_s, s, ds, dds);
  const double T = tr.ramp_s;
  double w, dw, ddw;  // fade the sines in
  smoothstep((t - T) / T, w, dw, ddw);
  dw /= T, ddw /= T * T;
  for (int j = 0; j < nj; ++j) {
    const double d = tr.centre[j] - tr.q_start[j];
    double x = 0.0, dx = 0.0, ddx = 0.0;
    if (t > T)
      for (int k = 0; k < nf; ++k) {
        const double om = 2.0 * M_PI * tr.frequency[k], arg = om * (t - T) + tr.phase(j, k);
        const double A = tr.amplitude(j, k);
        x += A * std::sin(arg);  // |x| <= the peak; the fade-in w starts it from the centre
        dx += A * om * std::cos(arg);
        ddx -= A * om * om * std::sin(arg);
      }
    q[j] = tr.q_start[j] + d * s + w * x;
    v[j] = d * ds / T + dw * x + w * dx;
    a[j] = d * dds / (T * T) + ddw * x + 2.0 * dw * dx + w * ddx;
  }
}

LegSwingData::LegSwingData(const Model& model)
    : dynamics(model), state(State::zero(model)), qd(Eigen::VectorXd::Zero(model.njoints)),
      vd(Eigen::VectorXd::Zero(model.njoints)), ad(Eigen::VectorXd::Zero(model.njoints)) {}

void legSwingTorque(const Model& model, const LegSwingTrajectory& tr, LegSwingData& data,
                    double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  legSwingReference(tr, t, data.qd, data.vd, data.ad);
  data.state.q = data.qd;  // base: at rest and upright (State::zero)
  data.state.v = data.vd;
  data.state.a = data.ad;
  rnea(model, data.dynamics, data.state);
  const int off = model.floating_base ? 6 : 0;
  for (int j = 0; j < model.njoints; ++j) {
    tau[j] = tr.driven[static_cast<size_t>(j)]
                 ? data.dynamics.tau[off + j] + tr.kp[j] * (data.qd[j] - q[j]) + tr.kd[j] * (data.vd[j] - v[j])
                 : 0.0;
  }
}

}  // namespace exoid::controller
