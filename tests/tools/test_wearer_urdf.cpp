// exoid model wearer / tools::writeWearerPrior: the exoskeleton URDF plus the wearer's segments. The written prior
// loads with the exo's links and joints, weighs exo + wearer, and its standing CoM equals the one computed here
// from the segments placed by hand on the exo's joint points (config/exo.urdf: hips 0.1 m below the pelvis origin
// at y = -+0.11, knees 0.43 m lower, ankle axes 0.42 m lower, soles 0.09 m below the ankle axes).
#include <gtest/gtest.h>

#include "exoid/controller/com_observer.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/wearer_urdf.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

Eigen::Vector3d standingCom(const Model& model, double* mass) {
  DynamicsData dyn(model);
  forwardKinematics(model, dyn.kin, State::zero(model));
  centroidal(model, dyn);
  *mass = dyn.mass;
  return dyn.com;
}

// The segments' world CoMs from the placement rules of docs/wearer.md, written out independently of wearer_mount.
Eigen::Vector3d handPlacedCom(const Wearer& w, const BodySegment& s) {
  const double y = s.side * 0.11, f = s.com_fraction, L = s.length;
  const double hip = -0.1, knee = hip - 0.43, ankle = knee - 0.42, sole = ankle - 0.09;
  switch (s.kind) {
    case SegmentKind::Thigh: return {0.0, y, hip - f * L};
    case SegmentKind::Shank: return {0.0, y, knee - f * L};
    case SegmentKind::Foot: return {(f - 0.22) * L, y, 0.5 * (ankle + sole)};
    default: return Eigen::Vector3d(0.0, 0.0, hip) + standingSegmentCom(w, s);
  }
}

// The table person and two drawn ones, both tests below.
const WearerSpec kSpecs[] = {WearerSpec{75.0, 1.78, Sex::Male, 1, 0.0}, WearerSpec{52.0, 1.55, Sex::Female, 3, 0.15},
                             WearerSpec{110.0, 1.95, Sex::Male, 9, 0.15}};

// A prior written by tools::writeWearerPrior into dir and loaded, with the exoskeleton alone and the wearer.
struct WrittenPrior {
  WearerMount mount;
  Model exo, prior;
  Wearer wearer;
};
::testing::AssertionResult writePrior(const WearerSpec& spec, const test::TempDir& dir, WrittenPrior& w) {
  const std::string urdf = test::configPath("exo.urdf"), out = dir.file("prior.urdf");
  std::string err;
  if (!tools::writeWearerPrior(urdf, spec, out, &w.mount, &err) || !buildModelFromUrdfFile(urdf, true, w.exo, &err) ||
      !buildModelFromUrdfFile(out, true, w.prior, &err) || !buildWearer(spec, w.wearer, &err))
    return ::testing::AssertionFailure() << err;
  return ::testing::AssertionSuccess();
}

TEST(WearerUrdf, PriorWeighsExoPlusWearerAndItsComMatchesTheSegments) {
  test::TempDir dir("wearer_urdf");
  for (const WearerSpec& spec : kSpecs) {
    WrittenPrior written;
    ASSERT_TRUE(writePrior(spec, dir, written));
    const Model &exo = written.exo, &prior = written.prior;
    EXPECT_EQ(prior.body_names, exo.body_names);  // the wearer is lumped into the exo's links
    EXPECT_EQ(prior.joint_names, exo.joint_names);
    EXPECT_GE(prior.frameIndex("wearer_right_thigh"), 0);
    double m_exo = 0.0, m_prior = 0.0;
    const Eigen::Vector3d c_exo = standingCom(exo, &m_exo), c_prior = standingCom(prior, &m_prior);
    EXPECT_NEAR(m_prior, m_exo + spec.mass_kg, 1e-9);

    const Wearer& w = written.wearer;
    Eigen::Vector3d moment = m_exo * c_exo;
    for (const BodySegment& s : w.segments) moment += s.mass * handPlacedCom(w, s);
    EXPECT_LT((c_prior - moment / (m_exo + spec.mass_kg)).norm(), 1e-9) << spec.mass_kg;
  }
}

// The prior carries the lumbar pivot (a massless frame) and its upper body: the same body as lumpAboveLumbar, the
// pivot at the navel height above the mid-hip point (lower trunk's length above the hip axis, 0.1 m below the
// pelvis origin). upperBodyLever against the angular momentum summed segment by segment: a small turn rate w about
// the pivot's y axis gives each segment above the lumbar joint w = w y and c_i' = w y x (c_i - pivot), so
// dL_y = sum I_i,yy w + m_i [(c_i - c) x c_i']_y about the system's CoM c, and dF_x = sum m_i (c_i - pivot)_z w'.
TEST(WearerUrdf, ThePriorCarriesTheLumbarPivotAndItsUpperBodysLever) {
  test::TempDir dir("wearer_urdf_lumbar");
  for (const WearerSpec& spec : kSpecs) {
    WrittenPrior written;
    ASSERT_TRUE(writePrior(spec, dir, written));
    const Model &exo = written.exo, &prior = written.prior;
    const Wearer& w = written.wearer;
    const WearerMount& mount = written.mount;
    const double lower_trunk = w.segments[static_cast<size_t>(w.index("lower_trunk"))].length;
    MountedSegment body;
    Eigen::Vector3d pivot;
    ASSERT_TRUE(upperBodyFromModel(prior, body, pivot));
    EXPECT_LT((pivot - Eigen::Vector3d(0.0, 0.0, -0.1 + lower_trunk)).norm(), 1e-12);
    const MountedSegment lumped = lumpAboveLumbar(mount);
    EXPECT_NEAR(body.mass, lumped.mass, 1e-9);
    EXPECT_LT((body.com - lumped.com).norm(), 1e-9);
    EXPECT_LT((body.inertia_com - lumped.inertia_com).norm(), 1e-9);
    EXPECT_FALSE(upperBodyFromModel(exo, body, pivot));  // no wearer
    EXPECT_EQ(controller::upperBodyLever(exo), Eigen::Vector2d::Zero());

    double mass = 0.0;
    const Eigen::Vector3d c = standingCom(prior, &mass);
    const Eigen::Vector3d p(0.0, 0.0, -0.1 + lower_trunk);  // the pelvis is the world at the zero state
    Eigen::Vector2d dL = Eigen::Vector2d::Zero(), dF = Eigen::Vector2d::Zero();
    for (const MountedSegment& s : mount.segments) {
      if (!s.above_lumbar) continue;
      for (int a : {1, 0}) {  // a turn about y moves along x; about x along -y
        const Eigen::Vector3d axis = Eigen::Vector3d::Unit(a), v = axis.cross(s.com - p);
        dL[1 - a] += s.inertia_com(a, a) + s.mass * (s.com - c).cross(v)[a];
        dF[1 - a] += s.mass * v[1 - a];
      }
    }
    const Eigen::Vector2d expected(dL[0] / dF[0], -dL[1] / dF[1]);
    const Eigen::Vector2d lever = controller::upperBodyLever(prior);
    // The formula lumps the segments and leaves out their horizontal offsets from the pivot (mm): 1e-3 relative.
    EXPECT_NEAR(lever.x(), expected.x(), 1e-3 * expected.x()) << spec.mass_kg;
    EXPECT_NEAR(lever.y(), expected.y(), 1e-3 * expected.y()) << spec.mass_kg;
    EXPECT_GT(lever.minCoeff(), 0.3);
  }
}

TEST(WearerUrdf, CommandWritesThePriorAndRefusesBadInput) {
  test::TempDir dir("wearer_cli");
  const std::string out = dir.file("p.urdf");
  const std::string cmd = test::exoidBinary() + " model wearer --mass 75 --height 1.78 --sex m --out " + out;
  const test::CommandResult ok = test::runCommand(cmd, dir.path);
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("Total mass: 116.0500 kg"), std::string::npos) << ok.out;
  EXPECT_EQ(test::runCommand(cmd + " --variation 0.9", dir.path).exit_code, 2);
  EXPECT_EQ(test::runCommand(test::exoidBinary() + " model wearer --mass 75 --height 1.78 --sex x --out " + out,
                             dir.path).exit_code, 2);
  EXPECT_EQ(test::runCommand(cmd + " --model " + dir.file("missing.urdf"), dir.path).exit_code, 2);
}

}  // namespace
}  // namespace exoid
