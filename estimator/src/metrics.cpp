#include "exoid/estimator/metrics.hpp"

#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "exoid/model/inertial.hpp"
#include "exoid/model/kinematics.hpp"

namespace exoid::estimator {

namespace {

Eigen::Matrix3d skew3(const Eigen::Vector3d& x) {
  Eigen::Matrix3d S;
  S << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return S;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

std::vector<int> actuatedJoints(const Model& model) {
  std::vector<int> out;
  for (int j = 0; j < model.njoints; ++j)
    if (model.effort_limit.size() > j && model.effort_limit[j] > 0.0) out.push_back(j);
  return out;
}

double estimationErrorPercent(const Model& model, const Eigen::VectorXd& phi, const Eigen::VectorXd& phi_true) {
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < model.nInertialParams(); ++i) {
    if (phi_true[i] == 0.0) continue;
    sum += std::abs((phi[i] - phi_true[i]) / phi_true[i]);
    ++n;
  }
  return n > 0 ? 100.0 * sum / n : kNaN;
}

Eigen::VectorXd linkEstimationErrorPercent(const Model& model, const Eigen::VectorXd& phi,
                                           const Eigen::VectorXd& phi_true) {
  Eigen::VectorXd out(model.nbodies);
  for (int b = 0; b < model.nbodies; ++b) {
    double sum = 0.0;
    int n = 0;
    for (int k = 0; k < kParamsPerBody; ++k) {
      const int i = model.bodyParamIndex(b) + k;
      if (phi_true[i] == 0.0) continue;
      sum += std::abs((phi[i] - phi_true[i]) / phi_true[i]);
      ++n;
    }
    out[b] = n > 0 ? 100.0 * sum / n : kNaN;
  }
  return out;
}

void comAndMomentumMaps(const Model& model, const Data& kin, const Eigen::Vector3d& about,
                        Eigen::Ref<Eigen::MatrixXd> N, Eigen::Ref<Eigen::MatrixXd> Y) {
  N.setZero();
  Y.setZero();
  for (int b = 0; b < model.nbodies; ++b) {
    const int i = model.bodyParamIndex(b);
    const Eigen::Matrix3d& R = kin.R[b];
    N.col(i) = kin.p[b];
    N.middleCols<3>(i + 1) = R;
    Eigen::Matrix<double, 6, 1> V;  // body-frame velocity of the body origin
    V << R.transpose() * kin.omega[b], R.transpose() * kin.vel[b];
    const Eigen::Matrix<double, 6, 10> Yb = momentumRegressor(V);  // about the body origin, body coordinates
    const Eigen::Matrix<double, 3, 10> P = R * Yb.bottomRows<3>();
    Y.middleCols<kParamsPerBody>(i).topRows<3>() = R * Yb.topRows<3>() + skew3(kin.p[b] - about) * P;
    Y.middleCols<kParamsPerBody>(i).bottomRows<3>() = P;
  }
}

double QuadraticForm::value(const Eigen::VectorXd& phi, const Eigen::VectorXd& phi_ref) const {
  const Eigen::VectorXd d = phi - phi_ref;
  return d.dot(G.selfadjointView<Eigen::Lower>() * d) + 2.0 * c.dot(d) + s;
}

MetricAccumulator::MetricAccumulator(const Model& model, const Eigen::VectorXd& phi_true, std::vector<int> actuated,
                                     int block)
    : model_(model), phi_true_(phi_true), actuated_(std::move(actuated)), block_(std::max(block, 1)), dyn_(model) {
  const int p = model.nparams();
  mass_row_ = Eigen::RowVectorXd::Zero(p);
  for (int b = 0; b < model.nbodies; ++b) mass_row_[model.bodyParamIndex(b)] = 1.0;
  const int na = static_cast<int>(actuated_.size());
  comps_[kGen] = model.nv;
  comps_[kTorque] = na;
  comps_[kReal] = na;
  for (int f = 0; f < kForms; ++f) {
    forms_[f].G = Eigen::MatrixXd::Zero(p, p);
    forms_[f].c = Eigen::VectorXd::Zero(p);
    buf_B_[f].resize(block_ * std::max(comps_[f], 1), p);
    buf_t_[f].resize(block_ * std::max(comps_[f], 1));
  }
}

void MetricAccumulator::push(int f, const Eigen::Ref<const Eigen::MatrixXd>& B,
                             const Eigen::Ref<const Eigen::VectorXd>& t) {
  const int n = static_cast<int>(B.rows());
  if (buf_rows_[f] + n > buf_B_[f].rows()) flush(f);
  buf_B_[f].middleRows(buf_rows_[f], n) = B;
  buf_t_[f].segment(buf_rows_[f], n) = t;
  buf_rows_[f] += n;
  forms_[f].samples += 1;
}

void MetricAccumulator::flush(int f) {
  const int n = buf_rows_[f];
  if (n == 0) return;
  const auto B = buf_B_[f].topRows(n);
  const Eigen::VectorXd e0 = B * phi_true_ - buf_t_[f].head(n);
  forms_[f].G.selfadjointView<Eigen::Lower>().rankUpdate(B.transpose());
  forms_[f].c.noalias() += B.transpose() * e0;
  forms_[f].s += e0.squaredNorm();
  forms_[f].rows += n;
  buf_rows_[f] = 0;
}

void MetricAccumulator::finish() {
  for (int f = 0; f < kForms; ++f) flush(f);
}

bool MetricAccumulator::add(const State& state, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
  if (!K.allFinite() || !y.allFinite() || !state.q.allFinite() || !state.v.allFinite()) return false;
  const int p = model_.nparams();
  push(kGen, K, y);
  Eigen::MatrixXd Bt(actuated_.size(), p);
  Eigen::VectorXd tt(actuated_.size());
  for (size_t k = 0; k < actuated_.size(); ++k) {
    const int row = model_.jointRow(actuated_[k]);
    Bt.row(static_cast<Eigen::Index>(k)) = K.row(row);
    tt[static_cast<Eigen::Index>(k)] = y[row];
  }
  push(kTorque, Bt, tt);
  forwardKinematics(model_, dyn_.kin, state);
  Eigen::MatrixXd N(3, p), Y(6, p);
  comAndMomentumMaps(model_, dyn_.kin, Eigen::Vector3d::Zero(), N, Y);
  const Eigen::Vector3d com_true = N * phi_true_ / mass_row_.dot(phi_true_);
  // CoM error times the estimate's mass: (N - c_true m^T) phi, zero at phi_true.
  push(kCom, N - com_true * mass_row_, Eigen::Vector3d::Zero());
  comAndMomentumMaps(model_, dyn_.kin, com_true, N, Y);
  push(kMomentum, Y, Y * phi_true_);
  return true;
}

bool MetricAccumulator::addRealistic(const Eigen::MatrixXd& K, const Eigen::MatrixXd& JgT,
                                     const Eigen::VectorXd& fa_prev, const Eigen::VectorXd& fa) {
  if (!K.allFinite() || !JgT.allFinite() || !fa_prev.allFinite() || !fa.allFinite()) return false;
  const int nv = model_.nv, p = model_.nparams();
  // (J_g^T)^+ by a complete orthogonal decomposition (least squares, minimum norm).
  const Eigen::MatrixXd P = JgT.completeOrthogonalDecomposition().pseudoInverse();  // [e x nv]
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(nv, nv) - JgT * P;
  Eigen::VectorXd Sfa = Eigen::VectorXd::Zero(nv);
  for (int j : actuated_) Sfa[model_.jointRow(j)] = fa_prev[j];
  const Eigen::MatrixXd MK = M * K;
  const Eigen::VectorXd offset = JgT * (P * Sfa);
  // Predicted f_a = S (M K phi + J^T P S^T f_a_prev); error = B phi - t.
  Eigen::MatrixXd B(actuated_.size(), p);
  Eigen::VectorXd t(actuated_.size());
  for (size_t k = 0; k < actuated_.size(); ++k) {
    const int row = model_.jointRow(actuated_[k]);
    B.row(static_cast<Eigen::Index>(k)) = MK.row(row);
    t[static_cast<Eigen::Index>(k)] = fa[actuated_[k]] - offset[row];
  }
  push(kReal, B, t);
  return true;
}

Metrics MetricAccumulator::evaluate(const Eigen::VectorXd& phi) const {
  auto rmse = [&](int f) {
    const QuadraticForm& q = forms_[f];
    return q.rows > 0 ? std::sqrt(std::max(q.value(phi, phi_true_), 0.0) / static_cast<double>(q.rows)) : kNaN;
  };
  Metrics m;
  m.generalized_force_rmse = rmse(kGen);
  m.joint_torque_rmse = rmse(kTorque);
  const double mass = mass_row_.dot(phi);
  if (forms_[kCom].rows == 0)
    m.com_position_rmse_mm = kNaN;
  else if (!(mass > 0.0))
    m.com_position_rmse_mm = std::numeric_limits<double>::infinity();
  else
    m.com_position_rmse_mm = 1000.0 * rmse(kCom) / mass;
  m.com_momentum_rmse = rmse(kMomentum);
  m.realistic_torque_rmse = rmse(kReal);
  m.estimation_error_percent = estimationErrorPercent(model_, phi, phi_true_);
  return m;
}

}  // namespace exoid::estimator
