#include "exoid/estimator/sole_tilt.hpp"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "exoid/model/kinematics.hpp"

namespace exoid::estimator {

namespace {
constexpr long kMinSamples = 100;
}  // namespace

Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

Eigen::Matrix3d legsRotation(const std::vector<Eigen::Matrix3d>& sole_world, const Eigen::Matrix3d* Rbs) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (size_t f = 0; f < sole_world.size(); ++f) M += sole_world[f] * Rbs[f].transpose();
  return nearestRotation(M);
}

std::string soleTiltColumnName(int k) {
  static const char* const axes[6] = {"fx", "fy", "fz", "nx", "ny", "nz"};
  if (k <= 0 || k >= kSoleTiltRegressors) return "1";
  return std::string(k <= 6 ? "right_" : "left_") + axes[(k - 1) % 6];
}

std::string describeSoleTilt(const SoleTilt& t) {
  if (!t.fitted) return "not fitted (" + std::to_string(t.samples) + " samples)";
  std::string out;
  char buf[96];
  for (int a = 0; a < 3; ++a) {
    std::string cols;
    for (int k = 1; k < kSoleTiltRegressors; ++k)
      if (t.columns[a] & (1 << k)) cols += (cols.empty() ? "" : " ") + soleTiltColumnName(k);
    std::snprintf(buf, sizeof buf, "%s%c %.3f mrad (", a ? ", " : "", "xyz"[a], 1e3 * t.explained_rms[a]);
    out += buf + (cols.empty() ? std::string("constant") : cols) + ")";
  }
  std::snprintf(buf, sizeof buf, "; the IMU's correction left %.2f / %.2f / %.2f mrad RMS", 1e3 * t.residual_rms[0],
                1e3 * t.residual_rms[1], 1e3 * t.residual_rms[2]);
  return "tilt explained " + out + buf;
}

Eigen::Matrix<double, kSoleTiltRegressors, 1> soleTiltRegressor(const MeasuredSample& s) {
  Eigen::Matrix<double, kSoleTiltRegressors, 1> x = Eigen::Matrix<double, kSoleTiltRegressors, 1>::Zero();
  x[0] = 1.0;
  for (int k = 0; k < std::min(s.ncontacts, 2); ++k) {
    const ExternalWrench& w = s.contact[k];
    x.segment<3>(1 + 6 * k) = w.force;
    // About the plate's sensor origin: about the world origin the force's arm would dwarf the foot's moment.
    x.segment<3>(4 + 6 * k) = w.moment_world_origin - s.plate_position[k].cross(w.force);
  }
  return x;
}

SoleTiltFit::SoleTiltFit(const Model& model, const std::vector<DatasetOptions::Foothold>& footholds)
    : model_(model), footholds_(footholds), fk_(model), state_(State::zero(model)) {
  xx_.setZero();
  xe_.setZero();
  ee_.setZero();
}

void SoleTiltFit::add(const MeasuredSample& s) {
  if (footholds_.empty() || s.q.size() != model_.njoints) return;
  state_.q = s.q;
  forwardKinematics(model_, fk_, state_);
  std::vector<Eigen::Matrix3d> Rbs(footholds_.size());
  for (size_t f = 0; f < footholds_.size(); ++f)
    Rbs[f] = fk_.R[footholds_[f].body] * footholds_[f].rotation_in_body;
  const Eigen::Matrix<double, kSoleTiltRegressors, 1> x = soleTiltRegressor(s);
  if (sole_world_.empty()) {
    early_.push_back({Rbs, s.base_orientation, x});
    if (static_cast<int>(early_.size()) == kSoleWorldSamples) flushEarly();
    return;
  }
  accumulate(Rbs, s.base_orientation, x);
}

void SoleTiltFit::flushEarly() {
  sole_world_.assign(footholds_.size(), Eigen::Matrix3d::Zero());
  for (const Early& e : early_)
    for (size_t f = 0; f < footholds_.size(); ++f) sole_world_[f] += e.imu.toRotationMatrix() * e.Rbs[f];
  for (Eigen::Matrix3d& R : sole_world_) R = nearestRotation(R);
  for (const Early& e : early_) accumulate(e.Rbs, e.imu, e.x);
  early_.clear();
}

void SoleTiltFit::accumulate(const std::vector<Eigen::Matrix3d>& Rbs, const Eigen::Quaterniond& imu,
                             const Eigen::Matrix<double, kSoleTiltRegressors, 1>& x) {
  const Eigen::AngleAxisd d(legsRotation(sole_world_, Rbs.data()).transpose() * imu.toRotationMatrix());
  const Eigen::Vector3d e = d.angle() * d.axis();
  xx_.noalias() += x * x.transpose();
  xe_.noalias() += x * e.transpose();
  ee_.noalias() += e * e.transpose();
  ++n_;
}

SoleTilt SoleTiltFit::finish() {
  if (sole_world_.empty() && !early_.empty()) flushEarly();  // a run shorter than kSoleWorldSamples
  SoleTilt out;
  out.samples = n_;
  if (n_ < kMinSamples) return out;
  // Columns scaled to unit RMS; a column that is zero throughout (no contact k) gets scale 1 and a zero coefficient.
  Eigen::Matrix<double, kSoleTiltRegressors, 1> scale;
  for (int k = 0; k < kSoleTiltRegressors; ++k) {
    const double r = std::sqrt(xx_(k, k) / static_cast<double>(n_));
    scale[k] = r > 0.0 ? 1.0 / r : 1.0;
  }
  const Eigen::Matrix<double, kSoleTiltRegressors, kSoleTiltRegressors> A = scale.asDiagonal() * xx_ * scale.asDiagonal();
  const Eigen::Matrix<double, kSoleTiltRegressors, 3> Ab = scale.asDiagonal() * xe_;
  Eigen::Matrix<double, kSoleTiltRegressors, 3> C = Eigen::Matrix<double, kSoleTiltRegressors, 3>::Zero();
  const double n_d = static_cast<double>(n_);
  // Per axis, forward selection by BIC (Schwarz 1978): the constant first, then the wrench component that lowers the
  // residual most, while n log(RSS / n) + k log n falls. A column the tilt does not follow only adds the IMU's noise
  // to the orientation (sigma sqrt(k / n) per column kept).
  for (int a = 0; a < 3; ++a) {
    std::vector<int> S{0};
    auto rss = [&](const std::vector<int>& set, Eigen::VectorXd* coef) {
      const int k = static_cast<int>(set.size());
      Eigen::MatrixXd As(k, k);
      Eigen::VectorXd bs(k);
      for (int i = 0; i < k; ++i) {
        bs[i] = Ab(set[i], a);
        for (int j = 0; j < k; ++j) As(i, j) = A(set[i], set[j]);
      }
      Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(As);
      cod.setThreshold(1e-10);
      *coef = cod.solve(bs);
      return ee_(a, a) - coef->dot(bs);
    };
    Eigen::VectorXd coef, best_coef;
    double best = rss(S, &best_coef);
    double bic = n_d * std::log(std::max(best, 1e-300) / n_d) + std::log(n_d);
    for (;;) {
      int pick = -1;
      double pick_rss = best;
      Eigen::VectorXd pick_coef;
      for (int c = 1; c < kSoleTiltRegressors; ++c) {
        if (std::find(S.begin(), S.end(), c) != S.end() || xx_(c, c) <= 0.0) continue;
        std::vector<int> T = S;
        T.push_back(c);
        const double r = rss(T, &coef);
        if (r < pick_rss) pick = c, pick_rss = r, pick_coef = coef;
      }
      if (pick < 0) break;
      const double k = static_cast<double>(S.size() + 1);
      const double b = n_d * std::log(std::max(pick_rss, 1e-300) / n_d) + k * std::log(n_d);
      if (!(b < bic)) break;
      S.push_back(pick), bic = b, best = pick_rss, best_coef = pick_coef;
    }
    for (size_t i = 0; i < S.size(); ++i) {
      C(S[i], a) = scale[S[i]] * best_coef[static_cast<Eigen::Index>(i)];
      out.columns[a] |= 1 << S[i];
    }
  }
  out.coefficients = C.transpose();
  const double n = static_cast<double>(n_);
  const Eigen::Matrix<double, kSoleTiltRegressors, 1> xm = xx_.col(0) / n;  // mean of x (x_0 = 1)
  bool finite = true;
  for (int a = 0; a < 3; ++a) {
    const Eigen::Matrix<double, kSoleTiltRegressors, 1> c = C.col(a);
    const double fit2 = c.dot(xx_ * c) / n;             // mean of (C x)^2
    const double res2 = ee_(a, a) / n - 2.0 * c.dot(xe_.col(a)) / n + fit2;
    const double mean_fit = c.dot(xm);
    finite = finite && std::isfinite(fit2) && std::isfinite(res2) && std::isfinite(mean_fit);  // max() hides a NaN
    out.correction_rms[a] = std::sqrt(std::max(0.0, ee_(a, a) / n));
    out.explained_rms[a] = std::sqrt(std::max(0.0, fit2 - mean_fit * mean_fit));
    out.residual_rms[a] = std::sqrt(std::max(0.0, res2));
  }
  // A non-finite wrench (or one whose square leaves the double range) leaves the band to the caller.
  out.fitted = finite && out.coefficients.allFinite();
  return out;
}

}  // namespace exoid::estimator
