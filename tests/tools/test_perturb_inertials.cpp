// exoid model perturb / tools::perturbInertials: a +-25 % prior URDF that loads, is physically consistent link
// by link, keeps every physical quantity within the bound (recomputed here from the written file), and is the
// same file for the same seed (different for another).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>

#include "exoid/model/inertial.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/perturb_inertials.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

Eigen::Vector3d principalMoments(const Eigen::Matrix3d& I) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I, Eigen::EigenvaluesOnly).eigenvalues();
}

TEST(PerturbInertials, WrittenPriorLoadsIsConsistentAndWithinTheBound) {
  test::TempDir dir("perturb");
  const std::string urdf = test::configPath("exo.urdf");
  const std::string a = dir.file("a.urdf"), b = dir.file("b.urdf"), c = dir.file("c.urdf");
  const std::string cmd = test::exoidBinary() + " model perturb --model " + urdf + " --relative 0.25 --seed ";
  ASSERT_EQ(test::runCommand(cmd + "7 --out " + a, dir.path).exit_code, 0);
  ASSERT_EQ(test::runCommand(cmd + "7 --out " + b, dir.path).exit_code, 0);
  const test::CommandResult rc = test::runCommand(cmd + "8 --out " + c, dir.path);
  ASSERT_EQ(rc.exit_code, 0) << rc.err;
  EXPECT_NE(rc.out.find("total mass"), std::string::npos) << rc.out;
  EXPECT_EQ(test::slurp(a), test::slurp(b));  // seeded: the same file
  EXPECT_NE(test::slurp(a), test::slurp(c));

  std::string err;
  Model nominal, prior;
  ASSERT_TRUE(buildModelFromUrdfFile(urdf, true, nominal, &err)) << err;
  ASSERT_TRUE(buildModelFromUrdfFile(a, true, prior, &err)) << err;
  ASSERT_EQ(prior.body_names, nominal.body_names);
  ASSERT_EQ(prior.joint_names, nominal.joint_names);
  double largest = 0.0;  // the largest relative change seen: the perturbation is not trivially small
  int perturbed = 0;
  for (int k = 0; k < nominal.nbodies; ++k) {
    const Vector10d p0 = nominal.phi.segment<kParamsPerBody>(nominal.bodyParamIndex(k));
    const Vector10d p1 = prior.phi.segment<kParamsPerBody>(prior.bodyParamIndex(k));
    if (!(p0[0] > 0.0)) continue;
    ++perturbed;
    const std::string& name = nominal.body_names[static_cast<size_t>(k)];
    EXPECT_TRUE(checkConsistency(p1).consistent) << name << ": " << checkConsistency(p1).reason;
    InertialProperties i0, i1;
    ASSERT_TRUE(inertialFromParams(p0, i0) && inertialFromParams(p1, i1)) << name;
    const auto within = [&](double v0, double v1, const char* what) {
      const double rel = std::abs(v1 - v0) / std::abs(v0);
      if (std::abs(v0) < 1e-12) {
        EXPECT_LT(std::abs(v1), 1e-9) << name << " " << what;
        return;
      }
      largest = std::max(largest, rel);
      EXPECT_LE(rel, 0.25 + 1e-6) << name << " " << what << ": " << v0 << " -> " << v1;
    };
    within(i0.mass, i1.mass, "mass");
    for (int d = 0; d < 3; ++d) within(i0.com[d], i1.com[d], "com");
    // Principal moments, matched by the nominal principal axes (the file keeps them).
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(i0.inertia_com);
    for (int d = 0; d < 3; ++d) {
      const Eigen::Vector3d v = es.eigenvectors().col(d);
      within(es.eigenvalues()[d], v.dot(i1.inertia_com * v), "principal moment");
    }
    EXPECT_NEAR(principalMoments(i1.inertia_com).sum(), i1.inertia_com.trace(), 1e-9);
  }
  EXPECT_GT(perturbed, 5);
  EXPECT_GT(largest, 0.15);
}

TEST(PerturbInertials, BadInputExitsTwoWithOneLine) {
  test::TempDir dir("perturb_bad");
  const std::string base = test::exoidBinary() + " model perturb ";
  for (const std::string& args : {std::string("--relative 0.95 --out ") + dir.file("x.urdf"),
                                  std::string("--relative abc --out ") + dir.file("x.urdf"),
                                  std::string("--model /nonexistent.urdf --out ") + dir.file("x.urdf"),
                                  std::string("--out /nonexistent_dir/x.urdf"), std::string("")}) {
    const test::CommandResult r = test::runCommand(base + args, dir.path);
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_FALSE(r.err.empty()) << args;
  }
  EXPECT_EQ(test::runCommand(base + "--help", dir.path).exit_code, 0);
}

TEST(PerturbInertials, ZeroRelativeIsTheNominalModel) {
  std::string err;
  Model model;
  ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model, &err)) << err;
  Eigen::VectorXd phi;
  ASSERT_TRUE(tools::perturbInertials(model, 0.0, 3, phi, &err)) << err;
  EXPECT_LT((phi - model.phi).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_FALSE(tools::perturbInertials(model, -0.1, 3, phi, &err));
}

}  // namespace
}  // namespace exoid
