#include "exoid/estimator/measurement.hpp"

namespace exoid {

void generalizedForceFromMeasurements(const Model& model, const Data& kin, const State& state,
                                      const Eigen::VectorXd& tau_joints, const ExternalWrench* contacts,
                                      int ncontacts, Eigen::Ref<Eigen::VectorXd> y) {
  y.setZero();
  const int free_joint_rows = model.floating_base ? 6 : 0;
  y.tail(model.njoints) = tau_joints;
  Eigen::Matrix3d Rt = Eigen::Matrix3d::Identity();
  if (model.floating_base) Rt = state.base_orientation.toRotationMatrix().transpose();
  const Eigen::Vector3d pb = model.floating_base ? state.base_position : Eigen::Vector3d::Zero();
  for (int c = 0; c < ncontacts; ++c) {
    const ExternalWrench& w = contacts[c];
    // Wrench about the reference (base) origin in reference coordinates.
    const Eigen::Vector3d f = Rt * w.force;
    const Eigen::Vector3d n = Rt * (w.moment_world_origin - pb.cross(w.force));
    if (model.floating_base) {
      y.head<3>() += n;
      y.segment<3>(3) += f;
    }
    for (int a = w.body; a >= 0; a = model.parent[a]) {
      const int j = model.jointOfBody(a);
      if (j < 0) break;
      y[free_joint_rows + j] += kin.axis[a].dot(n) + kin.p[a].cross(kin.axis[a]).dot(f);
    }
  }
}

}  // namespace exoid
