// SolePlacementFit (exoid/estimator/sole_placement.hpp): the soles' common offset on their plates fitted with the base
// parameters. Synthetic rows of the exoskeleton's floating base at random states, the data built from the physics the
// fit assumes but by hand: y(0) = K phi - dY c*, with dY's base moment rows -(R^T e_j) x f_b (f_b the rows' base force,
// R the base orientation; docs/conventions.md: a floating base's rows are n then f, base coordinates).
#include <gtest/gtest.h>

#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/sole_placement.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::estimator {
namespace {

class SolePlacementTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
    base = computeBaseParameters(model);
  }
  /// n samples; dY from the rows' own force, or (in_span) a combination of the base-parameter columns.
  SolePlacement run(int n, const Eigen::Vector2d& c_true, double noise, bool in_span, unsigned seed = 7) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g(0.0, 1.0);
    Data kin(model);
    State st = State::zero(model);
    SolePlacementFit fit(model, base, 5, 200);
    Eigen::MatrixXd mix = Eigen::MatrixXd::Zero(model.nparams(), 2);
    for (int j = 0; j < base.rank; ++j) mix(base.independent[static_cast<size_t>(j)], j % 2) = g(rng);
    Eigen::MatrixXd dY(model.nv, 2);
    for (int k = 0; k < n; ++k) {
      randomState(model, rng, st);
      computeJointTorqueRegressor(model, kin, st);
      const Eigen::VectorXd y_true = kin.K * model.phi;
      const Eigen::Matrix3d R = st.base_orientation.toRotationMatrix();
      if (in_span) {
        dY = kin.K * mix;
      } else {
        dY.setZero();
        const Eigen::Vector3d f_b = y_true.segment<3>(3);
        for (int j = 0; j < 2; ++j) dY.col(j).head<3>() = -(R.transpose().col(j)).cross(f_b);
      }
      Eigen::VectorXd y = y_true - dY * c_true;
      for (int r = 0; r < model.nv; ++r) y[r] += noise * g(rng);
      fit.add(kin.K, y, dY);
    }
    return fit.finish();
  }
  Model model;
  BaseParameters base;
};

TEST_F(SolePlacementTest, TheCommonOffsetIsFoundWithinItsStandardError) {
  const Eigen::Vector2d c(0.012, -0.007);
  const SolePlacement sp = run(4000, c, 0.5, false);
  ASSERT_TRUE(sp.fitted) << sp.why_not;
  std::printf("offset %.5f %.5f m (true %.3f %.3f), se %.2e %.2e, separable %.3f %.3f, rms %.3f -> %.3f\n",
              sp.offset.x(), sp.offset.y(), c.x(), c.y(), sp.standard_error.x(), sp.standard_error.y(),
              sp.separable.x(), sp.separable.y(), sp.weighted_rms_without, sp.weighted_rms_with);
  for (int j = 0; j < 2; ++j) {
    EXPECT_LT(std::abs(sp.offset[j] - c[j]), 4.0 * sp.standard_error[j] + 1e-9) << j;
    EXPECT_LT(sp.standard_error[j], 1e-3) << j;  // sub-millimetre
    EXPECT_GT(sp.separable[j], 0.01) << j;
  }
  EXPECT_GT(sp.weighted_rms_without, 1.5 * sp.weighted_rms_with);
  EXPECT_NEAR(sp.weighted_rms_with, 1.0, 0.05);  // WLS: the noise in units of itself
  // Exact data: exact to rounding.
  const SolePlacement exact = run(1500, c, 0.0, false);
  ASSERT_TRUE(exact.fitted) << exact.why_not;
  EXPECT_LT((exact.offset - c).norm(), 1e-9);
}

TEST_F(SolePlacementTest, AnOffsetTheBaseParametersCanTakeIsNotFitted) {
  const SolePlacement sp = run(1500, Eigen::Vector2d(0.01, 0.0), 0.5, true);
  EXPECT_FALSE(sp.fitted);
  EXPECT_NE(sp.why_not.find("not determined by these data"), std::string::npos) << sp.why_not;
  EXPECT_LT(sp.separable.maxCoeff(), 1e-6);
}

TEST_F(SolePlacementTest, TooFewSamplesAreSaidSo) {
  const SolePlacement sp = run(999, Eigen::Vector2d(0.01, 0.0), 0.5, false);
  EXPECT_FALSE(sp.fitted);
  EXPECT_EQ(sp.why_not, "fewer than 1000 samples");
}

}  // namespace
}  // namespace exoid::estimator
