#pragma once
// Causal parallel filtering of the online estimator's equations: the same causal Butterworth (4th order by default)
// low-pass (exoid::LowPassFilter, the one filter of exoid) on every regressor entry a row can touch and on y.
// Because the filter F is linear and time-invariant, K_k phi = y_k for every k implies F(K) phi = F(y):
// the filter's lag and attenuation act identically on both sides and cancel in the equations (the causal
// counterpart of the batch pipeline's FilterMode::Parallel, docs/identification.md "Filtering rule"), so the
// estimator sees less noise without the phase error that filtering only the inputs would put into K.
#include <Eigen/Core>

#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/signal/filters.hpp"

namespace exoid::estimator {

class CausalRowFilter {
 public:
  /// Channels: the structural entries of K (model.active) and the nv entries of y; an order-`order` Butterworth
  /// (even, 2..8). cutoff_hz <= 0 or >= sample_hz / 2: pass-through. Allocates.
  void configure(const RecursiveLsModel& model, double cutoff_hz, double sample_hz, int order = 2);
  /// One sample: K [nv x p], y [nv] -> Kf (structural entries written, the rest left as they are: zeros if
  /// Kf started as zeros), yf. The filter starts (and restarts) at rest on zero: the equations' virtual past
  /// 0 = 0 holds exactly and no single noisy sample is held. Allocation-free.
  void filter(const RecursiveLsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& K,
              const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::MatrixXd> Kf, Eigen::Ref<Eigen::VectorXd> yf);
  /// Forget the history (the next sample restarts the filter at rest on zero).
  void reset() { started_ = false; }

 private:
  LowPassFilter filter_;
  Eigen::VectorXd buffer_, zero_;  ///< [sum |active_c| + nv]
  bool started_ = false;
};

}  // namespace exoid::estimator
