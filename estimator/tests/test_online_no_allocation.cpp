// The online estimator's per-sample path (regressor, causal filter, update, prediction) and its solve at the
// publication rate allocate nothing: Eigen's run-time guard (this binary compiles the online sources with
// EIGEN_RUNTIME_NO_MALLOC) and the process-wide malloc / operator new counter.
#include <gtest/gtest.h>

#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/estimator/online/row_filter.hpp"
#include "exoid/model/random_state.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "support/alloc_counter.hpp"

namespace exoid::estimator {
namespace {

TEST(OnlineNoAllocation, UpdateSolveAndPredictAllocateNothing) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  const BaseParameters base = computeBaseParameters(model);
  const Eigen::VectorXd prior = model.phi;
  RecursiveLsOptions opt;
  opt.forgetting = 0.5;  // renormalisation (every ~330 samples) happens inside the counted loop too
  RecursiveLsModel rm;
  ASSERT_TRUE(makeRecursiveLs(model, base, prior, diagonalPriorInformation(model, base, prior, 0.25), opt, rm, &err))
      << err;
  RecursiveLsData rd(rm);
  Data data(model);
  State s = State::zero(model);
  std::mt19937_64 rng(1);
  std::vector<State> states(50, s);
  for (State& st : states) randomState(model, rng, st);
  Eigen::VectorXd y(model.nv), tau(model.nv);
  Eigen::MatrixXd Kbad = Eigen::MatrixXd::Zero(model.nv, model.nparams());
  Kbad(6, base.independent[rm.active[6][0]]) = std::numeric_limits<double>::quiet_NaN();

  CausalRowFilter filter;
  filter.configure(rm, 30.0, 1000.0);
  Eigen::MatrixXd Kf = Eigen::MatrixXd::Zero(model.nv, model.nparams());
  Eigen::VectorXd yf(model.nv);

  exoid::test::AllocationCounter counter;
  Eigen::internal::set_is_malloc_allowed(false);
  long accepted = 0;
  for (int k = 0; k < 2000; ++k) {
    computeJointTorqueRegressor(model, data, states[k % states.size()]);
    y.noalias() = data.K * prior;
    filter.filter(rm, data.K, y, Kf, yf);
    accepted += updateRecursiveLs(rm, rd, k, Kf, yf) == SampleStatus::Accepted;
    updateRecursiveLs(rm, rd, k, data.K, y);   // duplicate
    updateRecursiveLs(rm, rd, k + 1, Kbad, y);  // non-finite
    predictRecursiveLs(rm, rd, data.K, tau);
    if (k % 100 == 0) solveRecursiveLs(rm, rd, k % 200 == 0);
  }
  Eigen::internal::set_is_malloc_allowed(true);
  counter.stop();
  EXPECT_EQ(counter.mallocs(), 0);
  EXPECT_EQ(counter.news(), 0);
  EXPECT_EQ(accepted, 2000);
  EXPECT_EQ(rd.rejected_duplicate, 2000);
  EXPECT_EQ(rd.rejected_nonfinite, 2000);
  EXPECT_TRUE(rd.x.allFinite());
}

}  // namespace
}  // namespace exoid::estimator
