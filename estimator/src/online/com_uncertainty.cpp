// OnlineEstimator's uncertainty of what the controller uses (docs/estimator.md, "Trust"): the CoM and total mass of
// the estimate and its generalized-force correction, each with a one-sigma uncertainty from the estimate's own
// information, with the residuals' correlation in time accounted for (a sandwich covariance).
#include <algorithm>
#include <cmath>

#include "exoid/estimator/online/online_estimator.hpp"

namespace exoid::estimator {

double filterCorrelationTime(double cutoff_hz, double sample_hz, int order) {
  LowPassFilter f;
  f.configure(1, cutoff_hz, sample_hz, order);
  if (f.passThrough()) return 1.0;
  // (sum h)^2 / sum h^2 over the impulse response, long enough for the slowest pole to die out (20 periods).
  const long n = static_cast<long>(std::ceil(20.0 * sample_hz / cutoff_hz));
  Eigen::VectorXd in = Eigen::VectorXd::Zero(1), out(1);
  f.reset(in);
  double sum = 0.0, sum2 = 0.0;
  for (long k = 0; k < n; ++k) {
    in[0] = k == 0 ? 1.0 : 0.0;
    f.filter(in, out);
    sum += out[0];
    sum2 += out[0] * out[0];
  }
  return sum2 > 0.0 ? std::max(1.0, sum * sum / sum2) : 1.0;
}

void OnlineEstimator::trackResidualCorrelation(const Eigen::VectorXd& e) {
  // Batch means over a long window: for a stationary residual e with variance s^2 and integrated autocorrelation
  // time T (samples), the mean of a window of W >> T samples has variance s^2 T / W_eff. With the exponential
  // window of weight a (W_eff = (2 - a) / a), T = E[mean^2] / (E[e^2] a / (2 - a)). e: the innovation against the
  // full-information fit (RowWeighting::WlsRCorrelated), else the change detector's (the last publication's).
  const double a = std::min(1.0, 1.0 / (kCorrelationWindowS * opt_.sample_hz));
  const double b = std::min(1.0, 1.0 / (opt_.change_baseline_s * opt_.sample_hz));
  corr_mean_ += a * (e - corr_mean_);
  corr_ms_ += b * (corr_mean_.cwiseAbs2() - corr_ms_);
  corr_var_ += b * (e.cwiseAbs2() - corr_var_);
}

void OnlineEstimator::rowCorrelationTimes() {
  // Never below the row filter's own (white residuals filtered): the long window's statistic needs several
  // windows of data before it can be believed, and it underestimates while it builds up. A noise-free coordinate
  // (e = 0, e.g. a passive joint's) says nothing and keeps the floor.
  const double a = std::min(1.0, 1.0 / (kCorrelationWindowS * opt_.sample_hz));
  for (Eigen::Index c = 0; c < row_correlation_.size(); ++c)
    row_correlation_[c] = corr_var_[c] > 0.0
                              ? std::max(filter_correlation_, corr_ms_[c] / (corr_var_[c] * a / (2.0 - a)))
                              : filter_correlation_;
  correlation_ = row_correlation_.maxCoeff();
}

void OnlineEstimator::sandwichInformation() {
  // Var(x_hat) = A^-1 A_T A^-1 with A_T = Lambda0 + sum_c T_c g_c^4 sigma_c^2 D_c: the data's score
  // sum_k K_k^T W e_k has, per row c, the variance of T_c independent samples per T_c samples (rows taken as
  // mutually uncorrelated). With WLS-R weights (g_c sigma_c = 1) each row's information is scaled by its
  // correlation time; the prior's part (Lambda0) and carried information (selective forgetting) count once.
  const int nv = model_.nv;
  AT_.setZero();
  AT_.topLeftCorner(rls_model_.m, rls_model_.m).triangularView<Eigen::Upper>() = rls_model_.prior_information;
  AT_.triangularView<Eigen::Upper>() += R_;  // carried information (selective blocks, sensor columns): once
  for (int c = 0; c < nv; ++c) {
    const std::vector<int>& cols = rls_model_.active[c];
    const double g = rls_model_.row_weight[c], sd = rls_.residual_rms[c];
    const double f = row_correlation_[c] * g * g * std::max(g * g * sd * sd, kMinWeightedVariance) * rls_.scale;
    const int k = static_cast<int>(cols.size());
    for (int j = 0; j < k; ++j)
      for (int i = 0; i <= j; ++i) AT_(cols[i], cols[j]) += f * rls_.D[c](i, j);
  }
}

void OnlineEstimator::controllerUncertainty(bool uncertainty, EstimatorOutputSample& out) {
  const int m = m_base_, nv = model_.nv;
  rowCorrelationTimes();
  if (!uncertainty && have_trust_) {  // kept between uncertainty publications, like param_stddev
    out.com_stddev = com_stddev_;
    out.mass_stddev = mass_stddev_;
    out.tau_correction_stddev = tau_stddev_;
    return;
  }
  if (rls_.llt.info() != Eigen::Success) return;
  // Right-hand sides F [mx x (4 + nv)] (zero on the effect columns): the CoM's sensitivity (base frame), the
  // total mass's, each tau_correction row's (K_B at the gravity-only state, feedforwardTorque's).
  // CoM c = sum_b (m_b p_b + R_b h_b) / M at the estimate's state: dc/dm_b = (p_b - c) / M, dc/dh_b = R_b / M,
  // and through phi = phi_prior + G (x - x0), dc/dx = dc/dphi G; dM/dx = sum_b G's mass rows.
  double M = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (int b = 0; b < model_.nbodies; ++b) {
    const int i = model_.bodyParamIndex(b);
    M += phi_[i];
    first += phi_[i] * kin_.p[b] + kin_.R[b] * phi_.segment<3>(i + 1);
  }
  if (!(M > 0.0)) return;
  const Eigen::Vector3d c = first / M;
  V_.setZero();
  for (int b = 0; b < model_.nbodies; ++b) {
    const int i = model_.bodyParamIndex(b);
    V_.block(0, 0, m, 3).noalias() += G_.row(i).transpose() * ((kin_.p[b] - c) / M).transpose();
    V_.block(0, 0, m, 3).noalias() += G_.middleRows<3>(i + 1).transpose() * (kin_.R[b] / M).transpose();
    V_.block(0, 3, m, 1) += G_.row(i).transpose();
  }
  for (int r = 0; r < nv; ++r)
    for (int j : rls_model_.active[r]) {
      if (j >= m) break;
      V_(j, 4 + r) = kin_.K(r, rls_model_.independent[j]);
    }
  rls_.llt.solveInPlace(V_);  // A^-1 F
  sandwichInformation();
  AV_.noalias() = AT_.selfadjointView<Eigen::Upper>() * V_;
  Eigen::Matrix3d cov_base;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) cov_base(i, j) = V_.col(i).dot(AV_.col(j));
  const Eigen::Matrix3d R = state_.base_orientation.toRotationMatrix();
  com_cov_.noalias() = R * cov_base * R.transpose();
  com_cov_(2, 2) += height_prior_sigma_ * height_prior_sigma_;  // base_body_moves: the base rows do not tell it
  com_stddev_ = com_cov_.diagonal().cwiseMax(0.0).cwiseSqrt();
  mass_stddev_ = std::sqrt(std::max(0.0, V_.col(3).dot(AV_.col(3))));
  for (int r = 0; r < nv; ++r) tau_stddev_[r] = std::sqrt(std::max(0.0, V_.col(4 + r).dot(AV_.col(4 + r))));
  have_trust_ = true;
  out.com_stddev = com_stddev_;
  out.mass_stddev = mass_stddev_;
  out.tau_correction_stddev = tau_stddev_;
}

}  // namespace exoid::estimator
