#include "exoid/signal/filters.hpp"

#include <cmath>

namespace exoid {

Biquad Biquad::butterworthLowPass(double fc, double fs) {
  const double k = std::tan(M_PI * fc / fs);  // pre-warped analogue cutoff
  const double norm = 1.0 / (1.0 + M_SQRT2 * k + k * k);
  Biquad c;
  c.b0 = k * k * norm;
  c.b1 = 2.0 * c.b0;
  c.b2 = c.b0;
  c.a1 = 2.0 * (k * k - 1.0) * norm;
  c.a2 = (1.0 - M_SQRT2 * k + k * k) * norm;
  return c;
}

void LowPassFilter::configure(int channels, double cutoff_hz, double sample_hz) {
  x1_ = x2_ = y1_ = y2_ = Eigen::VectorXd::Zero(channels);
  initialized_ = false;
  pass_through_ = !(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_hz);
  c_ = pass_through_ ? Biquad() : Biquad::butterworthLowPass(cutoff_hz, sample_hz);
}

void LowPassFilter::reset(const Eigen::Ref<const Eigen::VectorXd>& value) {
  x1_ = x2_ = y1_ = y2_ = value;
  initialized_ = true;
}

void LowPassFilter::filter(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> out) {
  if (pass_through_) {
    out = in;
    return;
  }
  if (!initialized_) reset(in);
  for (Eigen::Index i = 0; i < in.size(); ++i) {
    const double x = in[i];
    const double y = c_.b0 * x + c_.b1 * x1_[i] + c_.b2 * x2_[i] - c_.a1 * y1_[i] - c_.a2 * y2_[i];
    x2_[i] = x1_[i];
    x1_[i] = x;
    y2_[i] = y1_[i];
    y1_[i] = y;
    out[i] = y;
  }
}

namespace {
Eigen::VectorXd onePass(const Biquad& c, const Eigen::VectorXd& x) {
  Eigen::VectorXd y(x.size());
  double x1 = x[0], x2 = x[0], y1 = x[0], y2 = x[0];  // steady state at the first value
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    y[i] = c.b0 * x[i] + c.b1 * x1 + c.b2 * x2 - c.a1 * y1 - c.a2 * y2;
    x2 = x1, x1 = x[i], y2 = y1, y1 = y[i];
  }
  return y;
}
}  // namespace

Eigen::MatrixXd filtfilt(const Biquad& c, const Eigen::MatrixXd& signal) {
  const Eigen::Index n = signal.rows();
  const Eigen::Index pad = std::min<Eigen::Index>(6, n > 1 ? n - 1 : 0);
  Eigen::MatrixXd out(n, signal.cols());
  for (Eigen::Index col = 0; col < signal.cols(); ++col) {
    const Eigen::VectorXd x = signal.col(col);
    Eigen::VectorXd ext(n + 2 * pad);
    for (Eigen::Index i = 0; i < pad; ++i) {
      ext[i] = 2.0 * x[0] - x[pad - i];
      ext[n + pad + i] = 2.0 * x[n - 1] - x[n - 2 - i];
    }
    ext.segment(pad, n) = x;
    Eigen::VectorXd y = onePass(c, ext);
    y.reverseInPlace();
    y = onePass(c, y);
    y.reverseInPlace();
    out.col(col) = y.segment(pad, n);
  }
  return out;
}

Eigen::MatrixXd differentiate(const Eigen::MatrixXd& s, double dt) {
  const Eigen::Index n = s.rows();
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, s.cols());
  if (n < 2) return d;
  d.row(0) = (s.row(1) - s.row(0)) / dt;
  d.row(n - 1) = (s.row(n - 1) - s.row(n - 2)) / dt;
  if (n > 2) d.middleRows(1, n - 2) = (s.bottomRows(n - 2) - s.topRows(n - 2)) / (2.0 * dt);
  return d;
}

}  // namespace exoid
