#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/sample_checks.hpp"

#include <algorithm>
#include <Eigen/QR>
#include <cmath>
#include <cstdio>
#include <limits>

#include "exoid/estimator/batch/consistent.hpp"
#include "exoid/estimator/batch/solvers.hpp"
#include "exoid/estimator/measurement.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/signal/filters.hpp"

namespace exoid::estimator {

const char* forgettingName(Forgetting f) {
  switch (f) {
    case Forgetting::None: return "none";
    case Forgetting::Stabilised: return "stabilised";
    case Forgetting::Selective: return "selective";
  }
  return "?";
}

bool parseForgetting(const std::string& name, Forgetting& f) {
  for (Forgetting g : {Forgetting::None, Forgetting::Stabilised, Forgetting::Selective})
    if (name == forgettingName(g)) {
      f = g;
      return true;
    }
  return false;
}

const char* rowWeightingName(RowWeighting w) {
  switch (w) {
    case RowWeighting::Fixed: return "fixed";
    case RowWeighting::WlsR: return "wls-r";
    case RowWeighting::WlsRCorrelated: return "wls-r-corr";
  }
  return "?";
}

bool parseRowWeighting(const std::string& name, RowWeighting& w) {
  for (RowWeighting g : {RowWeighting::Fixed, RowWeighting::WlsR, RowWeighting::WlsRCorrelated})
    if (name == rowWeightingName(g)) {
      w = g;
      return true;
    }
  return false;
}

namespace {
enum Channel { kStateChannel = kTickState, kRightPlate = kTickPlateRight, kLeftPlate = kTickPlateLeft };

}  // namespace

/// The prior on the base parameters and what the standard parameters are computed from.
struct OnlineEstimator::BasePrior {
  Eigen::VectorXd var;      ///< [p] prior variance of each standard parameter
  Eigen::MatrixXd BS;       ///< [m x p] B Sigma
  Eigen::MatrixXd Sx;       ///< [m x m] B Sigma B^T
  Eigen::MatrixXd Lambda0;  ///< [m x m] (B Sigma B^T)^-1
};

OnlineEstimator::OnlineEstimator(const Model& model, const BaseParameters& base, const Eigen::VectorXd& prior_phi,
                                 const OnlineEstimatorOptions& options)
    : model_(model), opt_(options), rls_(RecursiveLsModel{}), kin_(model), fk_(model) {
  if (!checkModelAndOptions()) return;
  dt_ = 1.0 / opt_.sample_hz;
  if (prior_phi.size() != model.nparams() || !prior_phi.allFinite()) {
    setError("the prior must have one finite value per parameter");
    return;
  }
  BasePrior prior;
  if (!setUpRecursiveLs(base, prior_phi, prior)) return;
  m_base_ = base.rank;
  // A diagnose sidecar (docs/estimator.md "Extra columns"): its dynamics effects become parameters m..m+ne-1
  // (prior 0, sigma = factor x |value|), its gains correct y. Added before the data and the filter are sized,
  // so the filter runs on E's entries too and the checkpoint structure holds the columns.
  std::vector<double> effect_sigma;
  if (!opt_.effects.effects.empty() && !addEffectColumns(effect_sigma)) return;
  // Told by the options or by the sidecar (a diagnosis that named an unmeasured body on the base): the CoM height the
  // base rows give is that body's lag as much as the robot's, so the stated height uncertainty keeps the prior's
  // (docs/estimator.md "A body that moves on the base"). One sigma of the base link's mcz over the total mass.
  if (opt_.base_body_moves || opt_.effects.base_body_moves) {
    double mass = 0.0;
    for (int b = 0; b < model_.nbodies; ++b) mass += prior_phi[model_.bodyParamIndex(b)];
    height_prior_sigma_ = std::sqrt(prior.var[model_.bodyParamIndex(0) + 3]) / mass;
  }
  if ((opt_.sensor_offset_sigma > 0.0 || opt_.sensor_gain_sigma > 0.0) && !addSensorOffsetColumns(effect_sigma)) return;
  rls_ = RecursiveLsData(rls_model_);
  weighting_ = opt_.forgetting == Forgetting::Selective ? RowWeighting::Fixed : opt_.row_weighting;
  initial_weights_ = rls_model_.row_weight;
  filter_.configure(rls_model_, opt_.cutoff_hz, opt_.sample_hz, opt_.filter_order);
  filter_correlation_ = filterCorrelationTime(opt_.cutoff_hz, opt_.sample_hz, opt_.filter_order);
  initStandardParameters(base, prior_phi, prior, effect_sigma);
  sizeWorkspace();
}

void OnlineEstimator::setError(const std::string& what) { error_ = what; }

bool OnlineEstimator::checkModelAndOptions() {
  if (!model_.floating_base) {
    setError("the online estimator needs a floating-base model standing on force plates");
    return false;
  }
  feet_[0] = model_.bodyIndex("right_foot");
  feet_[1] = model_.bodyIndex("left_foot");
  if (feet_[0] < 0 || feet_[1] < 0) {
    setError("the model needs right_foot and left_foot links (the plates' bodies)");
    return false;
  }
  footholds_ = defaultFootholds(model_, opt_.sole_on_plate);
  if (footholds_.empty()) {
    setError("the model needs right_sole / left_sole frames (base position from the legs)");
    return false;
  }
  if (opt_.filter_order < 2 || opt_.filter_order > Biquad::kMaxOrder || opt_.filter_order % 2 != 0) {
    setError("filter order " + std::to_string(opt_.filter_order) + ": must be even, 2 to " + std::to_string(Biquad::kMaxOrder));
    return false;
  }
  if (opt_.derivative_half_window < 1 || opt_.derivative_half_window > 500) {
    setError("derivative half window " + std::to_string(opt_.derivative_half_window) + ": must be 1 to 500 ticks");
    return false;
  }
  if (opt_.gyro_half_window < 1 || opt_.gyro_half_window > 500) {
    setError("gyro half window " + std::to_string(opt_.gyro_half_window) + ": must be 1 to 500 ticks");
    return false;
  }
  if (!(opt_.sample_hz > 0.0 && std::isfinite(opt_.sample_hz))) {
    setError("sample rate must be > 0");
    return false;
  }
  if (!(opt_.prior_relative > 0.0 && std::isfinite(opt_.prior_relative))) {
    setError("prior uncertainty must be > 0");
    return false;
  }
  if (opt_.forget_every < 1 || opt_.uncertainty_every < 1) {
    setError("forget_every and uncertainty_every must be >= 1");
    return false;
  }
  if (!(opt_.block_threshold > 0.0) || !(opt_.excited_gain > 0.0) ||
      !(opt_.min_excitation >= 0.0 && opt_.min_excitation <= 1.0))
    {
    setError("block threshold and excited gain must be > 0, minimum excitation in [0, 1]");
    return false;
  }
  return true;
}

bool OnlineEstimator::setUpRecursiveLs(const BaseParameters& base, const Eigen::VectorXd& prior_phi,
                                       BasePrior& prior) {
  const Model& model = model_;
  const int m = base.rank;
  // Prior on the standard parameters: independent, sigma_i = relative * h_i (h the WLS-C scale: |prior|, zero
  // priors their kind's). On x = B phi it is N(B phi_prior, B Sigma B^T): Lambda0 = (B Sigma B^T)^-1.
  prior.var = (opt_.prior_relative * columnScale(model, prior_phi)).cwiseAbs2();
  prior.BS = base.base_map * prior.var.asDiagonal();  // [m x p]
  prior.Sx = prior.BS * base.base_map.transpose();
  Eigen::LLT<Eigen::MatrixXd> sx(prior.Sx);
  if (sx.info() != Eigen::Success) {
    setError("prior covariance of the base parameters is not positive definite");
    return false;
  }
  Eigen::MatrixXd& Lambda0 = prior.Lambda0;
  Lambda0 = sx.solve(Eigen::MatrixXd::Identity(m, m));
  Lambda0 = (0.5 * (Lambda0 + Lambda0.transpose())).eval();  // eval: the transpose must not read what is written
  RecursiveLsOptions ro;
  ro.forgetting = opt_.forgetting == Forgetting::Stabilised ? opt_.lambda : 1.0;
  ro.row_weight = opt_.row_weight;
  if (!(opt_.lambda > 0.0 && opt_.lambda <= 1.0)) {
    setError("forgetting factor must be in (0, 1]");
    return false;
  }
  if (opt_.change_threshold > 0.0 &&
      !(opt_.change_window_s > 0.0 && opt_.change_baseline_s > 0.0 && opt_.change_hold_s >= 0.0 &&
        opt_.change_keep > 0.0 && opt_.change_keep <= 1.0)) {
    setError("change detection: window and baseline must be > 0, hold >= 0, keep in (0, 1]");
    return false;
  }
  std::string err;
  if (!makeRecursiveLs(model, base, prior_phi, Lambda0, ro, rls_model_, &err)) {
    setError(err);
    return false;
  }
  return true;
}

int OnlineEstimator::appendColumns(const std::vector<int>& rows, const std::vector<double>& sigma,
                                   const std::vector<unsigned char>& feedforward, std::vector<double>& effect_sigma) {
  std::string err;
  const Eigen::Map<const Eigen::VectorXd> s(sigma.data(), static_cast<Eigen::Index>(sigma.size()));
  if (!addExtraColumns(rls_model_, rows, s, &err)) {
    setError(err);
    return -1;
  }
  effect_sigma.insert(effect_sigma.end(), sigma.begin(), sigma.end());
  ff_effect_.insert(ff_effect_.end(), feedforward.begin(), feedforward.end());
  effect_row_.insert(effect_row_.end(), rows.begin(), rows.end());
  ne_ += static_cast<int>(rows.size());
  return static_cast<int>(rows.size());
}

bool OnlineEstimator::addEffectColumns(std::vector<double>& effect_sigma) {
  if (!(opt_.effect_prior_factor > 0.0 && std::isfinite(opt_.effect_prior_factor))) {
    setError("effect prior factor must be > 0");
    return false;
  }
  std::vector<int> rows;
  std::vector<double> sigma;
  std::vector<unsigned char> ff;
  for (const Effect& e : opt_.effects.effects) {
    if (e.joint < 0 || e.joint >= model_.njoints || signalJoint(e) < 0 || signalJoint(e) >= model_.njoints ||
        !std::isfinite(e.value)) {
      setError("effects: a joint index outside the model or a non-finite value");
      return false;
    }
    if (e.kind == EffectKind::Delay) {
      setError(std::string("effects: a time delay (") + model_.joint_names[e.joint] +
               ") needs the torque's future; the online estimator cannot apply it (remove it from the sidecar)");
      return false;
    }
    if (isMeasurementEffect(e.kind)) continue;
    rows.push_back(model_.jointRow(e.joint));
    sigma.push_back(opt_.effect_prior_factor * std::fabs(e.value) + 1e-6);
    // Armature multiplies the acceleration, which tau_correction leaves out of the rigid part too (below).
    ff.push_back(e.kind == EffectKind::Armature ? 0 : 1);
  }
  if (appendColumns(rows, sigma, ff, effect_sigma) < 0) return false;
  effects_ = true;
  return true;
}

bool OnlineEstimator::addSensorOffsetColumns(std::vector<double>& effect_sigma) {
  if (!std::isfinite(opt_.sensor_offset_sigma) || !std::isfinite(opt_.sensor_gain_sigma)) {
    setError("sensor offset and gain sigmas must be finite");
    return false;
  }
  // Offsets (a 1 on the joint's row), then gains (the joint's measured torque): process() fills them.
  std::vector<int> rows;
  std::vector<double> s;
  for (double sigma : {opt_.sensor_offset_sigma, opt_.sensor_gain_sigma}) {
    if (!(sigma > 0.0)) continue;
    for (int j = 0; j < model_.njoints; ++j) {
      rows.push_back(model_.jointRow(j));
      s.push_back(sigma);
    }
  }
  // A sensor's error is not a torque on the robot: never fed forward.
  n_offset_ = appendColumns(rows, s, std::vector<unsigned char>(rows.size(), 0), effect_sigma);
  return n_offset_ >= 0;
}

void OnlineEstimator::initStandardParameters(const BaseParameters& base, const Eigen::VectorXd& prior_phi,
                                             const BasePrior& prior, const std::vector<double>& effect_sigma) {
  const Model& model = model_;
  const int p = model.nparams(), m = base.rank;
  const Eigen::VectorXd& var = prior.var;
  const Eigen::MatrixXd& BS = prior.BS;
  const Eigen::MatrixXd& Lambda0 = prior.Lambda0;
  prior_sigma_ = Eigen::VectorXd::Zero(m + ne_);
  prior_sigma_.head(m) = prior.Sx.diagonal().cwiseSqrt();
  for (int e = 0; e < ne_; ++e) prior_sigma_[m + e] = effect_sigma[e];
  // Standard parameters from base parameters: the conditional mean of the prior given x (the same prior),
  // phi = phi_prior + G (x - x0), G = Sigma B^T Lambda0 (B G = I: the base parameters are reproduced exactly);
  // what x cannot tell keeps its prior variance diag(Sigma - G B Sigma).
  phi_prior_ = prior_phi;
  G_ = BS.transpose() * Lambda0;
  phi_var0_ = (var - (G_ * BS).diagonal()).cwiseMax(0.0);
  x_model_ = base.base_map * model.phi;
  phi_ = prior_phi;
  GC_ = Eigen::MatrixXd::Zero(p, m);
  param_stddev_ = phi_var0_.cwiseSqrt();
  dx_ = Eigen::VectorXd::Zero(m + ne_);
  // Consistent standard parameters (reconcile): with phi = phi_prior + Sigma^1/2 u, the prior's cost u^T u splits
  // into what B phi sees (the base prior, Lambda0, already inside the estimate's information A) and the rest,
  // ||N^T u||^2 with N an orthonormal basis of the nullspace of B Sigma^1/2. Using only the rest keeps the prior
  // from being counted twice: the unconstrained minimiser is then exactly the conditional mean above.
  if (opt_.consistent_every > 0) {
    B_ = base.base_map;
    const Eigen::VectorXd sd = var.cwiseSqrt();
    const Eigen::MatrixXd Mt = (base.base_map * sd.asDiagonal()).transpose();  // [p x m]
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(Mt);
    const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(p, p);
    prior_rows_ = Q.rightCols(p - m).transpose() * sd.cwiseInverse().asDiagonal();
    prior_rows_rhs_ = prior_rows_ * prior_phi;
    phi_c_ = prior_phi;
    d_ = u_m_ = Eigen::VectorXd::Zero(m);
  }
}

void OnlineEstimator::sizeWorkspace() {
  const Model& model = model_;
  const int p = model.nparams(), m = m_base_, nv = model.nv;
  const int mx = m + ne_;  // the estimated parameters: base, then effects
  R_ = Eigen::MatrixXd::Zero(mx, mx);
  dD_ = R1_ = Y_ = M_ = R_;
  r_ = dd_ = u_ = mask_ = Eigen::VectorXd::Zero(mx);
  sensor_S_ = Eigen::MatrixXd::Zero(n_offset_, n_offset_);
  mllt_ = Eigen::LLT<Eigen::MatrixXd>(mx);
  rss_carry_ = Eigen::VectorXd::Zero(nv);

  for (RobotStateSample& s : slot_state_) {
    s.q = s.tau = Eigen::VectorXd::Zero(model.njoints);
    s.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model.njoints, true);
  }
  {
    // The gyro's window counts only where the gyro gives the base's rate (otherwise its weights are never used).
    const bool gyro = !opt_.base_rate_from_legs;
    const int L = gyro ? std::max(opt_.derivative_half_window, opt_.gyro_half_window) : opt_.derivative_half_window;
    sg_ = savitzkyGolayWeights(opt_.derivative_half_window, L);
    if (gyro) sg_gyro_ = savitzkyGolayWeights(opt_.gyro_half_window, L);
    raw_.resize(2 * L + 1);
  }
  for (Raw& r : raw_) r.q = r.tau = r.sensed = Eigen::VectorXd::Zero(model.njoints);
  state_ = ff_state_ = fk_state_ = State::zero(model);
  y_ = yf_ = tau_sensor_ = Eigen::VectorXd::Zero(nv);
  innovation_ = innovation_mean_ = innovation_ms_ = Eigen::VectorXd::Zero(nv);
  corr_mean_ = corr_ms_ = corr_var_ = tau_stddev_ = Eigen::VectorXd::Zero(nv);
  row_correlation_ = Eigen::VectorXd::Constant(nv, filter_correlation_);
  full_weight_ = rls_model_.row_weight;
  full_innovation_ = Eigen::VectorXd::Zero(nv);
  x_full_ = rls_.x;
  V_ = AV_ = Eigen::MatrixXd::Zero(mx, 4 + nv);
  AT_ = Eigen::MatrixXd::Zero(mx, mx);
  Kf_ = Eigen::MatrixXd::Zero(nv, p + ne_);
  if (ne_ > 0) Kx_ = Eigen::MatrixXd::Zero(nv, p + ne_);
}

long OnlineEstimator::rejected(InputStatus why) const { return rejected_[static_cast<int>(why)]; }

InputStatus OnlineEstimator::admit(int channel, long tick, SampleFault values, bool sizes_ok, int* slot) {
  InputStatus s = InputStatus::Accepted;
  // Sizes, then the tick assembly's order (a tick < 0, before the one being assembled, or already given on
  // this channel), then the values; a rejected message leaves the assembly untouched.
  const TickPlacement order = assembly_.check(channel, tick);
  if (!sizes_ok) s = InputStatus::Malformed;
  else if (order == TickPlacement::Duplicate) s = InputStatus::Duplicate;
  else if (order != TickPlacement::Accepted) s = InputStatus::OutOfOrder;  // window 0 with 2 slots: no Overflow
  else if (values == SampleFault::NonFinite) s = InputStatus::NonFinite;
  else if (values == SampleFault::Malformed) s = InputStatus::Malformed;
  if (s != InputStatus::Accepted) {
    ++rejected_[static_cast<int>(s)];
    return s;
  }
  assembly_.place(channel, tick, slot);
  return s;
}

void OnlineEstimator::processReleased() {
  ReleasedTick r;
  while (assembly_.release(r))
    if (r.complete) assemble(r.slot, static_cast<long>(r.tick));
}

InputStatus OnlineEstimator::addState(const RobotStateSample& s) {
  if (!ok()) return InputStatus::Malformed;
  // The gate's rules (sample_checks.hpp), as the LCM adapters apply them.
  const bool sizes = stateSizesOk(s, model_.njoints);
  int slot = -1;
  const InputStatus st = admit(kStateChannel, s.tick, sizes ? checkStateValues(s) : SampleFault::None, sizes, &slot);
  if (st != InputStatus::Accepted) return st;
  RobotStateSample& held = slot_state_[slot];  // sizes as preallocated: no allocation
  held.tick = s.tick;
  held.utime = s.utime;
  held.q = s.q;
  held.tau = s.tau;
  held.has_tau = s.has_tau;
  held.imu_orientation = s.imu_orientation;
  held.imu_gyro = s.imu_gyro;
  held.imu_accel = s.imu_accel;
  processReleased();
  return st;
}

InputStatus OnlineEstimator::addPlate(const ForcePlateSample& p) {
  if (!ok()) return InputStatus::Malformed;
  const bool sizes = plateIndexOk(p);
  int slot = -1;
  const InputStatus st = admit(sizes ? kRightPlate + p.plate : kRightPlate, p.tick, checkPlateValues(p), sizes, &slot);
  if (st != InputStatus::Accepted) return st;
  slot_plate_[slot][p.plate] = p;
  processReleased();
  return st;
}

void OnlineEstimator::assemble(int held, long tick) {
  // Raw values of this tick into the ring (the oldest slot is overwritten).
  const int n = static_cast<int>(raw_.size());
  const int slot = (raw_head_ + raw_count_) % n;
  Raw& r = raw_[raw_count_ < n ? slot : raw_head_];
  if (raw_count_ == n) raw_head_ = (raw_head_ + 1) % n;
  else ++raw_count_;
  const RobotStateSample& s = slot_state_[held];
  r.tick = tick;
  r.q = s.q;
  for (int j = 0; j < model_.njoints; ++j) {
    r.tau[j] = s.has_tau[j] ? s.tau[j] : 0.0;
    r.sensed[j] = s.has_tau[j] ? 1.0 : 0.0;
  }
  r.orientation = s.imu_orientation.normalized();
  r.gyro = s.imu_gyro;
  // Accelerometer = R^T (a - g): the classical base acceleration is accel + R^T g (IMU frame = base frame).
  r.acceleration = s.imu_accel + r.orientation.conjugate() * model_.gravity;
  for (int i = 0; i < 2; ++i) {
    r.contact[i].body = feet_[i];
    footWrenchFromPlate(slot_plate_[held][i], r.contact[i].force, r.contact[i].moment_world_origin);
    r.plate_position[i] = slot_plate_[held][i].plate_position;
  }
  if (opt_.base_rate_from_legs) {
    fk_state_.q = r.q;  // base frame: the base at identity, no motion
    forwardKinematics(model_, fk_, fk_state_);
    for (int i = 0; i < 2; ++i) r.foot_rotation[i] = fk_.R[feet_[i]];
  }
  // The fit needs 2L + 1 consecutive ticks; after a gap the history (and the filter) restart from this one.
  if (raw_count_ >= 2 && r.tick != raw_[(raw_head_ + raw_count_ - 2) % n].tick + 1) {
    raw_head_ = (raw_head_ + raw_count_ - 1) % n;
    raw_count_ = 1;
    filter_.reset();
    return;
  }
  if (raw_count_ == n) process();
}

void OnlineEstimator::process() {
  // The state of the middle tick of the window (evaluated L ticks late): the quadratic fits' slope and curvature
  // (v, a through the encoders; omega and its derivative through the base's rotation from the legs, or the gyro's
  // value and slope), with L = 1 exactly the central differences. The configuration and the signals that enter y
  // and K linearly or barely (torques, plates, accelerometer, orientation) are the middle tick's own.
  const int n = static_cast<int>(raw_.size()), L = n / 2;
  const Raw& r1 = raw_[(raw_head_ + L) % n];
  State& st = state_;
  st.q = r1.q;
  st.v.setZero();
  st.a.setZero();
  st.base_omega.setZero();
  st.base_domega.setZero();
  for (int i = 0; i < n; ++i) {
    const Raw& ri = raw_[(raw_head_ + i) % n];
    st.v.noalias() += (sg_(1, i) / dt_) * ri.q;
    st.a.noalias() += (2.0 * sg_(2, i) / (dt_ * dt_)) * ri.q;
    if (opt_.base_rate_from_legs) {
      // Feet fixed in the world: R_wb,c^T R_wb,i = R_bf,c R_bf,i^T = exp([theta_i]) in the middle tick's base
      // frame; theta is the base's rotation since that tick, whose fitted slope and curvature are omega and its
      // derivative (base frame, as the gyro's). theta = vee of the skew part: its error O(|theta|^3) is ~1e-10
      // rad over the window. Averaged over the two feet.
      for (int f = 0; f < 2; ++f) {
        const Eigen::Matrix3d M = r1.foot_rotation[f] * ri.foot_rotation[f].transpose();
        const Eigen::Vector3d theta(0.5 * (M(2, 1) - M(1, 2)), 0.5 * (M(0, 2) - M(2, 0)), 0.5 * (M(1, 0) - M(0, 1)));
        st.base_omega.noalias() += (0.5 * sg_(1, i) / dt_) * theta;
        st.base_domega.noalias() += (sg_(2, i) / (dt_ * dt_)) * theta;
      }
    } else {
      st.base_omega.noalias() += sg_gyro_(0, i) * ri.gyro;
      st.base_domega.noalias() += (sg_gyro_(1, i) / dt_) * ri.gyro;
    }
  }
  st.base_orientation = r1.orientation;
  st.base_acceleration = r1.acceleration;
  st.base_velocity.setZero();  // does not enter the dynamics (docs/conventions.md)
  computeJointTorqueRegressor(model_, kin_, st);
  st.base_position = basePositionFromFootholds(footholds_, kin_, st.base_orientation.toRotationMatrix(), r1.plate_position);
  generalizedForceFromMeasurements(model_, kin_, st, r1.tau, r1.contact, 2, y_);
  has_state_ = true;
  if (effects_) {
    // Gains on the torque sensors' part of y (the plates' part through the leg is not scaled); the effect
    // columns at this sample's reconstructed joint velocity and acceleration, filtered with K like every column.
    for (int j = 0; j < model_.njoints; ++j) tau_sensor_[model_.jointRow(j)] = r1.tau[j];
    correctMeasurement(model_, opt_.effects, y_, tau_sensor_);
  }
  if (ne_ > 0) {
    const int p = model_.nparams(), nd = effectColumnCount(), ns = ne_ - n_offset_;
    Kx_.leftCols(p) = kin_.K;
    if (nd > 0) effectColumns(model_, opt_.effects, st.q, st.v, st.a, Kx_.middleCols(p, nd));
    // The sensor columns: offsets (1 where the joint has a sensor), then gains (its measured torque).
    const int nj = model_.njoints;
    const bool offsets = opt_.sensor_offset_sigma > 0.0;
    for (int j = 0; j < n_offset_; ++j) {
      const int jj = j % nj;
      const bool gain = !offsets || j >= nj;
      Kx_(model_.jointRow(jj), p + ns + j) = gain ? r1.sensed[jj] * r1.tau[jj] : r1.sensed[jj];
    }
    filter_.filter(rls_model_, Kx_, y_, Kf_, yf_);
    // Dry friction as the diagnosis builds its column (and fits the sidecar's width for it): the tanh of the
    // filtered velocity (K's viscous column as filtered), not the filtered tanh of the raw differenced velocity,
    // whose shape at the same width differs (the knee's 3 N m: 4.0 N m online against 3.4 in the batch).
    int col = 0;
    for (const Effect& e : opt_.effects.effects) {
      if (isMeasurementEffect(e.kind)) continue;
      if (isDryFriction(e.kind)) {
        const int r = model_.jointRow(e.joint);
        Kf_(r, p + col) =
            effectSignal(e.kind, effectShape(opt_.effects.shape, e), 0.0, Kf_(r, model_.frictionParamIndex(e.joint)), 0.0,
                         0.0, 0.0);
      }
      ++col;
    }
  } else {
    filter_.filter(rls_model_, kin_.K, y_, Kf_, yf_);
  }
  if (Kf_.allFinite() && yf_.allFinite()) observeInnovation(r1.tick);
  if (updateRecursiveLs(rls_model_, rls_, r1.tick, Kf_, yf_) == SampleStatus::Accepted) {
    row_tick_ = r1.tick;
    ++since_publication_;
    ++block_samples_;
  } else {
    ++rejected_[static_cast<int>(InputStatus::NonFinite)];  // e.g. a kinematic singularity made K non-finite
  }
}

void OnlineEstimator::observeInnovation(long tick) {
  // Innovation of this sample against the last published estimate (before the sample is folded in): the
  // residuals' correlation time (the trust's uncertainty) and the change detector both read it.
  predictRecursiveLs(rls_model_, rls_, Kf_, innovation_);
  innovation_ = yf_ - innovation_;
  if (weighting_ == RowWeighting::WlsRCorrelated) {
    predictRecursiveLs(rls_model_, x_full_, Kf_, full_innovation_);
    full_innovation_ = yf_ - full_innovation_;
    trackResidualCorrelation(full_innovation_);
  } else {
    trackResidualCorrelation(innovation_);
  }
  if (opt_.change_threshold > 0.0) detectChange(tick);
}

void OnlineEstimator::detectChange(long tick) {
  const double a_mean = std::min(1.0, 1.0 / (opt_.change_window_s * opt_.sample_hz));
  const double a_ms = std::min(1.0, 1.0 / (opt_.change_baseline_s * opt_.sample_hz));
  innovation_mean_ += a_mean * (innovation_ - innovation_mean_);
  // The baseline is the mean's own long-run mean square: scale-free against how correlated the filtered
  // innovations are (the raw innovation's RMS would be sqrt(window / correlation time) too large).
  innovation_ms_ += a_ms * (innovation_mean_.cwiseAbs2() - innovation_ms_);
  // The mean square started from 0 at the (re)arming: divide by the weight its samples have so far,
  // 1 - (1 - a)^n, so that it is unbiased from the first samples (2 s of a 10 s baseline hold only 18 %).
  ms_weight_ += a_ms * (1.0 - ms_weight_);
  ++change_samples_;
  if (rls_.solves == 0 || static_cast<double>(change_samples_) < opt_.change_hold_s * opt_.sample_hz) return;
  double z = 0.0;
  for (Eigen::Index c = 0; c < innovation_.size(); ++c)
    if (innovation_ms_[c] > 0.0)
      z = std::max(z, std::abs(innovation_mean_[c]) / std::sqrt(innovation_ms_[c] / ms_weight_));
  z_max_ = std::max(z_max_, z);
  if (!(z > opt_.change_threshold)) return;
  // The robot changed (a payload, a tool): keep change_keep of what the data said, the prior untouched.
  carrySensorInformation();  // the torque sensors did not change: what the data said of them stays
  discountRecursiveLs(rls_model_, rls_, opt_.change_keep);
  if (opt_.forgetting == Forgetting::Selective) {
    rss_carry_ *= opt_.change_keep;
    n_carry_ *= opt_.change_keep;
  }
  ++changes_;
  last_change_tick_ = tick;
  change_samples_ = 0;
  innovation_mean_.setZero();
  innovation_ms_.setZero();  // the baseline restarts with the changed robot
  ms_weight_ = 0.0;
}

void OnlineEstimator::fold() {
  // Selective forgetting (docs/estimator.md): S = base-parameter axes this block informed. The carried data
  // information R splits into R1 = R_{:S} R_SS^-1 R_{S:} (what R says about S) and R2 = R - R1 >= 0 (what it
  // says about the rest, R2 e_S = 0; Cao & Schwartz 2000's decomposition, on a coordinate subspace); only R1
  // is forgotten, with its data centre kept: R <- R - (1 - lb) R1, r <- r - (1 - lb) R_{:S} R_SS^-1 r_S.
  const int m = rls_model_.m;
  recursiveLsInformation(rls_model_, rls_, dD_, dd_);
  for (int j = 0; j < m; ++j)
    for (int i = j + 1; i < m; ++i) dD_(i, j) = dD_(j, i);
  const double lb = std::pow(opt_.lambda, static_cast<double>(block_samples_));
  const Eigen::MatrixXd& L0 = rls_model_.prior_information;
  int nS = 0;
  for (int j = 0; j < m; ++j) {
    // Forget axis j only where this block brings at least what forgetting takes ((1 - lb) R_jj) and a
    // meaningful amount against the prior: information on an axis never shrinks, so nothing winds up when
    // the excitation stops, while a persistently excited axis reaches exponential forgetting's steady state.
    const bool in_S = dD_(j, j) >= std::max(opt_.block_threshold * L0(j, j), (1.0 - lb) * R_(j, j));
    mask_[j] = in_S ? 1.0 : 0.0;  // P = diag(mask)
    nS += in_S ? 1 : 0;
  }
  if (nS > 0 && lb < 1.0) {
    // M = P R P + (I - P) + eps P: R_SS padded with the identity; eps keeps R2 >= 0 where R_SS is singular.
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) M_(i, j) = mask_[i] * mask_[j] * R_(i, j);
    for (int j = 0; j < m; ++j) M_(j, j) += mask_[j] > 0.0 ? 1e-10 * (R_(j, j) + L0(j, j)) : 1.0;
    mllt_.compute(M_);
    // Y = M^-1 P R and u = M^-1 P r vanish outside S, so R P Y = R Y and R P u = R u.
    // A column at a time: the blocked matrix solve and product need workspaces beyond Eigen's stack limit
    // (128 KiB) once m passes ~128 (extra columns), and this may not allocate.
    Y_ = mask_.asDiagonal() * R_;
    for (int j = 0; j < m; ++j) mllt_.solveInPlace(Y_.col(j));
    u_ = mask_.cwiseProduct(r_);
    mllt_.solveInPlace(u_);
    for (int j = 0; j < m; ++j) R1_.col(j).noalias() = R_ * Y_.col(j);
    dd_.noalias() -= (1.0 - lb) * R_ * u_;
    R_.noalias() -= (1.0 - lb) * R1_;
    for (int j = 0; j < m; ++j)
      for (int i = j + 1; i < m; ++i) R_(i, j) = R_(j, i) = 0.5 * (R_(i, j) + R_(j, i));
  }
  R_ += dD_;
  r_ += dd_;
  // Residual statistics: the block's residual sum of squares at the estimate just published, weighted like the
  // forgotten information (lb per block).
  for (int c = 0; c < rls_model_.nv; ++c)
    rss_carry_[c] = lb * rss_carry_[c] + rls_.residual_rms[c] * rls_.residual_rms[c] * rls_.effective_samples;
  n_carry_ = lb * n_carry_ + rls_.effective_samples;
  clearRecursiveLsSums(rls_model_, rls_);
  block_samples_ = 0;
}

void OnlineEstimator::sizeOutput(EstimatorOutputSample& out) const {
  const int p = model_.nparams(), m = rls_model_.m, nv = model_.nv;
  out.params = Eigen::VectorXd::Zero(p);
  out.param_stddev = Eigen::VectorXd::Zero(p);
  out.base_params = Eigen::VectorXd::Zero(m);
  out.base_stddev = Eigen::VectorXd::Zero(m);
  out.tau_correction = Eigen::VectorXd::Zero(nv);
  out.tau_correction_stddev = Eigen::VectorXd::Zero(nv);
  out.com_stddev.setZero();
  out.mass_stddev = 0.0;
  out.residual_rms = Eigen::VectorXd::Zero(nv);
}

void OnlineEstimator::fillOutput(EstimatorOutputSample& out) {
  const bool selective = opt_.forgetting == Forgetting::Selective;
  fitFullInformation();
  updateRowWeights();
  // The covariance costs m^3 (most of a publication): every uncertainty_every-th one, the stddevs kept between.
  const bool uncertainty = publications_++ % opt_.uncertainty_every == 0;
  const bool solved = solveRecursiveLs(rls_model_, rls_, uncertainty, &R_, &r_);
  reportResidualRms(selective, out);
  standardParameters(uncertainty, out);
  out.excitation = excitation();
  const bool consistent = judgeConsistency(solved, out);
  out.consistent = consistent;
  // tau_correction = K(q, 0, 0)(phi_hat - phi_model) = K_B (x - B phi_model) at the latest reconstructed configuration
  // (gravity terms only): the estimator does not know the controller's desired acceleration, and the measured
  // one (encoders differenced twice) is the noisiest signal it has.
  if (has_state_) {
    feedforwardTorque(out);
    controllerUncertainty(uncertainty, out);
  } else {
    out.tau_correction.setZero();
  }
  out.tick = row_tick_ >= 0 ? row_tick_ : 0;
  out.samples_used = rls_.accepted;
  out.rejected_nonfinite = static_cast<int32_t>(rejected_[static_cast<int>(InputStatus::NonFinite)] +
                                                rejected_[static_cast<int>(InputStatus::Malformed)] +
                                                rls_.rejected_nonfinite);
  out.rejected_out_of_order = static_cast<int32_t>(rejected_[static_cast<int>(InputStatus::OutOfOrder)]);
  out.rejected_duplicate = static_cast<int32_t>(rejected_[static_cast<int>(InputStatus::Duplicate)]);
  out.samples_rejected = out.rejected_nonfinite + out.rejected_out_of_order + out.rejected_duplicate;
  out.samples_missing = rls_.missing;
  const bool finite = solved && out.params.allFinite() && out.param_stddev.allFinite() && out.tau_correction.allFinite() &&
                      out.residual_rms.allFinite() && out.base_stddev.allFinite();
  // The stated uncertainty rests on the residuals' correlation time, measured over kCorrelationWindowS: before
  // one window of data it is not yet honest, so nothing is valid (docs/estimator.md, "Publication").
  const double warm_up = kCorrelationWindowS * opt_.sample_hz;
  valid_rest_ = finite && static_cast<double>(rls_.accepted) >= warm_up && out.excitation >= opt_.min_excitation;
  out.valid = valid_rest_ && consistent;
  since_publication_ = 0;
  if (selective && block_samples_ >= opt_.forget_every) fold();
}

double OnlineEstimator::wlsRWeight(int c) const {
  const double y_rms = std::sqrt(std::max(0.0, rls_.scale * rls_.yy[c] / rls_.effective_samples));
  return 1.0 / std::max(rls_.residual_rms[c], 1e-6 * y_rms + 1e-12);
}

void OnlineEstimator::fitFullInformation() {
  if (weighting_ != RowWeighting::WlsRCorrelated || rls_.effective_samples <= 0.0) return;
  rls_model_.row_weight = full_weight_;
  if (!solveRecursiveLs(rls_model_, rls_, false, &R_, &r_)) return;
  x_full_ = rls_.x;
  for (int c = 0; c < model_.nv; ++c) full_weight_[c] = wlsRWeight(c);
}

void OnlineEstimator::carrySensorInformation() {
  // Carried information R_ (selective forgetting's blocks, and this) is discounted like the data; the sensor
  // columns' then get back the marginal information the whole estimate held on them, centred on their estimate:
  // with the sensor block last in A = U^T U (upper Cholesky of the last solve), the Schur complement of the
  // rest is U_ss^T U_ss; less their prior's diagonal (which stays) it is what data and carried blocks said.
  const double keep = opt_.change_keep;
  R_ *= keep;
  r_ *= keep;
  const int n = n_offset_, mx = m_base_ + ne_;
  if (n == 0 || rls_.solves == 0) return;
  // Explicit loops (n = 2 njoints, 20 here): this runs in the per-sample path, where no product may allocate.
  const Eigen::MatrixXd& U = rls_.llt.matrixLLT();  // upper triangle: U
  const int o = mx - n;
  for (int i = 0; i < n; ++i)
    for (int j = i; j < n; ++j) {
      double sum = 0.0;
      for (int k = 0; k <= i; ++k) sum += U(o + k, o + i) * U(o + k, o + j);
      sensor_S_(i, j) = sensor_S_(j, i) = sum;
    }
  for (int j = 0; j < n; ++j) sensor_S_(j, j) -= rls_model_.prior_information(o + j, o + j);
  for (int i = 0; i < n; ++i) {
    double rhs = 0.0;
    for (int j = 0; j < n; ++j) {
      R_(o + i, o + j) += (1.0 - keep) * sensor_S_(i, j);
      rhs += sensor_S_(i, j) * rls_.x[o + j];
    }
    r_[o + i] += (1.0 - keep) * rhs;
  }
}

void OnlineEstimator::updateRowWeights() {
  const int nv = model_.nv;
  // WLS-R (thesis eqs. 29-32) online: sigma_c from the previous solve's residuals over the whole memory. The
  // sums are stored unweighted and weighted only here, so this is the exact WLS-R cost over the history. The
  // correlated variant divides by sqrt(T_c) (the previous publication's correlation time, >= the filter's):
  // one independent residual per T_c rows.
  if (weighting_ != RowWeighting::Fixed && rls_.solves > 0 && rls_.effective_samples > 0.0) {
    const bool per_independent = weighting_ == RowWeighting::WlsRCorrelated;
    for (int c = 0; c < nv; ++c)  // per independent sample: fitFullInformation has just solved (1 / its sigma_c)
      rls_model_.row_weight[c] = per_independent ? full_weight_[c] / std::sqrt(row_correlation_[c]) : wlsRWeight(c);
  }
}

void OnlineEstimator::reportResidualRms(bool selective, EstimatorOutputSample& out) const {
  const int nv = model_.nv;
  // Residual RMS over the estimate's memory (selective: earlier blocks carried, forgetting-weighted).
  if (selective) {
    const double n = n_carry_ + rls_.effective_samples;
    for (int c = 0; c < nv; ++c)
      out.residual_rms[c] = n > 0.0 ? std::sqrt((rss_carry_[c] + rls_.residual_rms[c] * rls_.residual_rms[c] *
                                                                     rls_.effective_samples) / n)
                                    : 0.0;
    out.effective_samples = n;
  } else {
    out.residual_rms = rls_.residual_rms;
    out.effective_samples = rls_.effective_samples;
  }
}

void OnlineEstimator::standardParameters(bool uncertainty, EstimatorOutputSample& out) {
  // Standard parameters and their uncertainty: phi = phi_prior + G (x - x0), var = diag(G C G^T) + var0.
  dx_ = rls_.x - rls_model_.x0;
  phi_.noalias() = G_ * dx_.head(m_base_);
  phi_ += phi_prior_;
  if (uncertainty) {
    GC_.noalias() = G_ * rls_.covariance.topLeftCorner(m_base_, m_base_);  // marginal over the effect columns
    for (int i = 0; i < phi_.size(); ++i)
      param_stddev_[i] = std::sqrt(std::max(0.0, GC_.row(i).dot(G_.row(i)) + phi_var0_[i]));
  }
  out.param_stddev = param_stddev_;
  out.params = phi_;
  out.base_params = rls_.x;
  out.base_stddev = rls_.sigma;
}

double OnlineEstimator::excitation() const {
  // Excitation: fraction of base parameters whose variance the data cut to 1 / (1 + excited_gain) of the prior's.
  // (Over the rigid model's base parameters: the effect columns are reported in base_params but not counted.)
  int excited = 0;
  for (int j = 0; j < m_base_; ++j)
    if (prior_sigma_[j] * prior_sigma_[j] >= (1.0 + opt_.excited_gain) * rls_.sigma[j] * rls_.sigma[j]) ++excited;
  return m_base_ > 0 ? static_cast<double>(excited) / m_base_ : 0.0;
}

bool OnlineEstimator::judgeConsistency(bool solved, EstimatorOutputSample& out) {
  // Consistency: the conditional mean reproduces x exactly (B G = I), so when its every link passes the
  // pseudo-inertia test it is the consistent answer; otherwise the last reconcile()'s phi_c, judged by its misfit.
  bool mean_ok = true;
  for (int b = 0; b < model_.nbodies; ++b)
    mean_ok = mean_ok &&
              checkConsistency(Vector10d(phi_.segment<kParamsPerBody>(model_.bodyParamIndex(b)))).consistent;
  bool consistent = mean_ok;
  chi2_ = ratio_ = 0.0;
  if (!mean_ok && have_phi_c_ && solved) {
    out.params = phi_c_;
    consistent = links_ok_ && misfit(out.residual_rms, out.effective_samples);
  }
  return consistent;
}

void OnlineEstimator::feedforwardTorque(EstimatorOutputSample& out) {
  const int nv = model_.nv;
  ff_state_ = state_;
  // Velocity terms left out too: at the protocol's slow moves they are small, and the Coulomb friction column
  // sign(v) at the twice-noisy differenced velocity near standstill flips at random, which put ~0.8 N m of
  // noise into every joint's tau_correction (measured: 4x the controller's joint-torque prediction error).
  ff_state_.v.setZero();
  ff_state_.base_omega.setZero();
  ff_state_.base_velocity.setZero();
  ff_state_.a.setZero();
  ff_state_.base_domega.setZero();
  ff_state_.base_acceleration.setZero();
  computeJointTorqueRegressor(model_, kin_, ff_state_);
  dx_.head(m_base_) = rls_.x.head(m_base_) - x_model_;
  for (int c = 0; c < nv; ++c) {
    double sum = 0.0;
    for (int j : rls_model_.active[c]) {
      if (j >= m_base_) break;  // active sets are sorted: the effect columns come last
      sum += kin_.K(c, rls_model_.independent[j]) * dx_[j];
    }
    out.tau_correction[c] = sum;
  }
  // The sidecar's effects, which the controller's model lacks entirely: each column as the estimator last
  // filtered it (F(E), the sample of `tick`: the smoothed velocity's friction, the offset) times its estimate.
  // Armature is left out, like the rigid part's acceleration terms.
  const int p = model_.nparams();
  for (int e = 0; e < ne_; ++e) {
    if (!ff_effect_[e]) continue;
    const int r = effect_row_[e];
    out.tau_correction[r] += Kf_(r, p + e) * rls_.x[m_base_ + e];
  }
}

bool OnlineEstimator::misfit(const Eigen::VectorXd& rms, double effective_samples) {
  d_.noalias() = B_ * phi_c_;
  d_ -= rls_.x.head(m_base_);
  // A = U^T U, U in the upper triangle. The effect columns (after the base ones) are held at their estimates:
  // the misfit's vector is [d; 0], and ||U [d; 0]||^2 = d^T A_bb d needs U's leading m x m block only.
  const Eigen::MatrixXd& U = rls_.llt.matrixLLT();
  const int m = static_cast<int>(d_.size());
  chi2_ = 0.0;
  for (int i = 0; i < m; ++i) {  // ||U d||^2 (explicit: no temporaries)
    double ui = 0.0;
    for (int j = i; j < m; ++j) ui += U(i, j) * d_[j];
    chi2_ += ui * ui;
  }
  // The weighted residual cost over the memory: sum_c g_c^2 rss_c = sum_c (g_c rms_c)^2 N_eff.
  double rss = 0.0;
  for (int c = 0; c < rls_model_.nv; ++c) {
    const double g = rls_model_.row_weight[c] * rms[c];
    rss += g * g * effective_samples;
  }
  ratio_ = rss > 0.0 ? std::sqrt(chi2_ / rss) : std::numeric_limits<double>::infinity();
  return ratio_ <= opt_.consistent_tolerance;
}

bool OnlineEstimator::reconcileDue() const {
  return opt_.consistent_every > 0 && rls_.solves > 0 && (publications_ - 1) % opt_.consistent_every == 0;
}

bool OnlineEstimator::beginReconcile(ReconcileJob& job) const {
  if (opt_.consistent_every <= 0 || rls_.solves == 0 || rls_.llt.info() != Eigen::Success) return false;
  // The base block (effect columns held at their estimates, as in misfit()): A_bb = U_bb^T U_bb.
  job.U = rls_.llt.matrixLLT().topLeftCorner(m_base_, m_base_).triangularView<Eigen::Upper>();
  job.x = rls_.x.head(m_base_);
  job.start = have_phi_c_ ? phi_c_ : phi_;
  job.done = false;
  return true;
}

void OnlineEstimator::solveReconcile(ReconcileJob& job) const {
  // Target rows: the prior where no base parameter looks, then the base misfit in the estimate's information
  // metric, U (B phi - x) with A = U^T U (the solve's Cholesky factor).
  const int m = m_base_;
  QuadraticTarget target;
  const int k = static_cast<int>(prior_rows_.rows());
  target.A.resize(k + m, prior_rows_.cols());
  target.A.topRows(k) = prior_rows_;
  target.A.bottomRows(m).noalias() = job.U * B_;
  target.b.resize(k + m);
  target.b.head(k) = prior_rows_rhs_;
  target.b.tail(m).noalias() = job.U * job.x;
  ConsistentOptions co;
  co.max_iterations = std::max(1, opt_.consistent_iterations);
  co.prior_weight = 1e-9;  // the target's rows are already full rank; this only keeps the Newton matrix definite
  const ConsistentResult res = solveConsistent(model_, target, phi_prior_, job.start, co);
  job.phi = res.phi;
  job.iterations = res.iterations;
  job.links_ok = true;
  for (const LinkConsistency& l : res.consistency) job.links_ok = job.links_ok && l.consistent;
  job.done = true;
}

void OnlineEstimator::finishReconcile(const ReconcileJob& job) {
  ++reconciles_;
  reconcile_iterations_ = job.iterations;
  if (!job.done || job.phi.size() != phi_c_.size() || !job.phi.allFinite()) return;
  phi_c_ = job.phi;
  have_phi_c_ = true;
  links_ok_ = job.links_ok;
}

void OnlineEstimator::reconcile(EstimatorOutputSample& out) {
  ReconcileJob job;
  if (!beginReconcile(job)) return;
  solveReconcile(job);
  finishReconcile(job);
  // The publication just made, with the new phi_c (unless the conditional mean was consistent itself).
  bool mean_ok = true;
  for (int b = 0; b < model_.nbodies; ++b)
    mean_ok = mean_ok &&
              checkConsistency(Vector10d(phi_.segment<kParamsPerBody>(model_.bodyParamIndex(b)))).consistent;
  if (mean_ok || !have_phi_c_) return;
  out.params = phi_c_;
  out.consistent = links_ok_ && misfit(out.residual_rms, out.effective_samples);
  out.valid = valid_rest_ && out.consistent;
}

bool OnlineEstimator::saveCheckpoint(const std::string& path, std::string* error) const {
  // The carried block information (selective forgetting) and the options that shape the estimate travel with
  // the recursive state; the structure check of loadRecursiveLs covers prior, weights and active sets.
  std::vector<double> extra = {double(static_cast<int>(opt_.forgetting)), opt_.lambda, double(opt_.forget_every),
                               opt_.block_threshold, opt_.cutoff_hz, double(opt_.filter_order),
                               double(opt_.derivative_half_window), double(opt_.gyro_half_window),
                               double(opt_.base_rate_from_legs), n_carry_,
                               double(block_samples_)};
  extra.insert(extra.end(), R_.data(), R_.data() + R_.size());
  extra.insert(extra.end(), r_.data(), r_.data() + r_.size());
  extra.insert(extra.end(), rss_carry_.data(), rss_carry_.data() + rss_carry_.size());
  for (long v : rejected_) extra.push_back(double(v));
  extra.push_back(double(assembly_.counts().incomplete));
  extra.insert(extra.end(), rls_model_.row_weight.data(), rls_model_.row_weight.data() + rls_model_.nv);
  // The residuals' correlation statistics: the correlated row weights are made from them.
  for (const Eigen::VectorXd* v : {&corr_mean_, &corr_ms_, &corr_var_, &row_correlation_, &full_weight_, &x_full_})
    extra.insert(extra.end(), v->data(), v->data() + v->size());
  const std::vector<double> sig = effectSignature();
  extra.insert(extra.end(), sig.begin(), sig.end());
  RecursiveLsModel structure = rls_model_;  // checked against the weights the estimator was built with
  structure.row_weight = initial_weights_;
  return saveRecursiveLs(structure, rls_, path, error, extra);
}

std::vector<double> OnlineEstimator::effectSignature() const {
  // The sidecar the estimator applies (columns and gains change what the sums mean): shape, then kind, joint,
  // value and width of every effect; nothing without a sidecar (checkpoints of before stay readable).
  std::vector<double> v;
  if (!effects_) return v;
  v = {double(opt_.effects.effects.size()), opt_.effects.shape.coulomb_width, opt_.effects.shape.stribeck_velocity,
       opt_.effect_prior_factor};
  for (const Effect& e : opt_.effects.effects)
    v.insert(v.end(), {double(static_cast<int>(e.kind)), double(e.joint), e.value, e.width});
  return v;
}

std::string OnlineEstimator::describeEffects(const std::vector<double>& sig) const {
  if (sig.size() < 4) return "no effects";
  std::string s = std::to_string(long(sig[0])) + " effect(s)";
  for (size_t i = 4; i + 3 < sig.size(); i += 4) {
    const int k = int(sig[i]), j = int(sig[i + 1]);
    char value[32];
    std::snprintf(value, sizeof value, "%.6g", sig[i + 2]);
    s += std::string(i == 4 ? ": " : ", ") + (j >= 0 && j < model_.njoints ? model_.joint_names[j] : "?") + " " +
         (k >= 0 && k < kEffectKinds ? effectKindName(static_cast<EffectKind>(k)) : "?") + " " + value;
  }
  return s;
}

bool OnlineEstimator::loadCheckpoint(const std::string& path, std::string* error) {
  RecursiveLsData restored = rls_;
  std::vector<double> extra;
  RecursiveLsModel structure = rls_model_;
  structure.row_weight = initial_weights_;
  if (!loadRecursiveLs(structure, restored, path, error, &extra)) {
    if (error && effectColumnCount() > 0)
      *error += " (this estimator has " + std::to_string(effectColumnCount()) + " effect column(s) from its sidecar)";
    return false;
  }
  const int m = rls_model_.m, nv = rls_model_.nv;
  const size_t want = 11 + size_t(m) * m + m + nv + 5 + 1 + nv + 5 * size_t(nv) + m;
  // The sidecar first: a checkpoint of an estimator with other effects is refused by name.
  const std::vector<double> sig = effectSignature();
  const std::vector<double> file_sig(extra.begin() + std::ptrdiff_t(std::min(extra.size(), want)), extra.end());
  if (extra.size() >= want && file_sig != sig) {
    if (error)
      *error = path + ": written by an estimator with other effects (checkpoint: " + describeEffects(file_sig) +
               "; this estimator: " + describeEffects(sig) + ")";
    return false;
  }
  if (extra.size() != want + sig.size()) {
    if (error) *error = path + ": not an exo_estimator checkpoint (estimator section missing or of another size)";
    return false;
  }
  if (extra[0] != double(static_cast<int>(opt_.forgetting)) || extra[1] != opt_.lambda ||
      extra[2] != double(opt_.forget_every) || extra[3] != opt_.block_threshold || extra[4] != opt_.cutoff_hz ||
      extra[5] != double(opt_.filter_order) || extra[6] != double(opt_.derivative_half_window) ||
      extra[7] != double(opt_.gyro_half_window) || extra[8] != double(opt_.base_rate_from_legs)) {
    if (error)
      *error = path + ": written with other options (forgetting, lambda, block, threshold, cutoff, filter order, "
                      "derivative windows or base rate source differ)";
    return false;
  }
  size_t i = 9;
  n_carry_ = extra[i++];
  block_samples_ = long(extra[i++]);
  std::copy(extra.begin() + i, extra.begin() + i + m * m, R_.data());
  i += size_t(m) * m;
  std::copy(extra.begin() + i, extra.begin() + i + m, r_.data());
  i += m;
  std::copy(extra.begin() + i, extra.begin() + i + nv, rss_carry_.data());
  i += nv;
  for (long& v : rejected_) v = long(extra[i++]);
  TickAssemblyCounts counts;
  counts.incomplete = long(extra[i++]);
  for (int c = 0; c < nv; ++c) rls_model_.row_weight[c] = extra[i++];
  for (Eigen::VectorXd* v : {&corr_mean_, &corr_ms_, &corr_var_, &row_correlation_, &full_weight_, &x_full_})
    for (Eigen::Index c = 0; c < v->size(); ++c) (*v)[c] = extra[i++];
  rls_ = std::move(restored);
  // The channels resume after the checkpoint's last tick; the differencing history and the filter restart.
  assembly_.restart(rls_.has_tick ? rls_.last_tick + 1 : -1, counts);
  raw_count_ = 0;
  raw_head_ = 0;
  filter_.reset();
  since_publication_ = 0;
  if (!solveRecursiveLs(rls_model_, rls_, true, &R_, &r_)) {
    if (error) *error = path + ": restored information is not positive definite";
    return false;
  }
  return true;
}

}  // namespace exoid::estimator
