#include "exoid/estimator/dataset.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

#include "exoid/estimator/sole_tilt.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/signal/filters.hpp"

namespace exoid::estimator {

State stateFromTruth(const Model& model, const GroundTruthSample& t) {
  State s = State::zero(model);
  s.base_orientation = t.base_orientation;
  s.base_position = t.base_position;
  s.base_omega = t.base_omega;
  s.base_velocity = t.base_velocity;
  s.base_domega = t.base_domega;
  s.base_acceleration = t.base_acceleration;
  s.q = t.q;
  s.v = t.v;
  s.a = t.a;
  return s;
}

void footWrenchFromPlate(const ForcePlateSample& p, Eigen::Vector3d& f, Eigen::Vector3d& n) {
  const Eigen::Matrix3d R = p.plate_orientation.toRotationMatrix();
  f = -(R * p.force);
  n = -(R * p.moment) + p.plate_position.cross(f);
}

std::vector<AlignedTick> alignByTick(const std::vector<RobotStateSample>& states,
                                     const std::vector<ForcePlateSample>& plates_right,
                                     const std::vector<ForcePlateSample>& plates_left,
                                     const std::vector<GroundTruthSample>& truth, const TickNeeds& needs,
                                     long* skipped, TickAssemblyCounts* counts) {
  // The channels' messages go to the one tick assembly merged by tick (each channel in its log order), so
  // that a channel's own disorder is judged by the assembly's window, not by how the decoder split the log.
  const int drive = needs.state ? kTickState : kTickTruth;
  const unsigned needed = (needs.state ? 1u << kTickState : 0u) | (needs.truth ? 1u << kTickTruth : 0u) |
                          (needs.plates ? (1u << kTickPlateRight) | (1u << kTickPlateLeft) : 0u) | (1u << drive);
  const int capacity = static_cast<int>(kLogLagWindow) + 2;
  TickAssembly assembly(needed, kLogLagWindow, capacity);
  std::vector<AlignedTick> held(static_cast<size_t>(capacity)), out;
  const size_t size[kTickChannels] = {states.size(), plates_right.size(), plates_left.size(), truth.size()};
  size_t next[kTickChannels] = {0, 0, 0, 0};
  auto tickOf = [&](int c, size_t i) -> int64_t {
    switch (c) {
      case kTickState: return states[i].tick;
      case kTickPlateRight: return plates_right[i].tick;
      case kTickPlateLeft: return plates_left[i].tick;
      default: return truth[i].tick;
    }
  };
  long skip = 0;
  auto drain = [&](bool flush) {
    ReleasedTick r;
    while (assembly.release(r, flush)) {
      AlignedTick& a = held[static_cast<size_t>(r.slot)];
      if (r.complete) out.push_back(a);
      else if (r.present & (1u << drive)) ++skip;  // a driving message without its tick's other needed ones
      a = AlignedTick();
    }
  };
  for (;;) {
    // The channel whose next message has the smallest tick; ties: the channels not needed first (a tick is
    // released once its needed channels are in: an optional message of it offered after that would count as
    // out of order), then channel order.
    int c = -1;
    auto before = [&](int k, int than) {
      const int64_t tk = tickOf(k, next[k]), tt = tickOf(than, next[than]);
      if (tk != tt) return tk < tt;
      return !(needed & (1u << k)) && (needed & (1u << than));
    };
    for (int k = 0; k < kTickChannels; ++k)
      if (next[k] < size[k] && (c < 0 || before(k, c))) c = k;
    if (c < 0) break;
    const size_t i = next[c]++;
    int slot = -1;
    if (assembly.place(c, tickOf(c, i), &slot) != TickPlacement::Accepted) continue;
    AlignedTick& a = held[static_cast<size_t>(slot)];
    if (c == kTickState) a.state = &states[i];
    else if (c == kTickTruth) a.truth = &truth[i];
    else a.plate[c - kTickPlateRight] = c == kTickPlateRight ? &plates_right[i] : &plates_left[i];
    drain(false);
  }
  drain(true);
  if (skipped) *skipped = skip;
  if (counts) *counts = assembly.counts();
  return out;
}

namespace {
void contactsFromPlates(const ForcePlateSample* const plates[2], const int feet[2], MeasuredSample& out) {
  out.ncontacts = 2;
  for (int i = 0; i < 2; ++i) {
    out.contact[i].body = feet[i];
    footWrenchFromPlate(*plates[i], out.contact[i].force, out.contact[i].moment_world_origin);
    out.plate_position[i] = plates[i]->plate_position;
  }
}
}  // namespace

void measuredFromTruth(const Model& model, const GroundTruthSample& t, const ForcePlateSample* plates[2],
                       const int feet[2], MeasuredSample& out) {
  out.t = t.utime * 1e-6;
  out.q = t.q;
  out.v = t.v;
  out.a = t.a;
  out.tau = t.tau_applied;
  out.base_orientation = t.base_orientation;
  out.base_position = t.base_position;
  out.base_omega = t.base_omega;
  out.base_domega = t.base_domega;
  out.base_acceleration = t.base_acceleration;
  out.has_base_position = true;
  out.has_base_domega = true;
  if (plates && plates[0] && plates[1]) {
    contactsFromPlates(plates, feet, out);
  } else {
    out.ncontacts = 2;
    for (int i = 0; i < 2; ++i) {
      out.contact[i].body = feet[i];
      out.contact[i].force = t.foot_force[i];
      out.contact[i].moment_world_origin = t.foot_moment[i];
    }
  }
  (void)model;
}

void measuredFromSensors(const Model& model, const RobotStateSample& s, const ForcePlateSample* plates[2],
                         const int feet[2], MeasuredSample& out) {
  out.t = s.utime * 1e-6;
  out.q = s.q;
  out.v.resize(0);
  out.a.resize(0);
  out.tau = s.tau;
  for (int j = 0; j < model.njoints; ++j)
    if (!s.has_tau[j]) out.tau[j] = 0.0;
  out.base_orientation = s.imu_orientation;
  out.base_omega = s.imu_gyro;
  // Accelerometer = R^T (a - g): the classical acceleration of the base origin is accel + R^T g.
  out.base_acceleration = s.imu_accel + s.imu_orientation.conjugate() * model.gravity;
  out.base_domega.setZero();
  out.has_base_position = false;
  out.has_base_domega = false;
  contactsFromPlates(plates, feet, out);
}

bool heldBaseRowMeasured(const Model& model, int row) {
  const int j = row - (model.floating_base ? 6 : 0);
  return j >= 0 && j < model.njoints && (model.effort_limit.size() != model.njoints || model.effort_limit[j] > 0.0);
}

std::vector<DatasetOptions::Foothold> defaultFootholds(const Model& model,
                                                       const std::array<Eigen::Vector3d, 2>& sole_on_plate) {
  std::vector<DatasetOptions::Foothold> out;
  const char* soles[2] = {"right_sole", "left_sole"};
  for (int i = 0; i < 2; ++i) {
    const int f = model.frameIndex(soles[i]);
    if (f < 0) continue;
    DatasetOptions::Foothold h;
    h.body = model.frames[f].body;
    h.point_in_body = model.frames[f].position;
    h.rotation_in_body = model.frames[f].rotation;
    h.plate = i;
    h.world = sole_on_plate[static_cast<size_t>(i)];
    out.push_back(h);
  }
  return out;
}

Eigen::Vector3d basePositionFromFootholds(const std::vector<DatasetOptions::Foothold>& footholds, const Data& kin,
                                          const Eigen::Matrix3d& Rwb, const Eigen::Vector3d plate_position[2]) {
  // Leg kinematics: each sole point stays where the lab placed it, p_b = p_world - R_wb p_base(q).
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const DatasetOptions::Foothold& f : footholds)
    sum += f.world + (f.plate >= 0 ? plate_position[f.plate] : Eigen::Vector3d::Zero()) -
           Rwb * (kin.p[f.body] + kin.R[f.body] * f.point_in_body);
  return sum / static_cast<double>(footholds.size());
}

void filterAndDifferentiate(const Eigen::MatrixXd& x, double dt, double cutoff_hz, Eigen::MatrixXd* xf,
                            Eigen::MatrixXd* dx, Eigen::MatrixXd* ddx) {
  const bool filter = cutoff_hz > 0.0;
  const Biquad lp = filter ? Biquad::butterworthLowPass(cutoff_hz, 1.0 / dt) : Biquad();
  auto F = [&](const Eigen::MatrixXd& s) { return filter ? filtfilt(lp, s) : s; };
  const Eigen::MatrixXd f = F(x);
  if (dx || ddx) {
    const Eigen::MatrixXd d = F(differentiate(f, dt));
    if (ddx) *ddx = F(differentiate(d, dt));
    if (dx) *dx = d;
  }
  if (xf) *xf = f;
}

namespace {
// Samples for the filter's transient to decay to e^-40 (~4e-18): the poles of the biquad have modulus
// sqrt(a2) (complex pair of a Butterworth), the error after k samples ~ sqrt(a2)^k.
int filterMargin(const Biquad& c, double decay_e = 40.0) {
  const double r = std::sqrt(std::max(c.a2, 1e-300));
  return r >= 1.0 ? 1 << 20 : static_cast<int>(std::ceil(decay_e / -std::log(r))) + 8;
}

double medianStep(const std::vector<MeasuredSample>& b) {
  std::vector<double> d;
  d.reserve(b.size());
  for (size_t i = 1; i < b.size(); ++i) d.push_back(b[i].t - b[i - 1].t);
  if (d.empty()) return 1e-3;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}
}  // namespace

DatasetBuilder::DatasetBuilder(const Model& model, const DatasetOptions& options, RowSink sink)
    : model_(model), opt_(options), sink_(std::move(sink)), rng_(options.noise_seed) {
  opt_.block = std::max(16, opt_.block);
  // Parallel filtering holds every column of W over the window: smaller blocks keep that bounded.
  // (4096 x 2080 doubles for the exoskeleton plus the margins: ~130 MB at 5 Hz, reused from block to block; a
  // smaller block would recompute the margins more often: they are 1800 samples on each side at 5 Hz).
  if (opt_.filter == FilterMode::Parallel && opt_.cutoff_hz > 0.0) opt_.block = std::min(opt_.block, 4096);
  margin_ = 4;  // central differences of differences
  if (opt_.cutoff_hz > 0.0) margin_ = 3 * 4 + 3 * 60;  // refined at the first block from the sample rate
}

bool DatasetBuilder::add(const MeasuredSample& sample, std::string* error) {
  buffer_.push_back(sample);
  MeasuredSample& s = buffer_.back();
  if (opt_.encoder_noise > 0.0) {
    std::mt19937_64 g(rng_);
    std::normal_distribution<double> n(0.0, opt_.encoder_noise);
    for (int j = 0; j < s.q.size(); ++j) s.q[j] += n(g);
    rng_ = g();
  }
  if (static_cast<int>(buffer_.size()) - head_ >= opt_.block + margin_) return processBlock(false, error);
  return true;
}

bool DatasetBuilder::finish(std::string* error) {
  while (head_ < static_cast<int>(buffer_.size()))
    if (!processBlock(true, error)) return false;
  return true;
}

/// One window of buffer_ on its way to rows: the filters designed for its sample step, the joint and base
/// signals (filtered and differentiated) and the fused base orientation.
struct DatasetBuilder::BlockSignals {
  int n = 0;           ///< samples in the window
  double dt = 0.0;     ///< median step (s)
  Biquad lp, lp_orientation;
  bool filter = false;    ///< a cutoff is set
  bool parallel = false;  ///< FilterMode::Parallel: inputs only differenced, W and y filtered
  bool fuse = false;      ///< base orientation from the legs and the IMU
  bool legs_rate = false; ///< base angular velocity and acceleration from the legs (base_rate_from_legs)
  bool legs_acc = false;  ///< base linear acceleration from the legs (base_acceleration_from_legs)
  double input_cutoff = 0.0;
  Eigen::MatrixXd q, v, a;    ///< [n x nj]
  Eigen::MatrixXd w, dw, acc; ///< [n x 3] base angular velocity, acceleration, classical linear acceleration
  std::vector<Eigen::Quaterniond> legs;  ///< [n] fused base orientation (fuse), else empty
  std::vector<Eigen::Matrix3d> legs_rotation;  ///< [n] R_wb from the legs alone (fuse, legs_rate or legs_acc), else empty
  std::vector<Eigen::Vector3d> sole_in_base;   ///< [n] mean of the footholds' points in base coordinates (same)
  /// The zero-phase input filter where the inputs are filtered (not parallel), else x itself.
  Eigen::MatrixXd inputs(const Eigen::MatrixXd& x) const { return filter && !parallel ? filtfilt(lp, x) : x; }
};

bool DatasetBuilder::designFilters(BlockSignals& b, int& want, std::string* error) {
  const Model& model = model_;
  b.n = static_cast<int>(buffer_.size());
  b.dt = medianStep(buffer_);
  const double dt = b.dt;
  b.filter = opt_.cutoff_hz > 0.0;
  b.fuse = model.floating_base && opt_.orientation_from_legs && !opt_.footholds.empty() && !buffer_.empty() &&
           !buffer_.front().has_base_position;
  const bool legs_usable = model.floating_base && !opt_.footholds.empty() && !buffer_.empty() &&
                           !buffer_.front().has_base_position;
  b.legs_rate = legs_usable && opt_.base_rate_from_legs;
  b.legs_acc = legs_usable && opt_.base_acceleration_from_legs;
  want = 0;
  if (b.filter) {
    if (!(dt > 0.0) || opt_.cutoff_hz >= 0.5 / dt) {
      if (error) *error = "the filter cutoff " + std::to_string(opt_.cutoff_hz) + " Hz is not below the Nyquist frequency " + std::to_string(0.5 / dt) + " Hz";
      return false;
    }
    b.lp = Biquad::butterworthLowPass(opt_.cutoff_hz, 1.0 / dt);
    want = (opt_.filter == FilterMode::Parallel ? 1 : 3) * filterMargin(b.lp) + 8;
    if (opt_.filter == FilterMode::Parallel) want += std::max(1, opt_.derivative_half_window);  // the fit's reach
    if (opt_.trim_edges) edge_ = filterMargin(b.lp, 14.0);  // <= margin_, so the last edge_ are in the last block
  }
  if (b.fuse) {
    if (!(dt > 0.0) || !(opt_.orientation_cutoff_hz > 0.0) || opt_.orientation_cutoff_hz >= 0.5 / dt) {
      if (error) *error = "the orientation fusion cutoff " + std::to_string(opt_.orientation_cutoff_hz) + " Hz is not in (0, Nyquist)";
      return false;
    }
    b.lp_orientation = Biquad::butterworthLowPass(opt_.orientation_cutoff_hz, 1.0 / dt);
    want += filterMargin(b.lp_orientation) + 8;
  }
  // Parallel filtering: the regressor's inputs are only differenced (no filter), then W and y both pass the
  // one zero-phase filter, so that F(W) phi = F(y) holds wherever W phi = y does (the filter is linear).
  b.parallel = b.filter && opt_.filter == FilterMode::Parallel;
  b.input_cutoff = b.parallel ? 0.0 : opt_.cutoff_hz;
  return true;
}

void DatasetBuilder::derivatives(const BlockSignals& b, const Eigen::MatrixXd& x, Eigen::MatrixXd* value,
                                 Eigen::MatrixXd* first, Eigen::MatrixXd* second) const {
  if (b.parallel && opt_.derivative_half_window > 1) {
    savitzkyGolay(x, b.dt, opt_.derivative_half_window, value, first, second);
  } else {
    filterAndDifferentiate(x, b.dt, b.input_cutoff, value, first, second);
  }
}

void DatasetBuilder::jointSignals(BlockSignals& b) const {
  const int n = b.n, nj = model_.njoints;
  Eigen::MatrixXd &q = b.q, &v = b.v, &a = b.a;
  q.resize(n, nj), v.resize(n, nj), a.resize(n, nj);
  bool measured_va = true;
  for (int i = 0; i < n; ++i) {
    q.row(i) = buffer_[i].q.transpose();
    if (buffer_[i].v.size() != nj || buffer_[i].a.size() != nj) measured_va = false;
  }
  if (measured_va && !opt_.derive) {
    for (int i = 0; i < n; ++i) v.row(i) = buffer_[i].v.transpose(), a.row(i) = buffer_[i].a.transpose();
    q = b.inputs(q);
    v = b.inputs(v);
    a = b.inputs(a);
  } else {
    // Parallel mode keeps q itself (its noise is never squared); filtering the inputs filters it.
    derivatives(b, q, b.parallel ? nullptr : &q, &v, &a);
  }
}

void DatasetBuilder::baseSignals(BlockSignals& b) const {
  const int n = b.n;
  Eigen::MatrixXd &w = b.w, &dw = b.dw, &acc = b.acc;
  w.resize(n, 3), dw.resize(n, 3), acc.resize(n, 3);
  if (!model_.floating_base) return;
  bool measured_dw = !opt_.derive;
  for (int i = 0; i < n; ++i) {
    w.row(i) = buffer_[i].base_omega.transpose();
    dw.row(i) = buffer_[i].base_domega.transpose();
    acc.row(i) = buffer_[i].base_acceleration.transpose();
    measured_dw = measured_dw && buffer_[i].has_base_domega;
  }
  if (measured_dw) {
    w = b.inputs(w);
    dw = b.inputs(dw);
  } else {
    derivatives(b, w, &w, &dw, nullptr);  // in place: outputs written last
  }
}

namespace {
Eigen::Vector3d veeOfSkewPart(const Eigen::Matrix3d& M) {
  return Eigen::Vector3d(0.5 * (M(2, 1) - M(1, 2)), 0.5 * (M(0, 2) - M(2, 0)), 0.5 * (M(1, 0) - M(0, 1)));
}
}  // namespace

void DatasetBuilder::legsRotations(BlockSignals& b) {
  const Model& model = model_;
  const int n = b.n;
  const int nf = static_cast<int>(opt_.footholds.size());
  Data fk(model);
  State sf = State::zero(model);
  std::vector<Eigen::Matrix3d> Rbs(static_cast<size_t>(n * nf));
  b.sole_in_base.resize(n);
  for (int i = 0; i < n; ++i) {
    sf.q = b.q.row(i).transpose();
    forwardKinematics(model, fk, sf);
    Eigen::Vector3d pb = Eigen::Vector3d::Zero();
    for (int f = 0; f < nf; ++f) {
      Rbs[i * nf + f] = fk.R[opt_.footholds[f].body] * opt_.footholds[f].rotation_in_body;
      pb += fk.p[opt_.footholds[f].body] + fk.R[opt_.footholds[f].body] * opt_.footholds[f].point_in_body;
    }
    b.sole_in_base[i] = pb / nf;
  }
  if (sole_world_.empty()) {
    // From the first kSoleWorldSamples samples (the first window holds at least the block plus the fusion filter's
    // margin).
    sole_world_.assign(nf, Eigen::Matrix3d::Zero());
    for (int i = 0; i < std::min(n, kSoleWorldSamples); ++i)
      for (int f = 0; f < nf; ++f) sole_world_[f] += buffer_[i].base_orientation.toRotationMatrix() * Rbs[i * nf + f];
    for (int f = 0; f < nf; ++f) sole_world_[f] = nearestRotation(sole_world_[f]);
  }
  b.legs_rotation.resize(n);
  for (int i = 0; i < n; ++i) b.legs_rotation[i] = legsRotation(sole_world_, Rbs.data() + i * nf);
}

void DatasetBuilder::fuseOrientation(BlockSignals& b) const {
  const Model& model = model_;
  const int n = b.n;
  std::vector<Eigen::Quaterniond>& legs = b.legs;
  legs.resize(n);
  Eigen::MatrixXd e(n, 3);  // the legs' correction: the soles' tilt fitted to the plates, else the IMU's low band
  for (int i = 0; i < n; ++i) {
    legs[i] = Eigen::Quaterniond(b.legs_rotation[i]);
    if (opt_.sole_tilt.fitted) {  // sole_tilt.hpp
      e.row(i) = (opt_.sole_tilt.coefficients * soleTiltRegressor(buffer_[i])).transpose();
    } else {  // log(R_legs^T R_IMU), low-passed below
      const Eigen::AngleAxisd d(legs[i].conjugate() * buffer_[i].base_orientation);
      e.row(i) = (d.angle() * d.axis()).transpose();
    }
  }
  if (!opt_.sole_tilt.fitted) e = filtfilt(b.lp_orientation, e);
  for (int i = 0; i < n; ++i) {
    const double angle = e.row(i).norm();
    if (angle > 0.0) legs[i] = (legs[i] * Eigen::Quaterniond(Eigen::AngleAxisd(angle, e.row(i).transpose() / angle))).normalized();
    {
      // accelerometer + R^T g with the IMU's R, re-based: + (R_legs^T - R_imu^T) g.
      b.acc.row(i) += (legs[i].conjugate() * model.gravity - buffer_[i].base_orientation.conjugate() * model.gravity).transpose();
    }
  }
}

Eigen::MatrixXd DatasetBuilder::withImuBelowFusionCutoff(const BlockSignals& b, const Eigen::MatrixXd& legs,
                                                         const Eigen::MatrixXd& imu) const {
  if (!(b.fuse && opt_.imu_below_fusion_cutoff)) return legs;
  return legs + filtfilt(b.lp_orientation, Eigen::MatrixXd(imu - legs));
}

void DatasetBuilder::legsRate(BlockSignals& b) const {
  // R^T R' = [omega] for a rotation; of the differentiated (filtered) entries only the skew part is kept, and
  // d/dt (R^T R') = R'^T R' + R^T R'' whose first term is symmetric: [domega] = skew(R^T R'').
  const int n = b.n;
  Eigen::MatrixXd r(n, 9), rf, dr, ddr;
  for (int i = 0; i < n; ++i) r.row(i) = Eigen::Map<const Eigen::Matrix<double, 1, 9>>(b.legs_rotation[i].data());
  derivatives(b, r, &rf, &dr, &ddr);
  // Not fused with the gyro below the orientation's cutoff by default (imu_below_fusion_cutoff): the gyro's share
  // below 5 Hz still cost the exoskeleton's nominal run a third more held-out error (docs/identification.md).
  Eigen::MatrixXd w(n, 3), dw(n, 3);
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix<double, 1, 9> r0 = rf.row(i), d1 = dr.row(i), d2 = ddr.row(i);
    const Eigen::Map<const Eigen::Matrix3d> R(r0.data()), dR(d1.data()), ddR(d2.data());
    w.row(i) = veeOfSkewPart(R.transpose() * dR).transpose();
    dw.row(i) = veeOfSkewPart(R.transpose() * ddR).transpose();
  }
  b.w = withImuBelowFusionCutoff(b, w, b.w);
  b.dw = withImuBelowFusionCutoff(b, dw, b.dw);
}

void DatasetBuilder::legsAcceleration(BlockSignals& b) const {
  // p_b = p_sole - R_wb p_sole^b(q) (the plates do not move; the constant drops out of p_b''), in base coordinates.
  const int n = b.n;
  Eigen::MatrixXd p(n, 3), ddp;
  for (int i = 0; i < n; ++i) p.row(i) = (-(b.legs_rotation[i] * b.sole_in_base[i])).transpose();
  derivatives(b, p, nullptr, nullptr, &ddp);
  Eigen::MatrixXd acc(n, 3);
  for (int i = 0; i < n; ++i) acc.row(i) = (b.legs_rotation[i].transpose() * ddp.row(i).transpose()).transpose();
  b.acc = withImuBelowFusionCutoff(b, acc, b.acc);
}

bool DatasetBuilder::keepSample(int i, int n, bool last) {
  const bool drop = edge_ > 0 && (seen_ + i < edge_ || (last && i >= n - edge_));
  if (drop) ++trimmed_;
  return !drop;
}

void DatasetBuilder::setSensorTorque(const Eigen::VectorXd& tau) {
  for (int j = 0; j < model_.njoints; ++j) sensor_torque_[model_.jointRow(j)] = tau[j];
}

void DatasetBuilder::regressWindow(const BlockSignals& b, bool last, int emit_end) {
  const Model& model = model_;
  const int n = b.n, nj = model.njoints, nv = model.nv, p = model.nparams();
  const bool parallel = b.parallel;
  const int from = parallel ? 0 : head_, to = parallel ? n : emit_end;
  Data kin(model);
  State st = State::zero(model);
  Eigen::VectorXd y(nv);
  SampleMajorMatrix& Kall = Kall_;
  SampleMajorMatrix& Yall = Yall_;
  // Kept between blocks: reallocated only when the window size changes (the last block).
  if (parallel && (Kall.rows() != to - from || Kall.cols() != nv * p))
    Kall.resize(to - from, nv * p), Yall.resize(to - from, nv), Tall_.resize(to - from, nj);
  if (sensor_torque_.size() != nv) sensor_torque_ = Eigen::VectorXd::Zero(nv);
  for (int i = from; i < to; ++i) {
    const MeasuredSample& s = buffer_[i];
    st.q = b.q.row(i).transpose();
    st.v = b.v.row(i).transpose();
    st.a = b.a.row(i).transpose();
    if (model.floating_base) {
      st.base_orientation = b.legs.empty() ? s.base_orientation : b.legs[i];
      st.base_omega = b.w.row(i).transpose();
      st.base_domega = b.dw.row(i).transpose();
      st.base_acceleration = b.acc.row(i).transpose();
    }
    computeJointTorqueRegressor(model, kin, st);
    if (model.floating_base) {
      if (s.has_base_position || opt_.footholds.empty()) {
        st.base_position = s.base_position;
      } else {
        st.base_position = basePositionFromFootholds(opt_.footholds, kin, st.base_orientation.toRotationMatrix(),
                                                     s.plate_position);
      }
    }
    generalizedForceFromMeasurements(model, kin, st, s.tau, s.contact, s.ncontacts, y);
    if (parallel) {
      for (int c = 0; c < nv; ++c) Kall.block(i - from, c * p, 1, p) = kin.K.row(c);
      Yall.row(i - from) = y.transpose();
      Tall_.row(i - from) = s.tau.transpose();
    } else if (keepSample(i, n, last)) {
      setSensorTorque(s.tau);
      joint_position_ = b.q.row(i).transpose();
      sink_(s.t, kin.K, y);
      ++emitted_;
    }
  }
}

void DatasetBuilder::emitFilteredWindow(const BlockSignals& b, bool last, int emit_end) {
  const int nv = model_.nv, p = model_.nparams();
  const SampleMajorMatrix& Kall = Kall_;
  const SampleMajorMatrix& Yall = Yall_;
  // In place, every channel at once through contiguous rows: column by column the window's 2080 strided columns
  // (exoskeleton) cost more than the regressor itself.
  filtfiltInPlace(b.lp, Kall_, filter_scratch_);
  filtfiltInPlace(b.lp, Yall_, filter_scratch_);
  filtfiltInPlace(b.lp, Tall_, filter_scratch_);
  Eigen::MatrixXd K(nv, p);
  for (int i = head_; i < emit_end; ++i) {
    if (!keepSample(i, b.n, last)) continue;
    for (int c = 0; c < nv; ++c) K.row(c) = Kall.block(i, c * p, 1, p);
    setSensorTorque(Tall_.row(i).transpose());
    joint_position_ = b.q.row(i).transpose();
    sink_(buffer_[i].t, K, Yall.row(i).transpose());
    ++emitted_;
  }
}

bool DatasetBuilder::processBlock(bool last, std::string* error) {
  BlockSignals b;
  int want = 0;
  if (!designFilters(b, want, error)) return false;
  const int n = b.n;
  if (want > margin_ && emitted_ == 0 && !last) {
    margin_ = want;  // wait for enough lookahead
    if (n - head_ < opt_.block + margin_) return true;
  }
  const int emit_end = last ? n : std::min(n, head_ + opt_.block);
  jointSignals(b);
  baseSignals(b);
  // Base orientation fused from the legs and the IMU (DatasetOptions::orientation_from_legs): R_bs(q) per
  // sample and foot from the (filtered) encoders, R_ws once from the first 1000 samples, R_legs per sample, the
  // IMU's low-passed correction on top; the accelerometer's gravity term re-based on it before filtering.
  if (b.fuse || b.legs_rate || b.legs_acc) legsRotations(b);
  if (b.fuse) fuseOrientation(b);
  if (model_.floating_base) b.acc = b.inputs(b.acc);
  // The base's rate and linear acceleration from the legs (base_rate_from_legs, base_acceleration_from_legs):
  // differentiated as q is, in place of the gyro's and the accelerometer's.
  if (b.legs_rate) legsRate(b);
  if (b.legs_acc) legsAcceleration(b);
  // trim_edges (keepSample): the run's first edge_ samples and, in the last block, its last edge_ are not
  // emitted. Regressor and generalized forces over the window; only [head_, emit_end) are emitted. With
  // parallel filtering every sample of the window is computed, then W and y filtered column by column.
  regressWindow(b, last, emit_end);
  if (b.parallel) emitFilteredWindow(b, last, emit_end);
  // Keep `margin_` samples of history before the next block.
  const int drop = std::max(0, emit_end - margin_);
  buffer_.erase(buffer_.begin(), buffer_.begin() + drop);
  seen_ += drop;
  head_ = emit_end - drop;
  return true;
}

}  // namespace exoid::estimator
