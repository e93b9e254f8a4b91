#include "exoid/model/model.hpp"

#include <algorithm>

namespace exoid {

const char* const kBodyParamNames[kParamsPerBody] = {"m", "mcx", "mcy", "mcz", "Ixx",
                                                     "Ixy", "Ixz", "Iyy", "Iyz", "Izz"};

namespace {
int indexOf(const std::vector<std::string>& names, const std::string& name) {
  auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}
}  // namespace

int Model::bodyIndex(const std::string& n) const { return indexOf(body_names, n); }
int Model::jointIndex(const std::string& n) const { return indexOf(joint_names, n); }
int Model::frameIndex(const std::string& n) const {
  for (size_t i = 0; i < frames.size(); ++i)
    if (frames[i].name == n) return static_cast<int>(i);
  return -1;
}

std::vector<std::string> Model::paramNames() const {
  std::vector<std::string> names;
  names.reserve(nparams());
  for (int b = 0; b < nbodies; ++b)
    for (int k = 0; k < kParamsPerBody; ++k) names.push_back(body_names[b] + "." + kBodyParamNames[k]);
  for (int j = 0; j < njoints; ++j) {
    names.push_back(joint_names[j] + ".fv");
    names.push_back(joint_names[j] + ".fc");
  }
  return names;
}

std::vector<std::string> Model::coordinateNames() const {
  std::vector<std::string> names;
  names.reserve(nv);
  if (floating_base) names = {"base_nx", "base_ny", "base_nz", "base_fx", "base_fy", "base_fz"};
  names.insert(names.end(), joint_names.begin(), joint_names.end());
  return names;
}

double Model::totalMass() const {
  double m = 0.0;
  for (int b = 0; b < nbodies; ++b) m += phi[bodyParamIndex(b)];
  return m;
}

State State::zero(const Model& model) {
  State s;
  s.q = Eigen::VectorXd::Zero(model.njoints);
  s.v = Eigen::VectorXd::Zero(model.njoints);
  s.a = Eigen::VectorXd::Zero(model.njoints);
  return s;
}

Data::Data(const Model& model)
    : R(model.nbodies, Eigen::Matrix3d::Identity()),
      p(model.nbodies, Eigen::Vector3d::Zero()),
      axis(model.nbodies, Eigen::Vector3d::Zero()),
      omega(model.nbodies, Eigen::Vector3d::Zero()),
      vel(model.nbodies, Eigen::Vector3d::Zero()),
      alpha(model.nbodies, Eigen::Vector3d::Zero()),
      acc(model.nbodies, Eigen::Vector3d::Zero()),
      body_regressor(model.nbodies, Matrix6x10::Zero()),
      K(Eigen::MatrixXd::Zero(model.nv, model.nparams())) {}

}  // namespace exoid
