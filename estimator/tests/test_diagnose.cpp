// Diagnosis on synthetic data of the KUKA LWR4+ model (fixed base, 7 joints) with known injected effects:
// the effect is found on the right joint with the right kind and value; clean data give no finding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <array>
#include <random>
#include <unistd.h>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/passive_joint_moments.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "diagnosis_runs.hpp"
#include "kuka_model.hpp"

namespace exoid::estimator {
namespace {

using test::kuka;

// A smooth excitation: per joint a sum of three sines (0.1-0.6 Hz), |v| up to about 1 rad/s.
struct Trajectory {
  std::vector<std::array<double, 3>> amp, freq, phase;  // [nj]
  std::vector<double> offset;                           // [nj] the posture swung about (empty: 0)
  State at(const Model& model, double t) const {
    State s = State::zero(model);
    for (int j = 0; j < static_cast<int>(offset.size()); ++j) s.q[j] = offset[static_cast<size_t>(j)];
    for (int j = 0; j < model.njoints; ++j)
      for (int h = 0; h < 3; ++h) {
        const double w = 2 * M_PI * freq[j][h], arg = w * t + phase[j][h];
        s.q[j] += amp[j][h] * std::sin(arg);
        s.v[j] += amp[j][h] * w * std::cos(arg);
        s.a[j] -= amp[j][h] * w * w * std::sin(arg);
      }
    return s;
  }
};

Trajectory randomTrajectory(const Model& model, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> f(0.1, 0.6), ph(0, 2 * M_PI), a(0.15, 0.35);
  Trajectory tr;
  for (int j = 0; j < model.njoints; ++j) {
    std::array<double, 3> A{}, F{}, P{};
    for (int h = 0; h < 3; ++h) F[h] = f(rng), P[h] = ph(rng), A[h] = a(rng) / (2 * M_PI * F[h]) * 0.5;
    tr.amp.push_back(A), tr.freq.push_back(F), tr.phase.push_back(P);
  }
  return tr;
}

struct Injected {
  EffectKind kind;
  int joint;
  double value;
  double width = 0.0;  // Coulomb, Stribeck: the injected tanh width (0: the shape's); ElasticExp(Coupled): its scale
  double center = 0.0; // Elastic, ElasticExp(Coupled): the reference angle
  int coupled = -1;    // ElasticExpCoupled: the neighbour, its weight in the exponent, its reference angle
  double ratio = 0.0, coupled_center = 0.0;
};

using diagnosis_runs::Run;
using diagnosis_runs::segmentOf;

// One run: samples at 200 Hz, y = K phi_true + effect + white noise of sigma N m on every joint.
Run makeRun(const Model& model, uint64_t seed, double duration, double sigma, const std::vector<Injected>& effects,
            const EffectShape& shape) {
  std::mt19937_64 rng(seed);
  const Trajectory tr = randomTrajectory(model, rng);
  std::normal_distribution<double> noise(0.0, sigma);
  Data data(model);
  Run run;
  const double dt = 0.005;
  for (double t = 0; t < duration; t += dt) {
    const State s = tr.at(model, t);
    computeJointTorqueRegressor(model, data, s);
    Eigen::VectorXd tau = data.K * model.phi;
    Eigen::VectorXd y = tau;
    for (const Injected& e : effects) {
      const int r = model.jointRow(e.joint);
      if (e.kind == EffectKind::GainError) {
        y[r] = (1 + e.value) * tau[r];
      } else if (e.kind == EffectKind::Delay) {
        const State past = tr.at(model, t - e.value);
        computeJointTorqueRegressor(model, data, past);
        y[r] = (data.K * model.phi)[r];
      } else {
        Effect ef{e.kind, e.joint, e.value, e.width, e.center, e.coupled};
        ef.ratio = e.ratio, ef.coupled_center = e.coupled_center;
        y[r] += e.value * effectSignal(e.kind, effectShape(shape, ef), effectAngle(ef, s.q[e.joint], s.q[signalJoint(ef)]),
                                       s.v[e.joint], s.a[e.joint], 0, 0);
      }
    }
    for (int r = 0; r < model.nv; ++r) y[r] += noise(rng);
    run.states.push_back(s);
    run.t.push_back(t);
    run.y.push_back(y);
  }
  return run;
}



// Prints every finding under `label` and checks the first one's kind, joint and width (scale); returns it. The caller
// has asserted that there is one.
const Finding& expectFirstFinding(const DiagnosisResult& res, const char* label, EffectKind kind, int joint, double width) {
  for (const Finding& g : res.findings) std::printf("%s: %s\n", label, g.sentence.c_str());
  const Finding& f = res.findings.front();
  EXPECT_EQ(f.effect.kind, kind) << f.sentence;
  EXPECT_EQ(f.effect.joint, joint) << f.sentence;
  EXPECT_EQ(f.effect.width, width) << f.sentence;
  return f;
}

// The mean joint angles over runDiagnosis(seed, ...)'s two training runs: the elastic candidates' centers.
Eigen::VectorXd meanTrainingAngles(const Model& model, uint64_t seed, double sigma) {
  Eigen::VectorXd c = Eigen::VectorXd::Zero(model.njoints);
  long n = 0;
  for (uint64_t rs : {seed * 3 + 1, seed * 3 + 2})
    for (const State& st : makeRun(model, rs, 20.0, sigma, {}, EffectShape{}).states) c += st.q, ++n;
  return c / static_cast<double>(n);
}

DiagnosisResult runDiagnosis(uint64_t seed, double sigma, const std::vector<Injected>& effects,
                             const DiagnoseOptions& opt = {}) {
  const Model& model = kuka();
  const Run r1 = makeRun(model, seed * 3 + 1, 20.0, sigma, effects, opt.shape);
  const Run r2 = makeRun(model, seed * 3 + 2, 20.0, sigma, effects, opt.shape);
  const Run rv = makeRun(model, seed * 3 + 3, 20.0, sigma, effects, opt.shape);
  DiagnosisResult res;
  std::string err;
  EXPECT_TRUE(diagnose(model, {segmentOf(model, r1, "a"), segmentOf(model, r2, "b")}, {segmentOf(model, rv, "v")}, opt,
                       res, &err))
      << err;
  return res;
}

TEST(StudentT, MatchesTabulatedQuantiles) {
  // t_{0.99}(9) = 2.821, t_{0.975}(9) = 2.262, t_{0.95}(30) = 1.697 (standard tables).
  EXPECT_NEAR(studentTUpperTail(2.821, 9), 0.01, 2e-4);
  EXPECT_NEAR(studentTUpperTail(2.262, 9), 0.025, 2e-4);
  EXPECT_NEAR(studentTUpperTail(1.697, 30), 0.05, 2e-4);
  EXPECT_NEAR(studentTUpperTail(0.0, 5), 0.5, 1e-12);
  EXPECT_NEAR(studentTUpperTail(-2.821, 9), 0.99, 2e-4);
}

// The signed-rank test's exact upper tail against a count over every sign pattern (n = 10: 1024), with ties; the
// tabulated critical value (n = 20, one-sided 0.05: W+ >= 150 has p 0.0487); all of 20 positive: 2^-20.
TEST(SignedRank, MatchesEnumerationAndTables) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.3, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd d(10);
    for (int i = 0; i < 10; ++i) d[i] = g(rng);
    if (trial % 4 == 0) d[3] = -d[7];  // a tie in |d|
    if (trial % 5 == 0) d[2] = 0.0;    // a zero: left out
    std::vector<int> idx;
    for (int i = 0; i < 10; ++i)
      if (d[i] != 0.0) idx.push_back(i);
    const int n = static_cast<int>(idx.size());
    std::vector<double> rank(static_cast<size_t>(n));
    for (int a = 0; a < n; ++a) {  // mean rank of |d| among the nonzero values
      double below = 0, equal = 0;
      for (int b = 0; b < n; ++b) {
        below += std::fabs(d[idx[b]]) < std::fabs(d[idx[a]]);
        equal += std::fabs(d[idx[b]]) == std::fabs(d[idx[a]]);
      }
      rank[static_cast<size_t>(a)] = below + (equal + 1) / 2.0;
    }
    double w = 0;
    for (int a = 0; a < n; ++a) w += d[idx[a]] > 0 ? rank[static_cast<size_t>(a)] : 0.0;
    long at_least = 0;
    for (long mask = 0; mask < (1L << n); ++mask) {
      double s = 0;
      for (int a = 0; a < n; ++a) s += (mask >> a) & 1 ? rank[static_cast<size_t>(a)] : 0.0;
      at_least += s >= w - 1e-9;
    }
    EXPECT_NEAR(signedRankUpperTail(d), static_cast<double>(at_least) / (1L << n), 1e-15) << trial;
  }
  Eigen::VectorXd d20(20);
  for (int i = 0; i < 20; ++i) d20[i] = i + 1.0;
  EXPECT_NEAR(signedRankUpperTail(d20), std::ldexp(1.0, -20), 1e-21);
  for (int i : {8, 11, 18, 19}) d20[i] = -d20[i];  // negative ranks 9, 12, 19, 20: T = 60, W+ = 150
  EXPECT_NEAR(signedRankUpperTail(d20), 0.0486536, 1e-7);  // the table's one-sided 0.05 critical value T = 60
  d20[7] = -d20[7];  // T = 68
  EXPECT_GT(signedRankUpperTail(d20), 0.05);
  EXPECT_EQ(signedRankUpperTail(Eigen::VectorXd::Zero(5)), 1.0);
  EXPECT_EQ(signedRankUpperTail(Eigen::VectorXd::Constant(3, NAN)), 1.0);
}

// Each kind on one joint, sized at least 3x the torque noise (sigma = 0.05 N m): named on the right joint
// with the right kind as the first finding, value within 10 %, and the held-out RMSE back near the noise.
// (An offset on a joint whose gravity torque barely changes over the run hides in the rigid-body parameters:
// lwr_5 with this excitation; lwr_0's axis is vertical, so its offset cannot hide.)
struct Case {
  EffectKind kind;
  int joint;
  double value;
};
class SingleEffect : public ::testing::TestWithParam<Case> {};

TEST_P(SingleEffect, FoundOnTheRightJointWithTheRightKindAndValue) {
  const Case c = GetParam();
  const double sigma = 0.05;
  const DiagnosisResult res = runDiagnosis(11, sigma, {{c.kind, c.joint, c.value}});
  ASSERT_FALSE(res.findings.empty());
  const Finding& f = res.findings.front();
  EXPECT_EQ(f.effect.joint, c.joint) << f.sentence;
  EXPECT_EQ(f.effect.kind, c.kind) << f.sentence;
  EXPECT_NEAR(f.effect.value, c.value, 0.1 * std::fabs(c.value)) << f.sentence;
  // Nothing else of note: at most one further finding, and the augmented model is at the noise floor.
  EXPECT_LE(res.findings.size(), 2u) << res.findings.back().sentence;
  // Held-out: the joint is back at the noise floor and better than before (part of an effect can hide in
  // the rigid-body parameters, so "before" is not always far above the noise).
  EXPECT_LT(res.pooled_after, 1.1 * sigma);
  EXPECT_LT(res.coordinates[c.joint].rms_after, 1.1 * sigma);
  EXPECT_LT(res.coordinates[c.joint].rms_after, res.coordinates[c.joint].rms_before);
  // What remains is white noise: the last stage (residual predictability) names nothing.
  EXPECT_TRUE(res.predictability.ran);
  for (const JointPredictability& j : res.predictability.joints) EXPECT_FALSE(j.predictable) << j.sentence;
}

INSTANTIATE_TEST_SUITE_P(Kinds, SingleEffect,
                         ::testing::Values(Case{EffectKind::Viscous, 3, 0.6}, Case{EffectKind::Coulomb, 1, 0.4},
                                           Case{EffectKind::Stribeck, 4, 0.4}, Case{EffectKind::Offset, 0, 0.2},
                                           Case{EffectKind::Armature, 2, 0.3}, Case{EffectKind::GainError, 1, 0.05},
                                           Case{EffectKind::Delay, 3, 0.01}));

// Clean data (no undeclared effect, different noise seeds): no finding at the documented false-alarm rate
// alpha = 0.01 per data set; 10 seeds may give at most one. The last stage (residual predictability, the same alpha)
// likewise: at most one data set with a joint named.
TEST(Diagnose, CleanDataGiveNoFinding) {
  int found = 0, predictable = 0;
  for (uint64_t seed = 100; seed < 110; ++seed) {
    const DiagnosisResult res = runDiagnosis(seed, 0.05, {});
    for (const Finding& f : res.findings) std::printf("seed %llu: %s\n", (unsigned long long)seed, f.sentence.c_str());
    found += res.findings.empty() ? 0 : 1;
    EXPECT_NEAR(res.pooled_before, 0.05, 0.005);
    EXPECT_EQ(res.predictability.joints.size(), 7u);
    bool any = false;
    for (const JointPredictability& j : res.predictability.joints) any = any || j.predictable;
    predictable += any ? 1 : 0;
  }
  EXPECT_LE(found, 1);
  EXPECT_LE(predictable, 1);
}

// The first joint's axis is vertical: its armature column (joint acceleration) is the link's own Izz column,
// so it is reported as not separable and never tested; with the friction declared, no friction candidate.
TEST(Diagnose, CandidatesInTheDeclaredSpanAreNotTested) {
  const DiagnosisResult res = runDiagnosis(31, 0.05, {});
  bool armature0 = false;
  for (const CandidateScore& c : res.first_step) {
    if (c.effect.kind == EffectKind::Armature && c.effect.joint == 0) {
      armature0 = c.status == "not separable from the declared model";
      EXPECT_LT(c.separable, 1e-6);  // the link's own Izz column
    }
    if (c.effect.kind == EffectKind::Viscous) {
      EXPECT_GT(c.separable, 0.1);  // no declared column looks like v
    }
  }
  EXPECT_TRUE(armature0);
  DiagnoseOptions opt;
  opt.declared_friction = true;
  const DiagnosisResult rf = runDiagnosis(31, 0.05, {}, opt);
  EXPECT_EQ(rf.declared_columns, res.declared_columns + 14);
  for (const CandidateScore& c : rf.first_step)
    EXPECT_TRUE(c.effect.kind != EffectKind::Viscous && c.effect.kind != EffectKind::Coulomb);
}

TEST(Diagnose, TwoEffectsOnDifferentJointsAreBothFound) {
  const DiagnosisResult res =
      runDiagnosis(21, 0.05, {{EffectKind::Viscous, 0, 0.8}, {EffectKind::Offset, 6, -0.3}});
  bool visc = false, off = false;
  for (const Finding& f : res.findings) {
    visc = visc || (f.effect.kind == EffectKind::Viscous && f.effect.joint == 0 && std::fabs(f.effect.value - 0.8) < 0.08);
    off = off || (f.effect.kind == EffectKind::Offset && f.effect.joint == 6 && std::fabs(f.effect.value + 0.3) < 0.03);
  }
  EXPECT_TRUE(visc);
  EXPECT_TRUE(off);
  EXPECT_LT(res.pooled_after, 1.2 * 0.05);
}

// A held-base segment (a calibration run: the pelvis in a harness, tools::SourceOptions::held_base) hands its
// unmeasured rows (the base's, the passive ankles') on as zero rows. They must carry nothing: not into the fit,
// the row weights or the figures, and no candidate signal either. Synthetic exoskeleton data: a floating-base
// segment (base and legs moving, every row measured) with a constant 0.5 N m torque on the right ankle's passive
// in/eversion row, and a held segment (base at rest, legs swinging) whose measured rows carry the same model.
// With the flag the in/eversion offset is estimated from the floating segment alone (0.5) and the base rows'
// training RMS is the floating segment's; without it the held segment's zero rows would count as data: the
// offset's signal 1 against y = 0 pulls the estimate towards 0 and the zeros dilute the base rows' RMS.
TEST(Diagnose, HeldBaseSegmentsZeroRowsAreNotData) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  const int ie = static_cast<int>(std::find(model.joint_names.begin(), model.joint_names.end(), "right_ankle_ie") -
                                  model.joint_names.begin());
  ASSERT_LT(ie, model.njoints);
  ASSERT_FALSE(heldBaseRowMeasured(model, model.jointRow(ie)));  // unactuated: pinned in the harness
  std::mt19937_64 rng(7);
  const Trajectory tr = randomTrajectory(model, rng);
  std::normal_distribution<double> noise(0.0, 0.02);
  estimator::Run floating, held;
  Data data(model);
  for (double t = 0; t < 8.0; t += 0.005) {  // short: it also runs under the sanitizers
    State s = tr.at(model, t);
    s.base_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.2 * std::sin(0.7 * t), Eigen::Vector3d::UnitX()) *
                                            Eigen::AngleAxisd(0.1 * std::sin(0.3 * t), Eigen::Vector3d::UnitY()));
    s.base_omega = Eigen::Vector3d(0.3 * std::sin(0.9 * t), 0.2 * std::cos(0.4 * t), 0.1 * std::sin(1.3 * t));
    s.base_domega = Eigen::Vector3d(0.27 * std::cos(0.9 * t), -0.08 * std::sin(0.4 * t), 0.13 * std::cos(1.3 * t));
    s.base_acceleration = Eigen::Vector3d(0.5 * std::sin(1.1 * t), 0.4 * std::cos(0.6 * t), 0.3 * std::sin(0.5 * t));
    computeJointTorqueRegressor(model, data, s);
    Eigen::VectorXd y = data.K * model.phi;
    y[model.jointRow(ie)] += 0.5;
    for (int r = 0; r < model.nv; ++r) y[r] += noise(rng);
    floating.states.push_back(s), floating.t.push_back(t), floating.y.push_back(y);
    State h = tr.at(model, t + 100.0);  // another stretch of the swing; base at rest, upright
    computeJointTorqueRegressor(model, data, h);
    Eigen::VectorXd yh = data.K * model.phi;
    for (int r = 0; r < model.nv; ++r) yh[r] = heldBaseRowMeasured(model, r) ? yh[r] + noise(rng) : 0.0;
    held.states.push_back(h), held.t.push_back(t), held.y.push_back(yh);
  }
  auto heldSegment = [&](bool flag) {
    Segment sg;
    sg.name = "held";
    sg.held_base = flag;
    sg.stream = [&](const DiagnosisRowSink& sink, std::string*) {
      Data d(model);
      Eigen::MatrixXd K;
      for (size_t i = 0; i < held.states.size(); ++i) {
        computeJointTorqueRegressor(model, d, held.states[i]);
        K = d.K;
        for (int r = 0; r < model.nv; ++r)
          if (!heldBaseRowMeasured(model, r)) K.row(r).setZero();
        sink(held.t[i], K, held.y[i], held.y[i]);
      }
      return true;
    };
    return sg;
  };
  DiagnoseOptions opt;
  opt.kinds = {EffectKind::Offset};
  opt.coulomb_widths.clear();
  auto run = [&](bool flag, double& ie_offset, double& base_rms, double& floating_base_rms) {
    DiagnosisResult res;
    ASSERT_TRUE(diagnose(model, {segmentOf(model, floating, "floating"), heldSegment(flag)}, {}, opt, res, &err)) << err;
    ie_offset = NAN;
    for (const CandidateScore& c : res.first_step)
      if (c.effect.joint == ie) ie_offset = c.effect.value;
    base_rms = res.coordinates[3].train_rms_before;  // base_fx
    const Eigen::VectorXd r0 = res.series[0].before.col(3);
    floating_base_rms = std::sqrt(r0.squaredNorm() / r0.size());
  };
  double off_held, rms_held, rms_floating, off_plain, rms_plain, rms_floating2;
  run(true, off_held, rms_held, rms_floating);
  run(false, off_plain, rms_plain, rms_floating2);
  std::printf("[ held ] in/eversion offset %.4f (flag) / %.4f (no flag); base_fx training RMS %.4f / %.4f (floating "
              "segment %.4f)\n", off_held, off_plain, rms_held, rms_plain, rms_floating);
  EXPECT_NEAR(off_held, 0.5, 0.02);
  EXPECT_LT(off_plain, 0.35);  // measured 0.001: the held rows say 0 with the full weight of the data
  EXPECT_NEAR(rms_held, rms_floating, 1e-12 * rms_floating);
  EXPECT_LT(rms_plain, 0.8 * rms_floating2);  // sqrt(1/2) of it
}

// Dry friction sharper than the default width (tanh(v / 0.004) on joint 3, 0.5 N m): each joint's width is
// profiled on the training data, so the finding carries 0.005 (the grid's nearest to the truth), its value is
// right and the augmented model is at the noise floor; with the one default width (0.03 for every joint, as
// before the profile) the shape is wrong and a sixth of the effect's torque stays in the residual.
TEST(Diagnose, TheCoulombWidthIsProfiledPerJoint) {
  const double sigma = 0.05;
  const std::vector<Injected> sharp = {{EffectKind::Coulomb, 3, 0.5, 0.004}};
  const DiagnosisResult res = runDiagnosis(17, sigma, sharp);
  ASSERT_FALSE(res.findings.empty());
  const Finding& f = res.findings.front();
  std::printf("profiled: %s; held-out %.4f -> %.4f N m\n", f.sentence.c_str(), res.pooled_before, res.pooled_after);
  EXPECT_EQ(f.effect.kind, EffectKind::Coulomb) << f.sentence;
  EXPECT_EQ(f.effect.joint, 3) << f.sentence;
  EXPECT_EQ(f.effect.width, 0.005) << f.sentence;
  EXPECT_NEAR(f.effect.value, 0.5, 0.05) << f.sentence;
  EXPECT_LT(res.coordinates[3].rms_after, 1.1 * sigma);
  DiagnoseOptions fixed;
  fixed.coulomb_widths = {fixed.shape.coulomb_width};
  const DiagnosisResult old = runDiagnosis(17, sigma, sharp, fixed);
  ASSERT_FALSE(old.findings.empty());
  std::printf("fixed 0.03: %s; joint 3 held-out %.4f N m\n", old.findings.front().sentence.c_str(),
              old.coordinates[3].rms_after);
  EXPECT_EQ(old.findings.front().effect.width, 0.03);
  EXPECT_GT(old.coordinates[3].rms_after, 1.3 * res.coordinates[3].rms_after);
}

// Joint elasticity (issue 21 part 4): a linear spring k (q - q0) on lwr_3 with its rest angle at 0, and, in a second data
// set, an exponential one k s (exp((q - c) / s) - 1), s = 0.05 rad (lwr_4 swings +-0.11 rad), on lwr_4 about the training runs' mean angle c. Each
// is named on its joint with its kind and the stiffness at the mean angle (the linear one: k; the exponential: k at c)
// within 5 %, the exponential one with its scale; the linear spring is not called exponential (the refinement needs a
// clearly better held-out fit), and both joints end at the noise floor. The linear spring's constant part k (c - 0) is
// a torque offset: where the offset is found too, the sentence's rest angle is c - offset / k = 0.
TEST(Diagnose, JointElasticityIsNamedWithItsStiffnessAndShape) {
  const Model& model = kuka();
  const double sigma = 0.05;
  const DiagnosisResult lin = runDiagnosis(41, sigma, {{EffectKind::Elastic, 3, 2.0, 0.0, 0.0}});
  ASSERT_FALSE(lin.findings.empty());
  for (const Finding& f : lin.findings) std::printf("linear: %s\n", f.sentence.c_str());
  const Finding& fl = lin.findings.front();
  EXPECT_EQ(fl.effect.kind, EffectKind::Elastic) << fl.sentence;
  EXPECT_EQ(fl.effect.joint, 3) << fl.sentence;
  EXPECT_NEAR(fl.effect.value, 2.0, 0.1) << fl.sentence;
  for (const Finding& f : lin.findings)
    if (f.effect.kind == EffectKind::Offset && f.effect.joint == 3) {
      EXPECT_NEAR(fl.effect.center - f.effect.value / fl.effect.value, 0.0, 0.02) << f.sentence;
    }
  EXPECT_LT(lin.coordinates[3].rms_after, 1.1 * sigma);
  // The exponential spring's stiffness at the training mean: k exp((c - c_inj) / s) with c_inj = c here.
  const uint64_t seed = 43;
  const double c = meanTrainingAngles(model, seed, sigma)[4];
  const DiagnosisResult ex = runDiagnosis(seed, sigma, {{EffectKind::ElasticExp, 4, 1.5, 0.05, c}});
  ASSERT_FALSE(ex.findings.empty());
  const Finding& fe = expectFirstFinding(ex, "exponential", EffectKind::ElasticExp, 4, 0.05);
  EXPECT_NEAR(fe.effect.center, c, 1e-12);
  EXPECT_NEAR(fe.effect.value, 1.5, 0.075) << fe.sentence;
  EXPECT_LT(ex.coordinates[4].rms_after, 1.1 * sigma);
}

// The two-angle exponential spring (opt-in: DiagnoseOptions::kinds), k s (exp(((q_4 - c_4) + r (q_3 - c_3)) / s) - 1)
// on lwr_4 with k = 1.5 N m/rad, s = 0.1 and r = -0.7 (grid values), injected about the centers 0: named on lwr_4 with
// lwr_3 as its neighbour, that scale and ratio, and the stiffness at the training runs' mean angles, k exp(((c_4 - 0) +
// r (c_3 - 0)) / s), within 5 %; the joint at the noise floor. The one-angle exponential spring of
// JointElasticityIsNamedWithItsStiffnessAndShape, with the kind opted in, is still named elastic_exp (the refinement
// margin); with the default kinds the two-angle spring leaves more than 3x the two-angle kind's residual. This spring's
// residual comes in the few chunks where lwr_4 is far out: its fold gains range 13-2720, all positive, and the t-test
// alone gave p = 0.008 (not named); the signed-rank test beside it gives 1e-6 (screening.cpp, pairedTest).
TEST(Diagnose, ATwoAngleExponentialSpringIsNamedWithItsNeighbourScaleAndRatio) {
  const Model& model = kuka();
  const double sigma = 0.05, k = 1.5, s = 0.1, r = -0.7;
  const uint64_t seed = 47;
  const Eigen::VectorXd c = meanTrainingAngles(model, seed, sigma);
  DiagnoseOptions opt;
  opt.kinds.push_back(EffectKind::ElasticExpCoupled);
  Injected two{EffectKind::ElasticExpCoupled, 4, k, s, 0.0};
  two.coupled = 3, two.ratio = r;
  const DiagnosisResult res = runDiagnosis(seed, sigma, {two}, opt);
  ASSERT_FALSE(res.findings.empty());
  const Finding& f = expectFirstFinding(res, "two-angle", EffectKind::ElasticExpCoupled, 4, s);
  EXPECT_EQ(f.effect.coupled, 3) << f.sentence;
  EXPECT_EQ(f.effect.ratio, r) << f.sentence;
  EXPECT_NEAR(f.effect.center, c[4], 1e-12);
  EXPECT_NEAR(f.effect.coupled_center, c[3], 1e-12);
  const double at_centers = k * std::exp((c[4] + r * c[3]) / s);
  EXPECT_NEAR(f.effect.value, at_centers, 0.05 * at_centers) << f.sentence;
  EXPECT_LT(res.coordinates[4].rms_after, 1.1 * sigma);
  // The one-angle spring with the kind opted in: elastic_exp, as without it.
  const DiagnosisResult one = runDiagnosis(43, sigma, {{EffectKind::ElasticExp, 4, 1.5, 0.05, 0.0}}, opt);
  ASSERT_FALSE(one.findings.empty());
  std::printf("one-angle: %s\n", one.findings.front().sentence.c_str());
  EXPECT_EQ(one.findings.front().effect.kind, EffectKind::ElasticExp) << one.findings.front().sentence;
  EXPECT_EQ(one.findings.front().effect.joint, 4);
  // The default kinds on the two-angle spring: the one-angle shapes leave part of it.
  const DiagnosisResult dflt = runDiagnosis(seed, sigma, {two});
  for (const Finding& g : dflt.findings) std::printf("default kinds: %s\n", g.sentence.c_str());
  std::printf("lwr_4 held-out: two-angle %.4f, default kinds %.4f N m\n", res.coordinates[4].rms_after,
              dflt.coordinates[4].rms_after);
  EXPECT_GT(dflt.coordinates[4].rms_after, 3.0 * res.coordinates[4].rms_after);
}

// A wearer's passive joint moments (issue 21 part 4; docs/wearer.md): Riener & Edrich's elastic law, its biarticular
// coupling included (passiveElasticMoments, the simulator's own), on the exoskeleton's sagittal hip, knee and ankle joints
// as the moment the drives must overcome (y = K phi - tau_passive), on synthetic floating-base data about a standing
// posture with the knees bent 0.2 rad, every joint swinging about +-0.1 rad. Each of the six joints is named with an
// elastic kind first; the stiffness its own springs give at the mean posture (linear plus exponential: both have slope 1
// there) is within 10 % of the law's slope -d tau_j / d q_j; the strongest biarticular term, the knee's moment on the
// ankle's angle (-0.046 phi_A in the knee's first exponential), is named on both knees within 10 % of the law's
// -d tau_knee / d q_ankle; no finding on the joints the law leaves alone (hip ab/adduction, ankle in/eversion) and no
// kind other than elastic, an offset (the law's constant part) or viscous; held-out RMSE from 11x the noise to below 2.2x
// (what stays is the law's curvature beyond the candidates' shapes).
TEST(Diagnose, AWearersPassiveMomentsAreNamedAsSpringsOnTheirJoints) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  const char* sides[2] = {"left", "right"};
  int sag[2][3];
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 3; ++k) {
      const std::string name = std::string(sides[s]) + (k == 0 ? "_hip_fe" : k == 1 ? "_knee" : "_ankle_pd");
      sag[s][k] = model.jointIndex(name);
      ASSERT_GE(sag[s][k], 0) << name;
    }
  const double sigma = 0.05;
  const auto passive = [&](const Eigen::VectorXd& q) {
    Eigen::VectorXd tau = Eigen::VectorXd::Zero(model.njoints);
    for (int s = 0; s < 2; ++s) {
      const LegJoints m = passiveElasticMoments(LegJoints(q[sag[s][0]], q[sag[s][1]], q[sag[s][2]]));
      for (int k = 0; k < 3; ++k) tau[sag[s][k]] = m[k];
    }
    return tau;
  };
  const auto makeWearerRun = [&](uint64_t seed) {
    std::mt19937_64 rng(seed);
    Trajectory tr = randomTrajectory(model, rng);
    for (auto& a : tr.amp)
      for (double& x : a) x *= 0.3;  // about +-0.1 rad
    tr.offset.assign(static_cast<size_t>(model.njoints), 0.0);
    for (int s = 0; s < 2; ++s) tr.offset[static_cast<size_t>(sag[s][1])] = 0.2;
    std::normal_distribution<double> noise(0.0, sigma);
    estimator::Run run;
    Data data(model);
    for (double t = 0; t < 20.0; t += 0.005) {
      State st = tr.at(model, t);
      st.base_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * std::sin(0.7 * t), Eigen::Vector3d::UnitX()) *
                                               Eigen::AngleAxisd(0.05 * std::sin(0.3 * t), Eigen::Vector3d::UnitY()));
      st.base_acceleration = Eigen::Vector3d(0.3 * std::sin(1.1 * t), 0.2 * std::cos(0.6 * t), 0.1 * std::sin(0.5 * t));
      computeJointTorqueRegressor(model, data, st);
      Eigen::VectorXd y = data.K * model.phi;
      const Eigen::VectorXd tp = passive(st.q);
      for (int j = 0; j < model.njoints; ++j) y[model.jointRow(j)] -= tp[j];
      for (int r = 0; r < model.nv; ++r) y[r] += noise(rng);
      run.states.push_back(st), run.t.push_back(t), run.y.push_back(y);
    }
    return run;
  };
  const estimator::Run r1 = makeWearerRun(51), r2 = makeWearerRun(52), rv = makeWearerRun(53);
  DiagnosisResult res;
  ASSERT_TRUE(diagnose(model, {segmentOf(model, r1, "a"), segmentOf(model, r2, "b")}, {segmentOf(model, rv, "v")}, {}, res,
                       &err))
      << err;
  for (const Finding& f : res.findings) std::printf("%s\n", f.sentence.c_str());
  std::printf("held-out pooled %.4f -> %.4f N m\n", res.pooled_before, res.pooled_after);
  // The law's slope at the training runs' mean posture, by central differences.
  Eigen::VectorXd qm = Eigen::VectorXd::Zero(model.njoints);
  for (const estimator::Run* r : {&r1, &r2})
    for (const State& s : r->states) qm += s.q;
  qm /= static_cast<double>(r1.states.size() + r2.states.size());
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 3; ++k) {
      const int j = sag[s][k];
      Eigen::VectorXd qp = qm, qn = qm;
      qp[j] += 1e-6, qn[j] -= 1e-6;
      const double slope = -(passive(qp)[j] - passive(qn)[j]) / 2e-6;
      const Finding* first = nullptr;
      double stiffness = 0.0;
      for (const Finding& f : res.findings) {
        if (f.effect.joint != j) continue;
        if (!first) first = &f;
        if (f.effect.kind == EffectKind::Elastic || f.effect.kind == EffectKind::ElasticExp) stiffness += f.effect.value;
      }
      ASSERT_NE(first, nullptr) << model.joint_names[j] << ": no finding (law's stiffness " << slope << " N m/rad)";
      EXPECT_TRUE(isElastic(first->effect.kind)) << first->sentence;
      std::printf("%s: stiffness %.2f N m/rad, the law's %.2f\n", model.joint_names[j].c_str(), stiffness, slope);
      EXPECT_NEAR(stiffness, slope, 0.1 * slope) << model.joint_names[j];
    }
  for (int s = 0; s < 2; ++s) {  // the knee's moment on the ankle's angle
    const int knee = sag[s][1], ankle = sag[s][2];
    Eigen::VectorXd qp = qm, qn = qm;
    qp[ankle] += 1e-6, qn[ankle] -= 1e-6;
    const double coupling = -(passive(qp)[knee] - passive(qn)[knee]) / 2e-6;
    bool named = false;
    for (const Finding& f : res.findings)
      if (f.effect.kind == EffectKind::ElasticCoupled && f.effect.joint == knee && f.effect.coupled == ankle) {
        named = true;
        std::printf("%s on %s: %.2f N m/rad, the law's %.2f\n", model.joint_names[knee].c_str(),
                    model.joint_names[ankle].c_str(), f.effect.value, coupling);
        EXPECT_NEAR(f.effect.value, coupling, 0.1 * std::fabs(coupling)) << f.sentence;
      }
    EXPECT_TRUE(named) << model.joint_names[knee] << " on " << model.joint_names[ankle] << ": " << coupling << " N m/rad";
  }
  for (const Finding& f : res.findings) {
    const std::string& n = model.joint_names[f.effect.joint];
    EXPECT_TRUE(n.find("_aa") == std::string::npos && n.find("_ie") == std::string::npos) << f.sentence;
    EXPECT_TRUE(isElastic(f.effect.kind) || f.effect.kind == EffectKind::Offset || f.effect.kind == EffectKind::Viscous)
        << f.sentence;
  }
  EXPECT_GT(res.pooled_before, 8.0 * sigma);
  EXPECT_LT(res.pooled_after, 2.2 * sigma);
}

// The exponential spring's signal: slope 1 at its center, s (e^(x/s) - 1) beside it, and finite however far a posture
// lies past the scale (the exponent is capped: an overflow would poison every fit the column enters).
TEST(Diagnose, TheExponentialSpringsSignalIsExactNearItsCenterAndFiniteFarFromIt) {
  EffectShape sh;
  sh.center = 0.3, sh.elastic_scale = -0.05;
  const double h = 1e-7;
  EXPECT_NEAR((effectSignal(EffectKind::ElasticExp, sh, 0.3 + h, 0, 0, 0, 0) -
               effectSignal(EffectKind::ElasticExp, sh, 0.3 - h, 0, 0, 0, 0)) / (2 * h), 1.0, 1e-6);
  EXPECT_NEAR(effectSignal(EffectKind::ElasticExp, sh, 0.2, 0, 0, 0, 0), -0.05 * std::expm1(2.0), 1e-15);
  EXPECT_TRUE(std::isfinite(effectSignal(EffectKind::ElasticExp, sh, -100.0, 0, 0, 0, 0)));
  sh.elastic_scale = 0.0;  // no scale: the linear spring
  EXPECT_EQ(effectSignal(EffectKind::ElasticExp, sh, 0.5, 0, 0, 0, 0), effectSignal(EffectKind::Elastic, sh, 0.5, 0, 0, 0, 0));
}

// The two-angle exponential's angle and signal against Riener & Edrich's hip term exp(1.3403 - 0.0226 phi_K + 0.0305
// phi_H) (degrees): with s = 1 / (0.0305 deg) and r = -0.0226 / 0.0305 the signal is that term over its value at the
// centers, times s, minus s, at any posture; slope 1 in the joint's own angle and r in the neighbour's at the centers;
// r = 0 is the one-angle exponential; an elastic_coupled effect reads the neighbour's angle alone.
TEST(Diagnose, TheTwoAngleExponentialIsOneOfRienerAndEdrichsTerms) {
  constexpr double kDeg = 180.0 / M_PI;
  Effect e{EffectKind::ElasticExpCoupled, 1, 2.0, 0.0, 0.2, 2};  // center 0.2 rad, neighbour 2
  e.width = 1.0 / (0.0305 * kDeg), e.ratio = -0.0226 / 0.0305, e.coupled_center = 0.6;
  const EffectShape sh = effectShape(EffectShape{}, e);
  const auto term = [](double h, double kn) { return std::exp(1.3403 - 0.0226 * kDeg * kn + 0.0305 * kDeg * h); };
  for (const auto& [h, kn] : {std::pair{0.2, 0.6}, {-0.3, 0.0}, {0.5, 1.3}, {0.1, 0.9}}) {
    const double sig = effectSignal(e.kind, sh, effectAngle(e, h, kn), 0, 0, 0, 0);
    EXPECT_NEAR(sig, e.width * (term(h, kn) / term(0.2, 0.6) - 1.0), 1e-12) << h << " " << kn;
  }
  const double d = 1e-7;
  const auto at = [&](double h, double kn) { return effectSignal(e.kind, sh, effectAngle(e, h, kn), 0, 0, 0, 0); };
  EXPECT_NEAR((at(0.2 + d, 0.6) - at(0.2 - d, 0.6)) / (2 * d), 1.0, 1e-6);
  EXPECT_NEAR((at(0.2, 0.6 + d) - at(0.2, 0.6 - d)) / (2 * d), e.ratio, 1e-6);
  Effect one = e;
  one.kind = EffectKind::ElasticExp, one.ratio = 0.0;
  e.ratio = 0.0;
  EXPECT_EQ(effectSignal(e.kind, sh, effectAngle(e, 0.4, 1.1), 0, 0, 0, 0),
            effectSignal(one.kind, effectShape(EffectShape{}, one), effectAngle(one, 0.4, 1.1), 0, 0, 0, 0));
  EXPECT_TRUE(std::isfinite(at(-100.0, 50.0)));
  Effect lin{EffectKind::ElasticCoupled, 1, 2.0, 0.0, 0.1, 2};
  EXPECT_EQ(effectAngle(lin, 0.4, 1.1), 1.1);
  EXPECT_EQ(signalJoint(lin), 2);
  EXPECT_EQ(signalJoint(e), 2);
  EXPECT_EQ(refinedKind(EffectKind::ElasticExpCoupled), EffectKind::ElasticExp);
}

// A payload against a held declared model (the caller streams y - K phi_declared, as `--declared-model` does): 2 kg on
// lwr_6_link at (0.02, 0.05, 0.03) m with its own inertia, its torque from rnea on a model holding only the payload,
// and viscous friction on lwr_2_joint. The payload is named on its link with its mass and CoM (the fit has no inertia
// column: the error is the inertia's), the friction beside it; without the payload, no payload.
TEST(Diagnose, APayloadAgainstAHeldModelIsNamedWithItsMassAndCom) {
  const Model& model = kuka();
  const int link = model.bodyIndex("lwr_6_link");
  ASSERT_GE(link, 0);
  const double mass = 2.0;
  const Eigen::Vector3d com(0.02, 0.05, 0.03);
  Eigen::VectorXd payload = Eigen::VectorXd::Zero(model.nparams());
  payload.segment<kParamsPerBody>(model.bodyParamIndex(link)) =
      paramsFromInertial(mass, com, Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Identity() * 0.003);
  for (const double m : {1.0, 0.0}) {
    std::vector<estimator::Run> runs;
    for (uint64_t seed : {71, 72}) {
      estimator::Run r = makeRun(model, seed, 10.0, 0.05, {{EffectKind::Viscous, 2, 0.5}}, EffectShape{});
      DynamicsData dd(model);
      for (size_t i = 0; i < r.states.size(); ++i) {
        rnea(model, Eigen::VectorXd(m * payload), dd, r.states[i]);
        r.y[i] += dd.tau;
      }
      runs.push_back(std::move(r));
    }
    auto held = [&model](const estimator::Run& run, const std::string& name) {
      return Segment{name, [&model, &run](const DiagnosisRowSink& sink, std::string*) {
                       Data data(model);
                       for (size_t i = 0; i < run.states.size(); ++i) {
                         computeJointTorqueRegressor(model, data, run.states[i]);
                         sink(run.t[i], data.K, run.y[i] - data.K * model.phi, run.y[i]);  // the sensor: y itself
                       }
                       return true;
                     }};
    };
    DiagnoseOptions opt;
    opt.hold_declared = true;
    opt.kinds = {EffectKind::Viscous, EffectKind::Offset, EffectKind::GainError};
    DiagnosisResult res;
    std::string err;
    ASSERT_TRUE(diagnose(model, {held(runs[0], "a")}, {held(runs[1], "v")}, opt, res, &err)) << err;
    EXPECT_EQ(res.declared_columns, 0);
    EXPECT_EQ(static_cast<int>(res.payload_first_step.size()), model.nbodies);
    ASSERT_EQ(res.findings.size(), 1u);
    EXPECT_EQ(res.findings[0].effect.kind, EffectKind::Viscous);
    EXPECT_NEAR(res.findings[0].effect.value, 0.5, 0.02);
    if (m == 0.0) {
      EXPECT_TRUE(res.payloads.empty()) << res.payloads[0].sentence;
      continue;
    }
    ASSERT_EQ(res.payloads.size(), 1u);
    std::printf("%s\n", res.payloads[0].sentence.c_str());
    EXPECT_EQ(res.payloads[0].link, link) << res.payloads[0].sentence;
    EXPECT_NEAR(res.payloads[0].mass, mass, 0.01 * mass) << res.payloads[0].sentence;
    EXPECT_LT((res.payloads[0].com - com).norm(), 0.002) << res.payloads[0].sentence;
    EXPECT_LT(res.pooled_after, 1.2 * 0.05);
  }
}

TEST(Diagnose, SidecarRoundTripsAndRejectsBadEntries) {
  const Model& model = kuka();
  EffectSet set;
  set.model = "kuka_lwr4.urdf";
  set.shape.coulomb_width = 0.02;
  set.effects = {{EffectKind::Offset, 0, 0.83},
                 {EffectKind::GainError, 4, -0.031},
                 {EffectKind::Coulomb, 2, 0.4, 0.005},
                 {EffectKind::Elastic, 1, 3.25, 0.0, 0.123},
                 {EffectKind::ElasticExp, 5, 1.5, -0.1, -0.25},
                 {EffectKind::ElasticCoupled, 2, -0.75, 0.0, 0.05, 3},
                 {EffectKind::ElasticExpCoupled, 4, 2.5, -0.2, 0.3, 3}};
  set.effects.back().ratio = -0.7, set.effects.back().coupled_center = -0.125;
  const std::string path = testing::TempDir() + "effects_" + std::to_string(::getpid()) + ".yaml";
  std::string err;
  ASSERT_TRUE(writeEffects(path, model, set, &err)) << err;
  EffectSet back;
  ASSERT_TRUE(readEffects(path, model, back, &err)) << err;
  ASSERT_EQ(back.effects.size(), 7u);
  EXPECT_EQ(back.effects[6].kind, EffectKind::ElasticExpCoupled);
  EXPECT_EQ(back.effects[6].coupled, 3);
  EXPECT_EQ(back.effects[6].value, 2.5);
  EXPECT_EQ(back.effects[6].width, -0.2);
  EXPECT_EQ(back.effects[6].center, 0.3);
  EXPECT_EQ(back.effects[6].ratio, -0.7);
  EXPECT_EQ(back.effects[6].coupled_center, -0.125);
  EXPECT_EQ(back.effects[5].kind, EffectKind::ElasticCoupled);
  EXPECT_EQ(back.effects[5].coupled, 3);
  EXPECT_EQ(back.effects[5].center, 0.05);
  EXPECT_EQ(back.effects[5].value, -0.75);
  EXPECT_EQ(back.effects[3].kind, EffectKind::Elastic);
  EXPECT_EQ(back.effects[3].center, 0.123);
  EXPECT_EQ(back.effects[3].value, 3.25);
  EXPECT_EQ(back.effects[4].kind, EffectKind::ElasticExp);
  EXPECT_EQ(back.effects[4].width, -0.1);
  EXPECT_EQ(back.effects[4].center, -0.25);
  EXPECT_EQ(back.effects[2].width, 0.005);
  EXPECT_EQ(back.effects[0].width, 0.0);
  EXPECT_EQ(back.effects[1].kind, EffectKind::GainError);
  EXPECT_EQ(back.effects[1].joint, 4);
  EXPECT_EQ(back.effects[1].value, -0.031);
  EXPECT_EQ(back.shape.coulomb_width, 0.02);
  // Joint names as a user's URDF may have them: 600 characters (the lines were once cut at 512 bytes, silently) and
  // YAML's own characters; written quoted, they read back to the same set.
  {
    Model named = model;
    named.joint_names[4] = std::string(600, 'j') + "_4";
    named.joint_names[3] = "lwr: \"3\", {x}";
    ASSERT_TRUE(writeEffects(path, named, set, &err)) << err;
    EffectSet again;
    ASSERT_TRUE(readEffects(path, named, again, &err)) << err;
    ASSERT_EQ(again.effects.size(), set.effects.size());
    for (size_t i = 0; i < set.effects.size(); ++i) {
      EXPECT_EQ(again.effects[i].joint, set.effects[i].joint) << i;
      EXPECT_EQ(again.effects[i].coupled, set.effects[i].coupled) << i;
      EXPECT_EQ(again.effects[i].value, set.effects[i].value) << i;
      EXPECT_EQ(again.effects[i].ratio, set.effects[i].ratio) << i;
    }
  }
  // Found by fuzz_effects_sidecar: a model name with a quote is written so that it reads back; a YAML error quoting a
  // control character is still one line.
  set.model = "exo \"v2\".urdf";
  ASSERT_TRUE(writeEffects(path, model, set, &err)) << err;
  ASSERT_TRUE(readEffects(path, model, back, &err)) << err;
  EXPECT_EQ(back.model, set.model);
  {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("model: \"exo\\\001.urdf\"\neffects: []\n", f);
    std::fclose(f);
  }
  EXPECT_FALSE(readEffects(path, model, back, &err));
  EXPECT_EQ(err.find('\n'), std::string::npos) << err;
  EXPECT_EQ(err.find('\001'), std::string::npos) << err;
  {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("effects:\n  - {joint: no_such_joint, kind: offset, value: 1}\n", f);
    std::fclose(f);
  }
  EXPECT_FALSE(readEffects(path, model, back, &err));
  EXPECT_NE(err.find("no_such_joint"), std::string::npos) << err;
  {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("effects:\n  - {joint: lwr_0_joint, kind: magic, value: 1}\n", f);
    std::fclose(f);
  }
  EXPECT_FALSE(readEffects(path, model, back, &err));
  EXPECT_NE(err.find("magic"), std::string::npos) << err;
  for (const char* bad : {"effects:\n  - {joint: lwr_0_joint, kind: offset, value: 1, width: 0.01}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: coulomb, value: 1, width: -0.01}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: coulomb, value: 1, widht: 0.01}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic, value: 1}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: offset, value: 1, center: 0.1}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp, value: 1, center: 0.1}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp, value: 1, center: 0.1, width: 0}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic, value: 1, center: .nan}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_coupled, value: 1, center: 0}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_coupled, value: 1, center: 0, angle_of: lwr_0_joint}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic, value: 1, center: 0, angle_of: lwr_1_joint}\n",
                          // elastic_exp_coupled: its ratio and the neighbour's center are required, and its only
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp_coupled, value: 1, center: 0, width: 0.1, "
                          "angle_of: lwr_1_joint, angle_of_center: 0}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp_coupled, value: 1, center: 0, width: 0.1, "
                          "angle_of: lwr_1_joint, ratio: 0.5}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp_coupled, value: 1, center: 0, width: 0.1, "
                          "ratio: 0.5, angle_of_center: 0}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp_coupled, value: 1, center: 0, width: 0.1, "
                          "angle_of: lwr_1_joint, ratio: .inf, angle_of_center: 0}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp_coupled, value: 1, center: 0, "
                          "angle_of: lwr_1_joint, ratio: 0.5, angle_of_center: 0}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_exp, value: 1, center: 0, width: 0.1, ratio: 0.5}\n",
                          "effects:\n  - {joint: lwr_0_joint, kind: elastic_coupled, value: 1, center: 0, angle_of: lwr_1_joint, "
                          "angle_of_center: 0}\n"}) {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs(bad, f);
    std::fclose(f);
    EXPECT_FALSE(readEffects(path, model, back, &err)) << bad;
    EXPECT_NE(err.find("effects[0]"), std::string::npos) << err;
  }
  // base_body_moves (an unmeasured body on the floating base): read back on a floating base, refused on a fixed one
  // (the KUKA) and unless true or false; a refused file leaves the set as it was.
  Model exo;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, exo, &err)) << err;
  EffectSet moving;
  moving.model = "exo.urdf";
  moving.base_body_moves = true;
  ASSERT_TRUE(writeEffects(path, exo, moving, &err)) << err;
  ASSERT_TRUE(readEffects(path, exo, back, &err)) << err;
  EXPECT_TRUE(back.base_body_moves);
  EXPECT_TRUE(back.effects.empty());
  EXPECT_FALSE(writeEffects(path, model, moving, &err));
  EXPECT_NE(err.find("floating base"), std::string::npos) << err;
  for (const char* bad : {"base_body_moves: yes\neffects: []\n", "base_body_moves: 1\neffects: []\n",
                          "base_body_moves: [true]\neffects: []\n"}) {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs(bad, f);
    std::fclose(f);
    EXPECT_FALSE(readEffects(path, exo, back, &err)) << bad;
    EXPECT_NE(err.find("base_body_moves must be true or false"), std::string::npos) << err;
    EXPECT_TRUE(back.base_body_moves) << "a refused file changed the set";
  }
  {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("base_body_moves: true\neffects: []\n", f);
    std::fclose(f);
  }
  EXPECT_FALSE(readEffects(path, model, back, &err));
  EXPECT_NE(err.find("needs a floating base"), std::string::npos) << err;
  std::remove(path.c_str());
}

}  // namespace
}  // namespace exoid::estimator

namespace exoid::estimator {
namespace {
// A sidecar's dynamics effects as extra columns of the online estimator (prior 0): on data holding those
// effects (viscous 2 N m s/rad on joint 2, Coulomb 0.8 N m on joint 4, armature 0.3 kg m^2 on joint 1, a spring of
// 4 N m/rad about 0.1 rad on joint 5, a gain
// the measurement correction undoes, no noise, prior = the true rigid parameters) the recursive LS recovers
// the values and predicts fresh data exactly; without the columns its prediction keeps the effects' torque.
TEST(DiagnoseOnline, SidecarColumnsInTheRecursiveLsRecoverTheEffects) {
  const Model& model = kuka();
  EffectSet set;
  set.effects = {{EffectKind::Viscous, 2, 2.0},     {EffectKind::Coulomb, 4, 0.8},
                 {EffectKind::Armature, 1, 0.3},    {EffectKind::GainError, 3, 0.05},
                 {EffectKind::Elastic, 5, 4.0, 0.0, 0.1},   {EffectKind::ElasticExpCoupled, 6, 1.5, 0.2, 0.05, 5}};
  set.effects.back().ratio = -0.7, set.effects.back().coupled_center = 0.1;
  std::vector<Injected> injected = {{EffectKind::Viscous, 2, 2.0},  {EffectKind::Coulomb, 4, 0.8},
                                    {EffectKind::Armature, 1, 0.3}, {EffectKind::GainError, 3, 0.05},
                                    {EffectKind::Elastic, 5, 4.0, 0.0, 0.1}, {EffectKind::ElasticExpCoupled, 6, 1.5, 0.2, 0.05}};
  injected.back().coupled = 5, injected.back().ratio = -0.7, injected.back().coupled_center = 0.1;
  const estimator::Run train = makeRun(model, 41, 20.0, 0.0, injected, set.shape), val = makeRun(model, 42, 10.0, 0.0, injected, set.shape);
  ASSERT_EQ(effectColumnCount(set), 5);
  const BaseParameters base = computeBaseParameters(model);
  RecursiveLsModel rigid, augmented;
  std::string err;
  ASSERT_TRUE(makeRecursiveLs(model, base, model.phi, diagonalPriorInformation(model, base, model.phi, 0.25), {}, rigid, &err)) << err;
  augmented = rigid;
  std::vector<int> rows;
  for (const Effect& e : set.effects)
    if (!isMeasurementEffect(e.kind)) rows.push_back(model.jointRow(e.joint));
  EXPECT_FALSE(addExtraColumns(augmented, {0}, Eigen::VectorXd::Ones(2), &err));  // sizes disagree
  ASSERT_TRUE(addExtraColumns(augmented, rows, Eigen::VectorXd::Constant(5, 100.0), &err)) << err;
  EXPECT_EQ(augmented.m, rigid.m + 5);
  EXPECT_EQ(augmented.p, rigid.p + 5);
  RecursiveLsData dr(rigid), da(augmented);
  const int p = model.nparams(), nv = model.nv;
  Data kin(model);
  Eigen::MatrixXd Ka(nv, p + 5);
  Eigen::VectorXd y(nv);
  auto rowsAt = [&](const estimator::Run& r, size_t i) {
    computeJointTorqueRegressor(model, kin, r.states[i]);
    Ka.leftCols(p) = kin.K;
    effectColumns(model, set, r.states[i].q, r.states[i].v, r.states[i].a, Ka.rightCols(5));
    y = r.y[i];
    ASSERT_TRUE(correctMeasurement(model, set, y));
  };
  for (size_t i = 0; i < train.states.size(); ++i) {
    rowsAt(train, i);
    updateRecursiveLs(rigid, dr, static_cast<long>(i), kin.K, train.y[i]);
    updateRecursiveLs(augmented, da, static_cast<long>(i), Ka, y);
  }
  ASSERT_TRUE(solveRecursiveLs(rigid, dr, false));
  ASSERT_TRUE(solveRecursiveLs(augmented, da, false));
  EXPECT_NEAR(da.x[rigid.m], 2.0, 1e-4);
  EXPECT_NEAR(da.x[rigid.m + 1], 0.8, 1e-4);
  EXPECT_NEAR(da.x[rigid.m + 2], 0.3, 1e-4);
  EXPECT_NEAR(da.x[rigid.m + 3], 4.0, 1e-4);  // the spring's stiffness, from the joint position the columns now take
  EXPECT_NEAR(da.x[rigid.m + 4], 1.5, 1e-4);  // the two-angle spring's, from both joints' positions
  double sse_r = 0, sse_a = 0, sse_y = 0;
  Eigen::VectorXd pr(nv), pa(nv);
  for (size_t i = 0; i < val.states.size(); ++i) {
    rowsAt(val, i);
    predictRecursiveLs(rigid, dr, kin.K, pr);
    predictRecursiveLs(augmented, da, Ka, pa);
    sse_r += (y - pr).squaredNorm(), sse_a += (y - pa).squaredNorm(), sse_y += y.squaredNorm();
  }
  EXPECT_LT(std::sqrt(sse_a / sse_y), 1e-5);
  EXPECT_GT(std::sqrt(sse_r / sse_y), 1e-2);
  // A delay cannot be undone causally: refused, y untouched.
  EffectSet delayed = set;
  delayed.effects.push_back({EffectKind::Delay, 0, 0.01});
  Eigen::VectorXd y0 = Eigen::VectorXd::Ones(nv), y1 = y0;
  EXPECT_FALSE(correctMeasurement(model, delayed, y1));
  EXPECT_EQ(y1, y0);
}
}  // namespace
}  // namespace exoid::estimator
