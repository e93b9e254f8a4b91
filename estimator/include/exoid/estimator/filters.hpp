#pragma once
// Second-order Butterworth low-pass filter (bilinear transform with pre-warping), usable sample by sample
// (causal, allocation-free after construction) and in batch, forward-backward (zero phase, like MATLAB's
// filtfilt used by the thesis, section III-E), plus the differentiation that goes with it.
#include <Eigen/Core>

namespace exoid {

struct Biquad {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;  ///< y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2
  /// 2nd-order Butterworth low-pass; requires 0 < cutoff_hz < sample_hz / 2.
  static Biquad butterworthLowPass(double cutoff_hz, double sample_hz);
};

/// Causal filter of a vector signal [width], one sample per call. State starts at the first sample
/// (steady state), so there is no start-up transient from zero.
class LowPassFilter {
 public:
  LowPassFilter(const Biquad& coefficients, int width);
  /// Filters one sample in place: x [width].
  void step(Eigen::Ref<Eigen::VectorXd> x);
  void reset() { initialized_ = false; }

 private:
  Biquad c_;
  Eigen::VectorXd x1_, x2_, y1_, y2_;
  bool initialized_ = false;
};

/// Zero-phase filtering of every column of a signal [samples x width]: forward then backward pass, each
/// started from the odd reflection of the signal's ends (3 x order samples beyond each end, as filtfilt).
Eigen::MatrixXd filtfilt(const Biquad& coefficients, const Eigen::MatrixXd& signal);

/// Derivative of every column by central differences (one-sided at the ends), uniform sample time dt.
Eigen::MatrixXd differentiate(const Eigen::MatrixXd& signal, double dt);

}  // namespace exoid
