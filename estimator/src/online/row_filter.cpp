#include "exoid/estimator/online/row_filter.hpp"

namespace exoid::estimator {

void CausalRowFilter::configure(const RecursiveLsModel& model, double cutoff_hz, double sample_hz) {
  int channels = model.nv;
  for (const auto& cols : model.active) channels += static_cast<int>(cols.size());
  filter_.configure(channels, cutoff_hz, sample_hz);
  buffer_ = Eigen::VectorXd::Zero(channels);
  started_ = false;
}

void CausalRowFilter::filter(const RecursiveLsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& K,
                             const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::MatrixXd> Kf,
                             Eigen::Ref<Eigen::VectorXd> yf) {
  int i = 0;
  for (int c = 0; c < model.nv; ++c)
    for (int j : model.active[c]) buffer_[i++] = K(c, model.independent[j]);
  buffer_.tail(model.nv) = y;
  if (!started_) filter_.reset(buffer_), started_ = true;
  filter_.filter(buffer_, buffer_);
  i = 0;
  for (int c = 0; c < model.nv; ++c)
    for (int j : model.active[c]) Kf(c, model.independent[j]) = buffer_[i++];
  yf = buffer_.tail(model.nv);
}

}  // namespace exoid::estimator
