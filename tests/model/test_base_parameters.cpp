// Structural base parameters: K times every null-space direction vanishes for fresh random states, the base
// parameters reproduce K*phi, and the classification matches what the mechanics says.
#include <gtest/gtest.h>

#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/mujoco_state.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

void expectNullspaceAndReconstruction(const Model& model, const BaseParameters& base, uint64_t seed) {
  ASSERT_EQ(base.nullspace.cols(), model.nparams() - base.rank);
  // The null space is really null: |K n| tiny compared with |K| |n| on states never used to compute it.
  Data data(model);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Base parameters of a perturbed parameter vector reproduce its generalized forces.
  Eigen::VectorXd phi = model.phi;
  for (int i = 0; i < phi.size(); ++i) phi[i] += 0.1 * u(rng);
  const Eigen::VectorXd phi_base = base.base_map * phi;
  Eigen::MatrixXd K_base(model.nv, base.rank);
  for (int k = 0; k < 100; ++k) {
    const State s = test::randomState(model, rng);
    computeJointTorqueRegressor(model, data, s);
    const double scale = data.K.cwiseAbs().maxCoeff();
    EXPECT_LT((data.K * base.nullspace).cwiseAbs().maxCoeff(), 1e-10 * scale);
    for (int i = 0; i < base.rank; ++i) K_base.col(i) = data.K.col(base.independent[i]);
    const Eigen::VectorXd tau = data.K * phi;
    EXPECT_LT((K_base * phi_base - tau).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, tau.cwiseAbs().maxCoeff()));
  }
  // Adding null-space directions changes nothing: the map kills them.
  EXPECT_LT((base.base_map * base.nullspace).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(BaseParameters, Exoskeleton) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  const BaseParameters base = computeBaseParameters(model);
  std::printf("%s", describeBaseParameters(model, base).c_str());
  // A clear rank: the first dropped pivot is orders of magnitude below the last kept one.
  EXPECT_LT(base.gap_ratio, 1e-6);
  expectNullspaceAndReconstruction(model, base, 99);
  // Every joint's friction is identifiable alone; the base body is fully identifiable (floating base: its
  // 10 parameters only appear in the 6 base rows, but each leg's parameters regroup onto... ) — check the
  // facts that hold for any tree on a floating base: total mass enters alone or in combination, never lost.
  for (int j = 0; j < model.njoints; ++j) {
    EXPECT_EQ(base.kind[model.frictionParamIndex(j)], Identifiability::Alone);
    EXPECT_EQ(base.kind[model.frictionParamIndex(j) + 1], Identifiability::Alone);
  }
  for (int b = 0; b < model.nbodies; ++b) EXPECT_NE(base.kind[model.bodyParamIndex(b)], Identifiability::None);
  // Rank equals the structural count: 10 per floating body minus what each revolute joint hides.
  EXPECT_EQ(base.rank, model.nparams() - static_cast<int>(base.dependent.size()));
}

TEST(BaseParameters, KukaLwr4FixedBase) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(test::dataPath("kuka_lwr4/kuka_lwr4.urdf"), false, model, &err)) << err;
  const BaseParameters base = computeBaseParameters(model);
  std::printf("%s", describeBaseParameters(model, base).c_str());
  EXPECT_LT(base.gap_ratio, 1e-6);
  expectNullspaceAndReconstruction(model, base, 98);
  // The first link turns about the fixed vertical axis through its origin: of its 10 parameters only Izz
  // enters the torques (in combination), mass and first moments never do.
  const int l1 = model.bodyParamIndex(0);
  for (int k : {0, 1, 2, 3, 4, 5, 6, 7, 8}) EXPECT_EQ(base.kind[l1 + k], Identifiability::None) << kBodyParamNames[k];
  EXPECT_NE(base.kind[l1 + 9], Identifiability::None);
}

}  // namespace
}  // namespace exoid
