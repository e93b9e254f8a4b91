#include "exoid/estimator/online/row_filter.hpp"

namespace exoid::estimator {

void CausalRowFilter::configure(const RecursiveLsModel& model, double cutoff_hz, double sample_hz, int order) {
  int channels = model.nv;
  for (const auto& cols : model.active) channels += static_cast<int>(cols.size());
  filter_.configure(channels, cutoff_hz, sample_hz, order);
  buffer_ = zero_ = Eigen::VectorXd::Zero(channels);
  started_ = false;
}

void CausalRowFilter::filter(const RecursiveLsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& K,
                             const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::MatrixXd> Kf,
                             Eigen::Ref<Eigen::VectorXd> yf) {
  int i = 0;
  for (int c = 0; c < model.nv; ++c)
    for (int j : model.active[c]) buffer_[i++] = K(c, model.independent[j]);
  buffer_.tail(model.nv) = y;
  // (Re)started at rest on zero, not on the first sample: the virtual past K = 0, y = 0 satisfies every
  // equation, while resting on the first sample would hold its raw noise (accelerations differenced twice) for
  // the filter's whole memory. With sample loss every gap restarts the filter, and that held noise in K biased
  // the live estimate (hip tau_correction ~1.2 N m for a true 0, docs/estimator.md).
  if (!started_) filter_.reset(zero_), started_ = true;
  filter_.filter(buffer_, buffer_);
  i = 0;
  for (int c = 0; c < model.nv; ++c)
    for (int j : model.active[c]) Kf(c, model.independent[j]) = buffer_[i++];
  yf = buffer_.tail(model.nv);
}

}  // namespace exoid::estimator
