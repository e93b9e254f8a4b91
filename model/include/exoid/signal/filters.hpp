#pragma once
// Butterworth low-pass filter (bilinear transform with pre-warping; 2nd order, or an even order as a cascade of
// 2nd-order sections), the one filter of exoid:
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
  /// Section `section` (0-based) of an order-`order` Butterworth low-pass (order even, 2..kMaxOrder): the analogue
  /// prototype's pole pair with quality factor Q_k = 1 / (2 cos((2k + 1) pi / (2 order))), unit DC gain. The
  /// cascade of sections 0..order/2-1 is the order-`order` filter; order 2 is butterworthLowPass.
  static Biquad butterworthSection(double cutoff_hz, double sample_hz, int order, int section);
  static constexpr int kMaxOrder = 8;
};

/// Causal filter of a vector of independent channels.
class LowPassFilter {
 public:
  /// Sizes the state (allocates). cutoff_hz <= 0 or >= sample_hz / 2 makes a pass-through. order: even, 2..8
  /// (Biquad::kMaxOrder; others are clamped to the nearest valid one): a cascade of order / 2 sections.
  void configure(int channels, double cutoff_hz, double sample_hz, int order = 2);
  /// State as if `value` had been the input forever (no start-up transient for a constant). If reset is
  /// never called, the first filtered sample does it.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& value);
  /// One step; `in` and `out` may alias. Allocation-free.
  void filter(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> out);

  bool passThrough() const { return pass_through_; }
  int channels() const { return static_cast<int>(x1_.rows()); }
  int order() const { return 2 * sections_; }
  /// Coefficients of section `section` (the first by default; the only one at order 2).
  const Biquad& coefficients(int section = 0) const { return c_[section]; }

 private:
  Biquad c_[Biquad::kMaxOrder / 2];
  int sections_ = 1;
  bool pass_through_ = true, initialized_ = false;
  Eigen::MatrixXd x1_, x2_, y1_, y2_;  ///< [channels x sections] each section's input and output history
};

/// Zero-phase filtering of every column of a signal [samples x width]: forward then backward pass, each
/// started from the odd reflection of the signal's ends (6 samples beyond each end, as filtfilt's 3 x order).
Eigen::MatrixXd filtfilt(const Biquad& coefficients, const Eigen::MatrixXd& signal);

/// Sample-major signal [samples x width], row-major: one sample's channels contiguous.
using SampleMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// filtfilt of a sample-major signal, in place (filtfilt itself is this on a copy): all channels advance together
/// through contiguous rows, so a wide signal such as a window of regressor rows, [samples x nv p], is filtered without
/// a strided pass per column; channels that are zero throughout are skipped. scratch: resized as needed, reused
/// between calls ([4 + 2 x 6, width]).
void filtfiltInPlace(const Biquad& coefficients, SampleMajorMatrix& signal, SampleMajorMatrix& scratch);

/// Derivative of every column by central differences (one-sided at the ends), uniform sample time dt.
Eigen::MatrixXd differentiate(const Eigen::MatrixXd& signal, double dt);

/// Savitzky-Golay weights of the least-squares quadratic c0 + c1 i + c2 i^2 through the samples i = -L..L
/// (Savitzky & Golay 1964): row 0 gives the fitted value c0 at i = 0, row 1 the slope c1 (per sample), row 2 the
/// coefficient c2 (second derivative 2 c2 per sample^2). [3 x 2 width + 1], the fit's 2L + 1 weights centred in it
/// and zeros around (width >= L; width = L without it). L = 1: the central differences (q1, (q2 - q0) / 2,
/// (q2 - 2 q1 + q0) / 2). The slope's noise variance is 3 / (L (L + 1) (2L + 1)) of a sample's.
Eigen::Matrix<double, 3, Eigen::Dynamic> savitzkyGolayWeights(int half_window, int width = -1);

/// Value, first and second derivative of every column of a signal [samples x width]: those of the
/// least-squares quadratic through the 2L + 1 samples around each sample (savitzkyGolayWeights); the first and
/// last L samples take the fit of the first and last full window at their own position. Uniform sample time dt;
/// fewer than 2L + 1 samples: the largest window that fits. L = 1: the central differences inside. Any output
/// may be null, or the signal itself (the outputs are assigned after the signal has been read).
void savitzkyGolay(const Eigen::MatrixXd& signal, double dt, int half_window, Eigen::MatrixXd* value,
                   Eigen::MatrixXd* first, Eigen::MatrixXd* second);

}  // namespace exoid
