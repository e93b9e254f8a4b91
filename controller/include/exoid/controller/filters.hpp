#pragma once
// Causal, sample-by-sample filters for the controller's state estimation (usable in batch by looping).
#include <Eigen/Core>

namespace exoid::controller {

/// Second-order Butterworth low-pass (bilinear transform with frequency pre-warping) on a vector of
/// independent channels. Direct form I: y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2, unit DC gain.
/// configure() sizes the state (allocates); reset()/filter() never allocate.
class LowPass2 {
 public:
  /// cutoff_hz <= 0 makes the filter a pass-through. Requires 0 < cutoff_hz < sample_hz / 2 otherwise.
  void configure(int channels, double cutoff_hz, double sample_hz);
  /// Sets the state as if `value` had been the input forever (no start-up transient for a constant).
  void reset(const Eigen::Ref<const Eigen::VectorXd>& value);
  /// One step; `in` and `out` may alias.
  void filter(const Eigen::Ref<const Eigen::VectorXd>& in, Eigen::Ref<Eigen::VectorXd> out);

  bool passThrough() const { return pass_through_; }
  int channels() const { return static_cast<int>(x1_.size()); }
  double b0() const { return b0_; }
  double b1() const { return b1_; }
  double b2() const { return b2_; }
  double a1() const { return a1_; }
  double a2() const { return a2_; }

 private:
  bool pass_through_ = true;
  double b0_ = 1.0, b1_ = 0.0, b2_ = 0.0, a1_ = 0.0, a2_ = 0.0;
  Eigen::VectorXd x1_, x2_, y1_, y2_;
};

}  // namespace exoid::controller
