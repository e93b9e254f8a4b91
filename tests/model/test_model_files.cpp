// config/exo.urdf and config/exo.xml describe the same robot (tree, joint placements and axes, masses,
// CoMs, inertias) to 1e-9; the parameters are exactly the Appendix D table; every link is physically
// consistent.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <fstream>
#include <sstream>

#include "exoid/model/kinematics.hpp"
#include "exoid/model/urdf.hpp"
#include "support/mujoco_fixture.hpp"
#include "support/mujoco_state.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

using ModelFiles = test::ExoMujocoTest;

Eigen::Matrix3d quatToMatrix(const mjtNum* q) { return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix(); }

TEST_F(ModelFiles, StructureMatchesTheDesignCard) {
  EXPECT_EQ(model_.nbodies, 11);
  EXPECT_EQ(model_.njoints, 10);
  EXPECT_EQ(model_.nv, 16);
  EXPECT_EQ(model_.body_names[0], "body");
  EXPECT_EQ(m_->nu, 8);  // the two ankle in/eversion joints are unactuated
  for (int a = 0; a < m_->nu; ++a) {
    const std::string joint = mj_id2name(m_, mjOBJ_JOINT, m_->actuator_trnid[2 * a]);
    EXPECT_EQ(joint.find("ankle_ie"), std::string::npos) << joint;
    const int j = model_.jointIndex(joint);
    ASSERT_GE(j, 0);
    EXPECT_DOUBLE_EQ(m_->actuator_ctrlrange[2 * a + 1], model_.effort_limit[j]);
  }
}

TEST_F(ModelFiles, UrdfAndMjcfDescribeTheSameRobot) {
  for (int b = 0; b < model_.nbodies; ++b) {
    const std::string& name = model_.body_names[b];
    const int id = mj_name2id(m_, mjOBJ_BODY, name.c_str());
    ASSERT_GT(id, 0) << name;
    // Tree.
    const int pid = m_->body_parentid[id];
    EXPECT_EQ(model_.parent[b] < 0 ? std::string("world") : model_.body_names[model_.parent[b]],
              pid == 0 ? std::string("world") : std::string(mj_id2name(m_, mjOBJ_BODY, pid)))
        << name;
    // Joint placement and axis (the base's placement is its initial pose, not part of the tree).
    if (b > 0) {
      ASSERT_EQ(m_->body_jntnum[id], 1) << name;
      const int jnt = m_->body_jntadr[id];
      EXPECT_EQ(std::string(mj_id2name(m_, mjOBJ_JOINT, jnt)), model_.joint_names[model_.jointOfBody(b)]);
      EXPECT_LT((Eigen::Vector3d(m_->body_pos + 3 * id) - model_.tree_position[b]).cwiseAbs().maxCoeff(), 1e-9) << name;
      EXPECT_LT((quatToMatrix(m_->body_quat + 4 * id) - model_.tree_rotation[b]).cwiseAbs().maxCoeff(), 1e-9) << name;
      EXPECT_LT((Eigen::Vector3d(m_->jnt_axis + 3 * jnt) - model_.joint_axis[b]).cwiseAbs().maxCoeff(), 1e-9) << name;
      EXPECT_LT(Eigen::Vector3d(m_->jnt_pos + 3 * jnt).norm(), 1e-12) << name;
    } else {
      EXPECT_EQ(m_->jnt_type[m_->body_jntadr[id]], mjJNT_FREE);
    }
    // Inertia: MuJoCo stores mass, CoM, principal moments and the principal frame.
    const Vector10d phi_mj = paramsFromInertial(m_->body_mass[id], Eigen::Vector3d(m_->body_ipos + 3 * id),
                                                quatToMatrix(m_->body_iquat + 4 * id),
                                                Eigen::Vector3d(m_->body_inertia + 3 * id).asDiagonal());
    const Vector10d phi = model_.phi.segment<10>(model_.bodyParamIndex(b));
    EXPECT_LT((phi_mj - phi).cwiseAbs().maxCoeff(), 1e-9) << name << "\n" << phi_mj.transpose() << "\n" << phi.transpose();
  }
}

TEST_F(ModelFiles, ParametersAreTheAppendixDTable) {
  std::ifstream in(test::configPath("exo_true_parameters.csv"));
  ASSERT_TRUE(in);
  std::string line;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("link,", 0) == 0) continue;
    std::stringstream ss(line);
    std::string cell, name;
    std::getline(ss, cell, ',');
    std::getline(ss, name, ',');
    const int b = model_.bodyIndex(name);
    ASSERT_GE(b, 0) << name;
    EXPECT_EQ(b, std::stoi(cell) - 1) << "tree order must be the thesis's link order";
    for (int k = 0; k < 10; ++k) {
      std::getline(ss, cell, ',');
      EXPECT_NEAR(model_.phi[model_.bodyParamIndex(b) + k], std::stod(cell), 1e-12) << name << " " << kBodyParamNames[k];
    }
    ++rows;
  }
  EXPECT_EQ(rows, 11);
}

TEST_F(ModelFiles, EveryLinkIsPhysicallyConsistent) {
  for (int b = 0; b < model_.nbodies; ++b) {
    const Eigen::Matrix4d P = pseudoInertia(model_.phi.segment<10>(model_.bodyParamIndex(b)));
    const double min_eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(P).eigenvalues().minCoeff();
    EXPECT_GT(min_eig, 0.0) << model_.body_names[b];
  }
}

TEST_F(ModelFiles, StandsWithTheCentreOfMassOverTheFeet) {
  // Standing pose: CoM inside the support polygon spanned by both soles (from the URDF's sole frames).
  Data d(model_);
  const State s = State::zero(model_);
  forwardKinematics(model_, d, s);
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (int b = 0; b < model_.nbodies; ++b)
    first += model_.phi[10 * b] * d.p[b] + d.R[b] * model_.phi.segment<3>(10 * b + 1);
  const Eigen::Vector3d com = first / model_.totalMass();
  const auto sole = [&](const char* name) {
    const Model::Frame& f = model_.frames[model_.frameIndex(name)];
    return Eigen::Vector3d(d.p[f.body] + d.R[f.body] * f.position);
  };
  const Eigen::Vector3d r = sole("right_sole"), l = sole("left_sole");
  EXPECT_NEAR(r.z(), l.z(), 1e-12);
  EXPECT_GT(com.z() - r.z(), 0.8);                     // an adult-height CoM above the soles
  EXPECT_LT(std::abs(com.x() - r.x()), 0.14);          // within the sole length (half 0.14 m)
  EXPECT_GT(com.y(), r.y());
  EXPECT_LT(com.y(), l.y());
}

}  // namespace
}  // namespace exoid
