// Butterworth design against its analytic frequency response; zero phase of the forward-backward pass;
// the causal per-sample filter equals the batch single pass; differentiation exact on quadratics.
#include <gtest/gtest.h>

#include <complex>

#include "exoid/estimator/filters.hpp"

namespace exoid {
namespace {

double gain(const Biquad& c, double f, double fs) {
  const std::complex<double> z = std::polar(1.0, 2.0 * M_PI * f / fs);
  const std::complex<double> zi = 1.0 / z, zi2 = zi * zi;
  return std::abs((c.b0 + c.b1 * zi + c.b2 * zi2) / (1.0 + c.a1 * zi + c.a2 * zi2));
}

TEST(Butterworth, UnitDcGainAndMinus3dBAtCutoff) {
  for (double fc : {30.0, 50.0, 70.0, 100.0}) {
    const Biquad c = Biquad::butterworthLowPass(fc, 1000.0);
    EXPECT_NEAR(gain(c, 0.0, 1000.0), 1.0, 1e-12);
    EXPECT_NEAR(gain(c, fc, 1000.0), 1.0 / std::sqrt(2.0), 1e-12);
    // Second order: about -40 dB per decade well above the cutoff.
    EXPECT_LT(gain(c, 4.0 * fc, 1000.0), 1.0 / 12.0);
  }
}

TEST(Butterworth, ForwardBackwardHasZeroPhase) {
  const double fs = 1000.0, f = 5.0;
  const int n = 4000;
  Eigen::MatrixXd x(n, 1);
  for (int i = 0; i < n; ++i) x(i, 0) = std::sin(2.0 * M_PI * f * i / fs);
  const Eigen::MatrixXd y = filtfilt(Biquad::butterworthLowPass(50.0, fs), x);
  // Away from the ends, the 5 Hz sine passes with gain |H|^2 and no delay.
  const double g2 = std::pow(gain(Biquad::butterworthLowPass(50.0, fs), f, fs), 2);
  for (int i = 500; i < n - 500; ++i) EXPECT_NEAR(y(i, 0), g2 * x(i, 0), 1e-6);
}

TEST(Butterworth, CausalStepMatchesTheRecursion) {
  const Biquad c = Biquad::butterworthLowPass(20.0, 1000.0);
  LowPassFilter filter(c, 1);
  Eigen::VectorXd v(1);
  double x1 = 1.0, x2 = 1.0, y1 = 1.0, y2 = 1.0;
  for (int i = 0; i < 200; ++i) {
    const double x = (i == 0) ? 1.0 : std::cos(0.1 * i);
    v[0] = x;
    filter.step(v);
    const double y = c.b0 * x + c.b1 * x1 + c.b2 * x2 - c.a1 * y1 - c.a2 * y2;
    x2 = x1, x1 = x, y2 = y1, y1 = y;
    EXPECT_NEAR(v[0], y, 1e-14);
  }
}

TEST(Differentiate, ExactOnQuadratics) {
  const int n = 50;
  const double dt = 0.01;
  Eigen::MatrixXd x(n, 1);
  for (int i = 0; i < n; ++i) x(i, 0) = 3.0 * (i * dt) * (i * dt) - 2.0 * i * dt;
  const Eigen::MatrixXd d = differentiate(x, dt);
  for (int i = 1; i < n - 1; ++i) EXPECT_NEAR(d(i, 0), 6.0 * i * dt - 2.0, 1e-9);
}

}  // namespace
}  // namespace exoid
