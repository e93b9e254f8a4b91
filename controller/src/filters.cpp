#include "exoid/controller/filters.hpp"

#include <cmath>

namespace exoid::controller {

void LowPass2::configure(int channels, double cutoff_hz, double sample_hz) {
  x1_ = Eigen::VectorXd::Zero(channels);
  x2_ = Eigen::VectorXd::Zero(channels);
  y1_ = Eigen::VectorXd::Zero(channels);
  y2_ = Eigen::VectorXd::Zero(channels);
  pass_through_ = !(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_hz);
  if (pass_through_) {
    b0_ = 1.0;
    b1_ = b2_ = a1_ = a2_ = 0.0;
    return;
  }
  const double k = std::tan(M_PI * cutoff_hz / sample_hz);
  const double k2 = k * k;
  const double norm = 1.0 / (1.0 + M_SQRT2 * k + k2);
  b0_ = k2 * norm;
  b1_ = 2.0 * b0_;
  b2_ = b0_;
  a1_ = 2.0 * (k2 - 1.0) * norm;
  a2_ = (1.0 - M_SQRT2 * k + k2) * norm;
}

void LowPass2::reset(const Eigen::Ref<const Eigen::VectorXd>& value) {
  x1_ = value;
  x2_ = value;
  y1_ = value;
  y2_ = value;
}

void LowPass2::filter(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> out) {
  if (pass_through_) {
    out = in;
    return;
  }
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    const double x = in[i];
    const double y = b0_ * x + b1_ * x1_[i] + b2_ * x2_[i] - a1_ * y1_[i] - a2_ * y2_[i];
    x2_[i] = x1_[i];
    x1_[i] = x;
    y2_[i] = y1_[i];
    y1_[i] = y;
    out[i] = y;
  }
}

}  // namespace exoid::controller
