// Butterworth design against its analytic frequency response; zero phase of the forward-backward pass;
// the causal per-sample filter equals the batch single pass; differentiation exact on quadratics.
#include <gtest/gtest.h>

#include <algorithm>
#include <complex>
#include <random>

#include "exoid/signal/filters.hpp"

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

// The textbook forward-backward filter, one column at a time (the reference of the test below): the column extended
// by the odd reflection of its ends (6 samples beyond each, 3 x the order), one pass from the steady state at its
// first value, the same pass over the reversed result, reversed back, the extension cut off.
Eigen::VectorXd referenceFiltfilt(const Biquad& c, const Eigen::VectorXd& x) {
  const Eigen::Index n = x.size(), pad = std::min<Eigen::Index>(6, n - 1);
  Eigen::VectorXd e(n + 2 * pad);
  for (Eigen::Index i = 0; i < pad; ++i) e[i] = 2.0 * x[0] - x[pad - i], e[n + pad + i] = 2.0 * x[n - 1] - x[n - 2 - i];
  e.segment(pad, n) = x;
  for (int pass = 0; pass < 2; ++pass) {
    double x1 = e[0], x2 = e[0], y1 = e[0], y2 = e[0];
    for (Eigen::Index i = 0; i < e.size(); ++i) {
      const double y = c.b0 * e[i] + c.b1 * x1 + c.b2 * x2 - c.a1 * y1 - c.a2 * y2;
      x2 = x1, x1 = e[i], y2 = y1, y1 = y;
      e[i] = y;
    }
    e.reverseInPlace();
  }
  return e.segment(pad, n);
}

// filtfilt and its in-place, sample-major form (what the dataset's parallel filtering runs on its windows) give the
// reference's values, column by column, at every length the reflection treats specially (1, 2, up to the 6-sample pad
// and beyond), with the scratch reused across widths. Bit for bit where the compiler fuses no multiply-add (x86-64's
// baseline, CI's builds: measured equal); to 1e-14 of the column's scale where it may fuse them differently in the
// two loops (a target with FMA in its baseline, e.g. aarch64).
TEST(Butterworth, FiltfiltAndItsInPlaceSampleMajorFormEqualTheTextbookForwardBackwardPass) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  SampleMajorMatrix scratch;
  for (const Biquad& c : {Biquad::butterworthLowPass(5.0, 1000.0), Biquad::butterworthSection(30.0, 500.0, 4, 1)})
    for (Eigen::Index n : {1, 2, 3, 6, 7, 8, 13, 500})
      for (Eigen::Index w : {1, 3, 37}) {
        Eigen::MatrixXd x(n, w);
        for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] = g(rng) + (i % 5 == 0 ? 100.0 : 0.0);
        if (w > 1) {
          x.col(1).setZero();  // a structural zero of a regressor stays zero
        }
        Eigen::MatrixXd expected(n, w);
        for (Eigen::Index k = 0; k < w; ++k) expected.col(k) = referenceFiltfilt(c, x.col(k));
        SampleMajorMatrix y = x;
        filtfiltInPlace(c, y, scratch);
        const Eigen::MatrixXd z = filtfilt(c, x);
        for (Eigen::Index i = 0; i < n; ++i) {
          for (Eigen::Index k = 0; k < w; ++k) {
            const double tol = 1e-14 * (1.0 + expected.col(k).cwiseAbs().maxCoeff());
            ASSERT_NEAR(y(i, k), expected(i, k), tol) << "n " << n << " w " << w << " at (" << i << ", " << k << ")";
            ASSERT_NEAR(z(i, k), expected(i, k), tol) << "n " << n << " w " << w << " at (" << i << ", " << k << ")";
          }
        }
        if (w > 1) {
          EXPECT_EQ(y.col(1).cwiseAbs().maxCoeff(), 0.0);
        }
      }
}

TEST(Butterworth, CausalStepMatchesTheRecursion) {
  const Biquad c = Biquad::butterworthLowPass(20.0, 1000.0);
  LowPassFilter filter;
  filter.configure(1, 20.0, 1000.0);
  Eigen::VectorXd v(1);
  double x1 = 1.0, x2 = 1.0, y1 = 1.0, y2 = 1.0;
  for (int i = 0; i < 200; ++i) {
    const double x = (i == 0) ? 1.0 : std::cos(0.1 * i);
    v[0] = x;
    filter.filter(v, v);
    const double y = c.b0 * x + c.b1 * x1 + c.b2 * x2 - c.a1 * y1 - c.a2 * y2;
    x2 = x1, x1 = x, y2 = y1, y1 = y;
    EXPECT_NEAR(v[0], y, 1e-14);
  }
}

TEST(Butterworth, PassThroughAndReset) {
  LowPassFilter off;
  off.configure(2, 0.0, 1000.0);
  EXPECT_TRUE(off.passThrough());
  Eigen::VectorXd v(2), out(2);
  v << 1.5, -2.0;
  off.filter(v, out);
  EXPECT_EQ(out, v);
  LowPassFilter on;
  on.configure(2, 30.0, 1000.0);
  on.reset(v);
  on.filter(v, out);  // a constant stays constant from a reset state
  EXPECT_NEAR((out - v).norm(), 0.0, 1e-14);
}

TEST(Butterworth, MeasuredSineResponse) {
  const double fs = 1000.0, fc = 100.0;
  LowPassFilter f;
  f.configure(1, fc, fs);
  ASSERT_FALSE(f.passThrough());
  // Unit DC gain.
  const Biquad& b = f.coefficients();
  EXPECT_NEAR((b.b0 + b.b1 + b.b2) / (1.0 + b.a1 + b.a2), 1.0, 1e-12);
  // |H| at the cutoff is 1/sqrt(2) (-3 dB); at fs/4 (250 Hz) a 2nd-order Butterworth (bilinear, pre-warped)
  // gives 1/sqrt(1 + (tan(pi 250/1000) / tan(pi 100/1000))^4).
  auto gain = [&](double freq) {
    LowPassFilter g;
    g.configure(1, fc, fs);
    Eigen::VectorXd x(1), y(1);
    double cs = 0.0, sn = 0.0;
    const int n0 = 2000, n = 2000;  // settle, then correlate over whole periods of both test frequencies
    for (int k = 0; k < n0 + n; ++k) {
      const double ph = 2.0 * M_PI * freq * k / fs;
      x[0] = std::sin(ph);
      g.filter(x, y);
      if (k >= n0) {
        sn += y[0] * std::sin(ph);
        cs += y[0] * std::cos(ph);
      }
    }
    return 2.0 / n * std::hypot(sn, cs);
  };
  EXPECT_NEAR(gain(fc), 1.0 / std::sqrt(2.0), 0.01);
  const double r = std::tan(M_PI * 250.0 / fs) / std::tan(M_PI * fc / fs);
  EXPECT_NEAR(gain(250.0), 1.0 / std::sqrt(1.0 + std::pow(r, 4)), 0.01);
  // reset() to a constant: no transient.
  Eigen::VectorXd c = Eigen::VectorXd::Constant(1, 3.0), y(1);
  f.reset(c);
  f.filter(c, y);
  EXPECT_DOUBLE_EQ(y[0], 3.0);
  LowPassFilter off;
  off.configure(2, 0.0, fs);
  EXPECT_TRUE(off.passThrough());
}

TEST(Butterworth, HigherOrdersMatchTheClosedFormMagnitudeAndKeepUnitDcGain) {
  // An order-n Butterworth by the bilinear transform with pre-warping has |H(f)|^2 = 1 / (1 + (tan(pi f / fs) /
  // tan(pi fc / fs))^(2n)) exactly; the cascade's response is evaluated from its coefficients at z = e^(j w) and
  // compared with that formula (an independent computation), and a measured sine at fc is -3 dB.
  const double fs = 1000.0, fc = 2.0;
  for (int order : {2, 4, 6, 8}) {
    LowPassFilter f;
    f.configure(3, fc, fs, order);
    ASSERT_EQ(f.order(), order);
    for (double freq : {0.5, 1.0, 2.0, 4.0, 10.0, 50.0, 250.0}) {
      const std::complex<double> z = std::polar(1.0, 2.0 * M_PI * freq / fs), zi = 1.0 / z;
      std::complex<double> h = 1.0;
      for (int s = 0; s < order / 2; ++s) {
        const Biquad& b = f.coefficients(s);
        h *= (b.b0 + b.b1 * zi + b.b2 * zi * zi) / (1.0 + b.a1 * zi + b.a2 * zi * zi);
      }
      const double r = std::tan(M_PI * freq / fs) / std::tan(M_PI * fc / fs);
      EXPECT_NEAR(std::abs(h), 1.0 / std::sqrt(1.0 + std::pow(r, 2 * order)), 1e-9) << order << " " << freq;
    }
    // Driven: a constant from rest on it stays exact; a sine at fc settles to 1/sqrt(2) on every channel.
    Eigen::VectorXd c = Eigen::VectorXd::Constant(3, -2.5), y(3);
    f.reset(c);
    for (int k = 0; k < 10; ++k) f.filter(c, y);
    EXPECT_NEAR((y - c).norm(), 0.0, 1e-12);
    LowPassFilter g;
    g.configure(3, fc, fs, order);
    Eigen::VectorXd x(3);
    double sn = 0.0, cs = 0.0;
    const int n0 = 20000, n = 5000;  // 10 periods at 2 Hz after the transient
    for (int k = 0; k < n0 + n; ++k) {
      const double ph = 2.0 * M_PI * fc * k / fs;
      x.setConstant(std::sin(ph));
      g.filter(x, y);
      EXPECT_EQ(y[0], y[2]);
      if (k >= n0) sn += y[1] * std::sin(ph), cs += y[1] * std::cos(ph);
    }
    EXPECT_NEAR(2.0 / n * std::hypot(sn, cs), 1.0 / std::sqrt(2.0), 1e-3) << order;
  }
  // Order 2 is the single section of butterworthLowPass.
  const Biquad a = Biquad::butterworthLowPass(fc, fs), b = Biquad::butterworthSection(fc, fs, 2, 0);
  EXPECT_EQ(a.a1, b.a1);
  EXPECT_EQ(a.a2, b.a2);
  EXPECT_EQ(a.b0, b.b0);
}

TEST(Differentiate, ExactOnQuadratics) {
  const int n = 50;
  const double dt = 0.01;
  Eigen::MatrixXd x(n, 1);
  for (int i = 0; i < n; ++i) x(i, 0) = 3.0 * (i * dt) * (i * dt) - 2.0 * i * dt;
  const Eigen::MatrixXd d = differentiate(x, dt);
  for (int i = 1; i < n - 1; ++i) EXPECT_NEAR(d(i, 0), 6.0 * i * dt - 2.0, 1e-9);
}

// Savitzky-Golay (quadratic fit over 2L + 1 samples): the central differences at L = 1, exact value, slope and
// curvature of a quadratic everywhere (the ends included), and the slope's noise variance 3 / (L (L + 1) (2L + 1))
// against white noise (the reason the online estimator uses it: docs/estimator.md, "State").
TEST(SavitzkyGolay, CentralDifferencesAtOneExactOnQuadraticsAndTheNoiseFormula) {
  const Eigen::Matrix<double, 3, Eigen::Dynamic> w1 = savitzkyGolayWeights(1);
  Eigen::Matrix<double, 3, 3> central;
  central << 0.0, 1.0, 0.0, -0.5, 0.0, 0.5, 0.5, -1.0, 0.5;  // value, slope, curvature / 2
  EXPECT_LE((w1 - central).cwiseAbs().maxCoeff(), 1e-14);
  const Eigen::Matrix<double, 3, Eigen::Dynamic> padded = savitzkyGolayWeights(1, 3);
  ASSERT_EQ(padded.cols(), 7);
  EXPECT_EQ(padded.leftCols(2).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LE((padded.middleCols(2, 3) - central).cwiseAbs().maxCoeff(), 1e-14);

  const int n = 200, L = 20;
  const double dt = 1e-3;
  Eigen::MatrixXd x(n, 2);
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    x(i, 0) = 3.0 * t * t - 2.0 * t + 0.5;
    x(i, 1) = -t * t + 4.0 * t;
  }
  Eigen::MatrixXd v, d1, d2;
  savitzkyGolay(x, dt, L, &v, &d1, &d2);
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    EXPECT_NEAR(v(i, 0), x(i, 0), 1e-12) << i;
    EXPECT_NEAR(d1(i, 0), 6.0 * t - 2.0, 1e-8) << i;
    EXPECT_NEAR(d2(i, 0), 6.0, 1e-4) << i;
    EXPECT_NEAR(d1(i, 1), -2.0 * t + 4.0, 1e-8) << i;
    EXPECT_NEAR(d2(i, 1), -2.0, 1e-4) << i;
  }
  // The slope's weights: sum of squares = 3 / (L (L + 1) (2L + 1)), the variance of the slope per unit noise.
  const Eigen::Matrix<double, 3, Eigen::Dynamic> w = savitzkyGolayWeights(L);
  EXPECT_NEAR(w.row(1).squaredNorm(), 3.0 / (L * (L + 1.0) * (2 * L + 1.0)), 1e-15);
  // And on noise: the fitted slope's spread over many windows.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd e(20000, 1);
  for (int i = 0; i < e.rows(); ++i) e(i, 0) = g(rng);
  Eigen::MatrixXd slope;
  savitzkyGolay(e, 1.0, L, nullptr, &slope, nullptr);
  const double var = slope.middleRows(L, e.rows() - 2 * L).squaredNorm() / double(e.rows() - 2 * L);
  EXPECT_NEAR(var / w.row(1).squaredNorm(), 1.0, 0.05);
  // Fewer samples than a window: the largest window that fits (here L = 2), still exact on the quadratic.
  savitzkyGolay(x.topRows(5), dt, L, nullptr, &d1, nullptr);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(d1(i, 0), 6.0 * i * dt - 2.0, 1e-8) << i;
}

}  // namespace
}  // namespace exoid
