// The per-sample algorithms allocate nothing once Model and Data exist: checked with a global operator new
// counter and with Eigen's run-time malloc guard (EIGEN_RUNTIME_NO_MALLOC).
#include <gtest/gtest.h>

#include <random>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/alloc_counter.hpp"
#include "support/mujoco_state.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

TEST(NoAllocation, RegressorAndDynamicsPerSample) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  Data data(model);
  DynamicsData dyn(model);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, model.nv);
  std::mt19937_64 rng(1);
  std::vector<State> states;
  for (int i = 0; i < 10; ++i) states.push_back(test::randomState(model, rng));
  const int foot = model.bodyIndex("right_foot");
  const Eigen::Vector3d point(0.06, 0.0, 0.03);
  const Eigen::VectorXd phi_estimate = 1.1 * model.phi;  // the arbitrary-phi overloads (an estimate)

  const std::size_t before = test::allocationCount();
  Eigen::internal::set_is_malloc_allowed(false);
  double checksum = 0.0;
  for (const State& s : states) {
    computeJointTorqueRegressor(model, data, s);
    rnea(model, dyn, s);
    crba(model, dyn, s);
    computePointJacobian(model, dyn.kin, foot, point, J);
    forwardKinematicsDrift(model, dyn.kin, s);
    checksum += pointAccelerationDrift(dyn.kin, foot, point).sum();
    forwardKinematics(model, dyn.kin, s);
    centroidal(model, dyn);
    checksum += dyn.com.sum();
    crba(model, phi_estimate, dyn, s);
    centroidal(model, phi_estimate, dyn);
    checksum += data.K.sum() + dyn.tau.sum() + dyn.M.sum() + J.sum() + dyn.com.sum();
  }
  Eigen::internal::set_is_malloc_allowed(true);
  EXPECT_EQ(test::allocationCount() - before, 0u);
  EXPECT_TRUE(std::isfinite(checksum));
}

TEST(NoAllocation, CounterSeesAllocations) {
  // The counter itself works: a std::vector and an Eigen allocation are both counted.
  const std::size_t before = test::allocationCount();
  std::vector<double> v(100);
  v[0] = 1.0;
  const std::size_t after_vector = test::allocationCount();
  EXPECT_GT(after_vector - before, 0u);
  Eigen::VectorXd e = Eigen::VectorXd::Ones(100);
  EXPECT_GT(test::allocationCount() - after_vector, 0u);
  EXPECT_EQ(e.sum() + v[0], 101.0);
}

}  // namespace
}  // namespace exoid
