#pragma once
// Second-order Butterworth low-pass filter (bilinear transform with pre-warping), the one filter of exoid:
// causal and sample by sample (controller, online estimator; allocation-free after configure) or in batch,
// forward-backward for zero phase (offline identification, like MATLAB's filtfilt in the seed thesis,
// section III-E), plus the differentiation that goes with it.
#include <Eigen/Core>

namespace exoid {

/// y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2 (direct form I).
struct Biquad {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;
  /// 2nd-order Butterworth low-pass with unit DC gain; requires 0 < cutoff_hz < sample_hz / 2.
  static Biquad butterworthLowPass(double cutoff_hz, double sample_hz);
};

/// Causal filter of a vector of independent channels.
class LowPassFilter {
 public:
  /// Sizes the state (allocates). cutoff_hz <= 0 or >= sample_hz / 2 makes a pass-through.
  void configure(int channels, double cutoff_hz, double sample_hz);
  /// State as if `value` had been the input forever (no start-up transient for a constant). If reset is
  /// never called, the first filtered sample does it.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& value);
  /// One step; `in` and `out` may alias. Allocation-free.
  void filter(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> out);

  bool passThrough() const { return pass_through_; }
  int channels() const { return static_cast<int>(x1_.size()); }
  const Biquad& coefficients() const { return c_; }

 private:
  Biquad c_;
  bool pass_through_ = true, initialized_ = false;
  Eigen::VectorXd x1_, x2_, y1_, y2_;
};

/// Zero-phase filtering of every column of a signal [samples x width]: forward then backward pass, each
/// started from the odd reflection of the signal's ends (6 samples beyond each end, as filtfilt's 3 x order).
Eigen::MatrixXd filtfilt(const Biquad& coefficients, const Eigen::MatrixXd& signal);

/// Derivative of every column by central differences (one-sided at the ends), uniform sample time dt.
Eigen::MatrixXd differentiate(const Eigen::MatrixXd& signal, double dt);

}  // namespace exoid
