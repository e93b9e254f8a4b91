// The anthropometric wearer (de Leva 1996 Table 4, docs/wearer.md) and the passive joint moments of Riener &
// Edrich 1999, against the published numbers and independent evaluations.
#include <gtest/gtest.h>

#include <cmath>

#include "exoid/model/anthropometry.hpp"
#include "exoid/model/passive_joint_moments.hpp"

namespace exoid {
namespace {

Wearer build(double mass, double height, Sex sex, uint64_t seed = 1, double variation = 0.0) {
  WearerSpec s;
  s.mass_kg = mass;
  s.height_m = height;
  s.sex = sex;
  s.seed = seed;
  s.variation = variation;
  Wearer w;
  std::string err;
  EXPECT_TRUE(buildWearer(s, w, &err)) << err;
  return w;
}

// The table's fractions, both sides counted: 1.0000 male, 0.9999 female (the published rounding).
TEST(Anthropometry, TableMassFractionsSumToOne) {
  for (Sex sex : {Sex::Male, Sex::Female}) {
    double sum = 0.0;
    for (int k = 0; k < kNumSegmentKinds; ++k) {
      const SegmentKind kind = static_cast<SegmentKind>(k);
      sum += (isBilateral(kind) ? 2.0 : 1.0) * deLevaRow(sex, kind).mass_fraction;
    }
    EXPECT_NEAR(sum, 1.0, sex == Sex::Male ? 1e-12 : 1.01e-4);
  }
}

// The trunk parts chain to de Leva's whole-trunk row (CERV-MIDH: 603.3 mm / 43.46 % male, 614.8 mm / 42.57 % female).
TEST(Anthropometry, TrunkPartsChainToTheWholeTrunkRow) {
  for (Sex sex : {Sex::Male, Sex::Female}) {
    double length = 0.0, mass = 0.0;
    for (SegmentKind k : {SegmentKind::UpperTrunk, SegmentKind::MiddleTrunk, SegmentKind::LowerTrunk}) {
      length += deLevaRow(sex, k).length_m;
      mass += deLevaRow(sex, k).mass_fraction;
    }
    EXPECT_NEAR(length, sex == Sex::Male ? 0.6033 : 0.6148, 1e-9);
    EXPECT_NEAR(mass, sex == Sex::Male ? 0.4346 : 0.4257, 1e-9);
  }
}

// At the reference stature and mass the segments are the table's: the male thigh 14.16 % of 73 kg, 422.2 mm,
// CoM 40.95 %, radii 0.329 / 0.329 / 0.149; the female foot's long axis on x (r_long 0.139).
TEST(Anthropometry, ReferenceSubjectReproducesTheTable) {
  const Wearer m = build(73.0, 1.741, Sex::Male);
  ASSERT_EQ(m.segments.size(), 16u);
  const BodySegment& thigh = m.segments[static_cast<size_t>(m.index("right_thigh"))];
  EXPECT_NEAR(thigh.mass, 0.1416 * 73.0, 1e-9);
  EXPECT_NEAR(thigh.length, 0.4222, 1e-12);
  EXPECT_NEAR(thigh.com_fraction, 0.4095, 1e-12);
  EXPECT_NEAR(thigh.inertia[0], thigh.mass * std::pow(0.329 * 0.4222, 2), 1e-12);
  EXPECT_NEAR(thigh.inertia[2], thigh.mass * std::pow(0.149 * 0.4222, 2), 1e-12);
  const Wearer f = build(61.9, 1.735, Sex::Female);
  const BodySegment& foot = f.segments[static_cast<size_t>(f.index("left_foot"))];
  EXPECT_NEAR(foot.length, 0.2283, 1e-12);
  EXPECT_NEAR(foot.inertia[0], foot.mass * std::pow(0.139 * 0.2283, 2), 1e-12);
  EXPECT_NEAR(foot.inertia[1], foot.mass * std::pow(0.299 * 0.2283, 2), 1e-12);
  // The female table sums to 0.9999: the masses are renormalised to the body mass.
  EXPECT_NEAR(f.totalMass(), 61.9, 1e-9);
  EXPECT_NEAR(foot.mass, 0.0129 / 0.9999 * 61.9, 1e-9);
}

TEST(Anthropometry, LengthsScaleWithHeightAndMassesWithMass) {
  const Wearer a = build(73.0, 1.741, Sex::Male), b = build(109.5, 1.95, Sex::Male);
  for (size_t i = 0; i < a.segments.size(); ++i) {
    EXPECT_NEAR(b.segments[i].length / a.segments[i].length, 1.95 / 1.741, 1e-12);
    EXPECT_NEAR(b.segments[i].mass / a.segments[i].mass, 1.5, 1e-12);
  }
}

// Standing upright, the whole-body CoM of the table person sits at 0.55-0.57 of the stature (docs/wearer.md).
TEST(Anthropometry, StandingComAtThePublishedFractionOfTheStature) {
  for (Sex sex : {Sex::Male, Sex::Female})
    for (double h : {1.50, 1.75, 1.95}) {
      const Wearer w = build(70.0, h, sex);
      const double fraction = standingComHeight(w) / h;
      EXPECT_GT(fraction, 0.55) << (sex == Sex::Male ? "male " : "female ") << h;
      EXPECT_LT(fraction, 0.57) << (sex == Sex::Male ? "male " : "female ") << h;
    }
}

// Variation: reproducible by seed, different across seeds, bounded by +-variation (before the mass renormalisation,
// which keeps the body mass), principal moments physical.
TEST(Anthropometry, VariationIsSeededBoundedAndKeepsTheBodyMass) {
  const Wearer t = build(80.0, 1.80, Sex::Male);
  const Wearer a = build(80.0, 1.80, Sex::Male, 7, 0.15), a2 = build(80.0, 1.80, Sex::Male, 7, 0.15);
  const Wearer b = build(80.0, 1.80, Sex::Male, 8, 0.15);
  EXPECT_NEAR(a.totalMass(), 80.0, 1e-9);
  double max_mass_ratio = 0.0, min_mass_ratio = 10.0, diff = 0.0;
  for (size_t i = 0; i < t.segments.size(); ++i) {
    const BodySegment &s = a.segments[i], &s0 = t.segments[i];
    EXPECT_EQ(s.mass, a2.segments[i].mass);
    EXPECT_EQ(s.inertia, a2.segments[i].inertia);
    diff += std::abs(s.mass - b.segments[i].mass);
    EXPECT_LE(std::abs(s.com_fraction / s0.com_fraction - 1.0), 0.15 + 1e-12);
    for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(s.radius[k] / s0.radius[k] - 1.0), 0.15 + 1e-12);
    const Eigen::Vector3d I = s.inertia;
    EXPECT_LE(I.maxCoeff(), I.sum() - I.maxCoeff() + 1e-15) << s.name;
    max_mass_ratio = std::max(max_mass_ratio, s.mass / s0.mass);
    min_mass_ratio = std::min(min_mass_ratio, s.mass / s0.mass);
  }
  EXPECT_GT(diff, 0.5);  // another seed, another person
  // Each mass within +-15 % of the table, times the common renormalisation (itself within +-15 %).
  EXPECT_LE(max_mass_ratio / min_mass_ratio, 1.15 / 0.85 + 1e-12);
  EXPECT_GT(max_mass_ratio / min_mass_ratio, 1.05);  // the variation is not a no-op
}

TEST(Anthropometry, RefusesSpecsOutOfRange) {
  WearerSpec s;
  Wearer w;
  std::string err;
  s.mass_kg = -1.0;
  EXPECT_FALSE(buildWearer(s, w, &err));
  EXPECT_NE(err.find("mass"), std::string::npos);
  s = WearerSpec();
  s.height_m = std::nan("");
  EXPECT_FALSE(buildWearer(s, w, &err));
  s = WearerSpec();
  s.variation = 0.7;
  EXPECT_FALSE(buildWearer(s, w, &err));
}

// Riener & Edrich 1999's equations evaluated by hand at the neutral posture (all angles 0):
// M_H = e^1.4655 - e^1.3403 + 8.072, M_K = e^1.8 - e^-3.971 - 4.82 + e^2.22, M_A = e^2.1016 - e^-7.9763 - 1.792.
TEST(PassiveMoments, PaperEquationsAtNeutral) {
  const Eigen::Vector3d m = rienerEdrichPaperMoments(0.0, 0.0, 0.0);
  EXPECT_NEAR(m[0], 4.329708 - 3.820189 + 8.072, 1e-5);
  EXPECT_NEAR(m[1], 6.049647 - 0.018855 - 4.820 + 9.207331, 1e-5);
  EXPECT_NEAR(m[2], 8.179246 - 0.000344 - 1.792, 1e-5);
}

// At hip 30 deg flexion, knee 60 deg flexion, paper ankle 10 deg plantarflexion, term by term.
TEST(PassiveMoments, PaperEquationsAtAFlexedPosture) {
  const double H = 30, K = 60, A = 10;
  const Eigen::Vector3d m = rienerEdrichPaperMoments(H, K, A);
  const double mh = std::exp(1.4655 - 0.204 - 2.25) - std::exp(1.3403 - 1.356 + 0.915) + 8.072;
  const double mk = std::exp(1.8 - 0.46 - 2.112 + 0.651) - std::exp(-3.971 - 0.004 + 2.97 - 0.384) - 4.82 +
                    std::exp(2.22 - 9.0);
  const double ma = std::exp(2.1016 - 0.843 - 1.056) - std::exp(-7.9763 + 1.949 + 0.048) - 1.792;
  EXPECT_NEAR(m[0], mh, 1e-12);
  EXPECT_NEAR(m[1], mk, 1e-12);
  EXPECT_NEAR(m[2], ma, 1e-12);
}

// exoid's convention: ankle dorsiflexion + (the paper's plantarflexion +): angle and moment flip at the ankle only.
TEST(PassiveMoments, ExoConventionFlipsTheAnkle) {
  const LegJoints q(0.3, 0.5, 0.2);  // hip flexed, knee flexed, ankle dorsiflexed
  const Eigen::Vector3d p = rienerEdrichPaperMoments(0.3 * 180 / M_PI, 0.5 * 180 / M_PI, -0.2 * 180 / M_PI);
  const LegJoints t = passiveElasticMoments(q);
  EXPECT_DOUBLE_EQ(t[0], p[0]);
  EXPECT_DOUBLE_EQ(t[1], p[1]);
  EXPECT_DOUBLE_EQ(t[2], -p[2]);
}

// Signs: the elastic law restores (each moment decreases with its own angle); near full extension the knee gets a
// flexing moment; a dorsiflexed ankle with a straight knee is pulled into plantarflexion (calf stretch), less so
// with the knee flexed (biarticular gastrocnemius); hip flexion with a straight knee gets an extending moment
// (hamstrings), smaller with the knee flexed.
TEST(PassiveMoments, SignsAndBiarticularCoupling) {
  const double d = 1e-6;
  for (double h : {-0.3, 0.0, 0.5, 1.0})
    for (double k : {0.0, 0.5, 1.2})
      for (double a : {-0.3, 0.0, 0.2}) {
        const LegJoints q(h, k, a);
        const LegJoints t = passiveElasticMoments(q);
        for (int j = 0; j < 3; ++j) {
          LegJoints qp = q;
          qp[j] += d;
          EXPECT_LT((passiveElasticMoments(qp)[j] - t[j]) / d, 0.0) << "joint " << j;
        }
      }
  EXPECT_GT(passiveElasticMoments(LegJoints(0, -0.05, 0))[1], 5.0);
  const double ankle_straight = passiveElasticMoments(LegJoints(0, 0, 0.2))[2];
  const double ankle_flexed = passiveElasticMoments(LegJoints(0, 1.0, 0.2))[2];
  EXPECT_LT(ankle_straight, -5.0);
  EXPECT_LT(ankle_straight, ankle_flexed);
  const double hip_straight = passiveElasticMoments(LegJoints(1.0, 0, 0))[0];
  const double hip_flexed = passiveElasticMoments(LegJoints(1.0, 1.2, 0))[0];
  EXPECT_LT(hip_straight, 0.0);
  EXPECT_LT(hip_straight, hip_flexed);
}

TEST(PassiveMoments, ContinuousAndDamped) {
  const LegJoints q(0.2, 0.4, -0.1), v(1.0, -2.0, 0.5);
  for (int j = 0; j < 3; ++j) {
    LegJoints q1 = q;
    q1[j] += 1e-9;
    EXPECT_NEAR(passiveElasticMoments(q1)[j], passiveElasticMoments(q)[j], 1e-6);
  }
  PassiveJointDamping damping;
  damping.b = LegJoints(1.5, 0.7, 0.2);
  const LegJoints t = passiveJointMoments(q, v, damping, 0.5);
  EXPECT_NEAR(t[0], 0.5 * passiveElasticMoments(q)[0] - 1.5, 1e-12);
  EXPECT_NEAR(t[1], 0.5 * passiveElasticMoments(q)[1] + 1.4, 1e-12);
  EXPECT_NEAR(t[2], 0.5 * passiveElasticMoments(q)[2] - 0.1, 1e-12);
}

}  // namespace
}  // namespace exoid
