#pragma once
// Test-side conversions between MuJoCo's state and exoid::State, written independently of the sim library
// so that the regressor proof does not share code with what it checks, and the exoskeleton fixture.
#include <mujoco/mujoco.h>

#include <random>
#include <vector>

#include "exoid/model/model.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/urdf.hpp"
#include "support/mujoco_fixture.hpp"
#include "support/paths.hpp"

namespace exoid::test {

/// Addresses of the model's joints in a MuJoCo model (by joint name).
struct MujocoMap {
  int free_qpos = -1, free_dof = -1;  ///< -1 for a fixed base
  std::vector<int> qpos, dof;         ///< [njoints]
};

inline MujocoMap mapJoints(const mjModel* m, const Model& model) {
  MujocoMap map;
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_type[j] == mjJNT_FREE) {
      map.free_qpos = m->jnt_qposadr[j];
      map.free_dof = m->jnt_dofadr[j];
    }
  for (const std::string& name : model.joint_names) {
    const int id = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    map.qpos.push_back(id < 0 ? -1 : m->jnt_qposadr[id]);
    map.dof.push_back(id < 0 ? -1 : m->jnt_dofadr[id]);
  }
  return map;
}

/// Random state (exoid::randomState) as a value.
inline State randomState(const Model& model, std::mt19937_64& rng) {
  State s = State::zero(model);
  exoid::randomState(model, rng, s);
  return s;
}

/// Writes an exoid::State into MuJoCo's qpos/qvel/qacc (free joint: linear world, angular local).
inline void toMujoco(const State& s, const MujocoMap& map, const mjModel* m, mjData* d) {
  if (map.free_qpos >= 0) {
    const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
    const Eigen::Vector3d v = R * s.base_velocity, a = R * s.base_acceleration;
    for (int i = 0; i < 3; ++i) {
      d->qpos[map.free_qpos + i] = s.base_position[i];
      d->qvel[map.free_dof + i] = v[i];
      d->qvel[map.free_dof + 3 + i] = s.base_omega[i];
      d->qacc[map.free_dof + i] = a[i];
      d->qacc[map.free_dof + 3 + i] = s.base_domega[i];
    }
    d->qpos[map.free_qpos + 3] = s.base_orientation.w();
    d->qpos[map.free_qpos + 4] = s.base_orientation.x();
    d->qpos[map.free_qpos + 5] = s.base_orientation.y();
    d->qpos[map.free_qpos + 6] = s.base_orientation.z();
  }
  for (size_t j = 0; j < map.qpos.size(); ++j) {
    d->qpos[map.qpos[j]] = s.q[j];
    d->qvel[map.dof[j]] = s.v[j];
    d->qacc[map.dof[j]] = s.a[j];
  }
}

/// MuJoCo generalized force -> exoid rows (base: [moment local; force local], then joints).
inline Eigen::VectorXd fromMujocoForce(const mjtNum* qfrc, const State& s, const MujocoMap& map, int nv) {
  Eigen::VectorXd out(nv);
  int row = 0;
  if (map.free_dof >= 0) {
    const Eigen::Matrix3d R = s.base_orientation.toRotationMatrix();
    const Eigen::Vector3d f(qfrc[map.free_dof], qfrc[map.free_dof + 1], qfrc[map.free_dof + 2]);
    out.head<3>() << qfrc[map.free_dof + 3], qfrc[map.free_dof + 4], qfrc[map.free_dof + 5];
    out.segment<3>(3) = R.transpose() * f;
    row = 6;
  }
  for (size_t j = 0; j < map.dof.size(); ++j) out[row + j] = qfrc[map.dof[j]];
  return out;
}

/// Relative error max|a - b| / max|b|.
inline double relError(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
}

}  // namespace exoid::test

namespace exoid::test {

/// The exoskeleton twice: model_ from config/exo.urdf (floating base) and m_/d_ from config/exo.xml with
/// contacts disabled (inverse dynamics of the free tree), joints mapped by name.
class ExoMujocoTest : public MujocoTest {
 protected:
  void SetUp() override {
    MujocoTest::SetUp();
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(configPath("exo.urdf"), true, model_, &err)) << err;
    load(configPath("exo.xml"));
    m_->opt.disableflags |= mjDSBL_CONTACT;
    map_ = mapJoints(m_, model_);
  }
  Model model_;
  MujocoMap map_;
};

}  // namespace exoid::test
