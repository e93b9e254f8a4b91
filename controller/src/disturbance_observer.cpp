#include "exoid/controller/disturbance_observer.hpp"

#include <Eigen/Geometry>

namespace exoid::controller {

DisturbanceObserver::DisturbanceObserver(const DisturbanceConfig& config, double period, int nv)
    : cfg_(config),
      period_(period),
      d_(Eigen::VectorXd::Zero(nv)),
      nu_prev_(Eigen::VectorXd::Zero(nv)),
      planned_(Eigen::VectorXd::Zero(nv)),
      acc_(Eigen::VectorXd::Zero(nv)),
      err_(Eigen::VectorXd::Zero(nv)) {}

void DisturbanceObserver::reset() {
  d_.setZero();
  has_prev_ = has_planned_ = false;
}

void DisturbanceObserver::update(const Eigen::MatrixXd& M, const Eigen::VectorXd& nu, int64_t ticks_since_last,
                                 const Eigen::VectorXd* wrench_residual) {
  if (has_prev_ && has_planned_ && ticks_since_last >= 1) {
    const double dt = static_cast<double>(ticks_since_last) * period_;
    acc_ = (nu - nu_prev_) / dt;
    // dnu uses the classical base acceleration: d/dt of the base-frame velocity plus omega x v.
    acc_.segment<3>(3) += nu.head<3>().cross(nu.segment<3>(3));
    err_ = planned_ - acc_;
    d_.noalias() += (period_ / cfg_.time_constant) * (M * err_);
    if (wrench_residual) d_ += (period_ / cfg_.time_constant) * *wrench_residual;
    d_ = d_.cwiseMax(-cfg_.max_abs).cwiseMin(cfg_.max_abs);
  }
  nu_prev_ = nu;
  has_prev_ = true;
}

void DisturbanceObserver::setPlanned(const Eigen::Ref<const Eigen::VectorXd>& dnu) {
  planned_ = dnu;
  has_planned_ = true;
}

}  // namespace exoid::controller
