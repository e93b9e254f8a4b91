// exo_estimator with a diagnose sidecar (--effects, docs/estimator.md "Extra columns"): the process's loop
// (EstimatorNode over memq://, the estimator built as exo_estimator builds it from the sidecar file) on in-process
// closed-loop runs of config/scenarios/diagnose/ (undeclared dry friction 3 N m, viscous damping 5 N m s/rad, on
// the right knee; realistic sensor noise; 3 moves train, 2 other moves held out), against the batch diagnosis on
// the same runs and the seeded value; bad sidecars.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/channels.hpp>
#include <filesystem>
#include <fstream>
#include <memory>
#include <unistd.h>

#include "estimator_node.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/sim/config.hpp"
#include "recorded_run.hpp"
#include "sim_closed_loop.hpp"

namespace exoid::estimator {
namespace {

using controller::testing::configPath;

using Log = testing::RecordedRun;

Log record(const Model& model, uint64_t seed, int moves, const char* scenario_file) {
  return testing::recordRun(model, seed, moves, scenario_file);
}

// The held-out rows: exoid diagnose's pipeline for the exoskeleton (sensors only, the one zero-phase 5 Hz filter on
// K and y, run ends trimmed: docs/diagnose.md), whose clean residual is at the sensor-noise level.
DatasetOptions heldOutPipeline(const Model& model) {
  DatasetOptions dopt;
  dopt.cutoff_hz = 5.0;
  dopt.filter = FilterMode::Parallel;
  dopt.trim_edges = true;
  dopt.footholds = defaultFootholds(model);
  return dopt;
}

// Streams a log's rows (K, y, the torque sensors' part of y) through the dataset pipeline.
bool streamLog(const Model& model, const Log& log, const DiagnosisRowSink& sink, std::string* err) {
  const int feet[2] = {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")};
  const DatasetBuilder* self = nullptr;
  DatasetBuilder builder(model, heldOutPipeline(model), [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    sink(t, K, y, self->sensorTorque());
  });
  self = &builder;
  MeasuredSample s;
  for (size_t i = 0; i < log.states.size(); ++i) {
    const ForcePlateSample* plates[2] = {&log.plates[i][0], &log.plates[i][1]};
    measuredFromSensors(model, log.states[i], plates, feet, s);
    if (!builder.add(s, err)) return false;
  }
  return builder.finish(err);
}

// Rows into an accumulator, optionally through an EffectCorrector (the effects at the given values subtracted
// from y, gains divided out: what `exoid identify --effects` does).
long accumulate(const Model& model, const Log& log, const EffectSet* effects, LsqAccumulator& acc) {
  long rows = 0;
  const RowSink add = [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) { rows += acc.add(K, y) ? 1 : 0; };
  std::unique_ptr<EffectCorrector> corrector;
  if (effects) corrector = std::make_unique<EffectCorrector>(model, *effects, add);
  std::string err;
  EXPECT_TRUE(streamLog(model, log, [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& ts) {
    if (corrector) corrector->add(t, K, y, &ts);
    else add(t, K, y);
  }, &err)) << err;
  if (corrector) corrector->finish();
  acc.flush();
  return rows;
}

double rowRmse(const LsqAccumulator& acc, int c, const Eigen::VectorXd& x, long rows) {
  return std::sqrt(acc.residual(c, x) / static_cast<double>(rows));
}

// The training log through exo_estimator's loop over memq:// (state and plate messages, EXO_ESTIMATE out).
EstimatorOutputSample runNode(const Model& model, OnlineEstimator& est, const Log& log, long* published) {
  LcmEndpoint lcm("memq://");
  NodeOptions nopt;
  nopt.reconcile_async = false;
  EstimatorNode node(lcm, model, est, nopt);
  exoid_lcm::robot_state_t sm;
  exoid_lcm::force_plate_t pm;
  std::string err;
  auto drain = [&] {
    while (node.poll(0, &err) > 0) {
    }
  };
  for (size_t i = 0; i < log.states.size(); ++i) {
    toLcm(log.states[i], model.joint_names, sm);
    lcm.publish(channels::kState, sm);
    drain();
    for (int p = 0; p < 2; ++p) {
      toLcm(log.plates[i][p], pm);
      lcm.publish(p == 0 ? channels::kPlateRight : channels::kPlateLeft, pm);
      drain();
    }
  }
  *published = node.publications();
  return node.lastOutput();
}

struct ExoSetup {
  Model model;
  BaseParameters base;
};
const ExoSetup& setup() {
  static const ExoSetup s = [] {
    ExoSetup x;
    std::string err;
    EXPECT_TRUE(controller::testing::loadModel(x.model, &err)) << err;
    x.base = computeBaseParameters(x.model);
    return x;
  }();
  return s;
}

// One run of the loop with and without a one-effect sidecar, and the held-out right-knee RMSE of each.
struct Compared {
  EstimatorOutputSample with, without;
  double effect = 0.0;                    ///< the sidecar column's online value
  double knee_with = 0.0, knee_without = 0.0;  ///< held-out right-knee RMSE, N m
  long rows = 0;
};
Compared compare(const Log& train, const Log& held, const Effect& sidecar_effect, OnlineEstimator** est_with_out,
                 std::unique_ptr<OnlineEstimator>* keep) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  std::string err;
  // The sidecar as `exoid diagnose` writes it, read back by the one parser (exo_estimator --effects).
  const std::string path = "/tmp/exoid_test_online_effects_" + std::to_string(getpid()) + ".yaml";
  EffectSet found;
  found.model = "exo.urdf";
  found.effects.push_back(sidecar_effect);
  EXPECT_TRUE(writeEffects(path, model, found, &err)) << err;
  // Without the torque sensors' offset and gain columns (the batch diagnosis compared with has none; with them,
  // the default, the knee's held-out RMSE is 0.296 N m against the batch's 0.226: their columns take part of the
  // knee row's signal).
  OnlineEstimatorOptions with, without;
  with.sensor_offset_sigma = without.sensor_offset_sigma = 0.0;
  with.sensor_gain_sigma = without.sensor_gain_sigma = 0.0;
  EXPECT_TRUE(readEffects(path, model, with.effects, &err)) << err;
  std::filesystem::remove(path);
  *keep = std::make_unique<OnlineEstimator>(model, s.base, model.phi, with);
  OnlineEstimator est(model, s.base, model.phi, without);
  EXPECT_TRUE((*keep)->ok() && est.ok()) << (*keep)->error() << est.error();
  EXPECT_EQ((*keep)->effectColumnCount(), 1);
  Compared c;
  long pub_with = 0, pub = 0;
  c.with = runNode(model, **keep, train, &pub_with);
  c.without = runNode(model, est, train, &pub);
  EXPECT_GT(pub_with, 100);
  EXPECT_EQ(pub_with, pub);
  const int m = s.base.rank, r = model.jointRow(sidecar_effect.joint);
  EXPECT_EQ(c.with.base_params.size(), m + 1);  // the effect column travels after the base parameters
  EXPECT_EQ(c.without.base_params.size(), m);
  c.effect = c.with.base_params[m];
  AccumulatorOptions one;
  one.folds = 1;
  LsqAccumulator held_rigid(model, s.base, one), held_fx(model, s.base, one);
  c.rows = accumulate(model, held, nullptr, held_rigid);
  EffectSet online = with.effects;
  online.effects[0].value = c.effect;
  EXPECT_EQ(accumulate(model, held, &online, held_fx), c.rows);
  c.knee_with = rowRmse(held_fx, r, c.with.base_params.head(m), c.rows);
  c.knee_without = rowRmse(held_rigid, r, c.without.base_params, c.rows);
  *est_with_out = keep->get();
  return c;
}

// Undeclared dry friction (MuJoCo frictionloss 3 N m on the right knee): the sidecar's tanh(v / w) column is a
// signal the rigid model's own hard-sign Coulomb column is not (sign of a noisy differenced velocity), so the
// process-shaped loop with the sidecar predicts the held-out knee torque far better. Independent reference: the
// batch diagnosis (its defaults: declared model rigid, candidate Coulomb tanh(v / w)) on the same runs.
TEST(OnlineEffects, SidecarInTheEstimatorNodeCompensatesUndeclaredDryFriction) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  const int m = s.base.rank, knee = model.jointIndex("right_knee"), r = model.jointRow(knee);
  ASSERT_GE(knee, 0);
  const char* scenario = "scenarios/diagnose/coulomb_right_knee_3.yaml";
  const Log train = record(model, 1, 3, scenario), held = record(model, 2, 2, scenario);
  DiagnoseOptions dopt;
  dopt.kinds = {EffectKind::Coulomb};
  auto segment = [&](const char* name, const Log& log) {
    return Segment{name, [&model, &log](const DiagnosisRowSink& sink, std::string* e) { return streamLog(model, log, sink, e); }};
  };
  DiagnosisResult batch;
  std::string err;
  ASSERT_TRUE(diagnose(model, {segment("train", train)}, {segment("held", held)}, dopt, batch, &err)) << err;
  double batch_value = 0.0, batch_width = 0.0;
  for (const Finding& f : batch.findings)
    if (f.effect.joint == knee) batch_value = f.effect.value, batch_width = f.effect.width;
  ASSERT_GT(batch_value, 0.0) << "the batch diagnosis found no Coulomb friction on the right knee";
  const double batch_knee = batch.coordinates[r].rms_after, batch_knee_before = batch.coordinates[r].rms_before;
  // The sidecar the diagnosis writes: its value (the online column's prior sigma is 10 x it) and profiled width.
  std::unique_ptr<OnlineEstimator> keep;
  OnlineEstimator* est = nullptr;
  const Compared c = compare(train, held, {EffectKind::Coulomb, knee, batch_value, batch_width}, &est, &keep);
  // The rigid model's own Coulomb column sign(v) (fc, a base parameter by itself) shares the dry friction with the
  // sidecar's tanh(v / w): at sliding speed (|v| >> w) the online friction is their sum.
  int fc = -1;
  for (int j = 0; j < m; ++j)
    if (s.base.independent[j] == model.frictionParamIndex(knee) + 1) fc = j;
  ASSERT_GE(fc, 0);
  const double sliding = c.effect + c.with.base_params[fc];
  std::printf("dry friction right knee (seeded 3 N m): online sidecar column %.3f + fc %.3f = %.3f N m (without the "
              "sidecar fc %.3f), batch diagnosis %.3f N m\n"
              "held-out right-knee RMSE: online + sidecar %.4f, online rigid + fv + fc %.4f; batch diagnosis %.4f -> %.4f N m\n",
              c.effect, c.with.base_params[fc], sliding, c.without.base_params[fc], batch_value, c.knee_with,
              c.knee_without, batch_knee_before, batch_knee);
  EXPECT_GT(batch_width, 0.0);
  EXPECT_NEAR(sliding, batch_value, 0.15 * batch_value);
  EXPECT_LT(c.knee_with, 0.6 * c.knee_without);
  EXPECT_LT(c.knee_with, 1.25 * batch_knee);

  // tau_correction = the rigid correction K(q, 0, 0)(phi_hat - phi_model) plus the effect's filtered column times its value;
  // the rigid part recomputed here from the configuration of the published tick (a publication made now, so that
  // its tick is the last sample's).
  EstimatorOutputSample out;
  est->sizeOutput(out);
  est->fillOutput(out);
  const long tick = out.tick;
  ASSERT_TRUE(tick >= 0 && static_cast<size_t>(tick) < train.states.size());
  const RobotStateSample& st_sample = train.states[static_cast<size_t>(tick)];
  ASSERT_EQ(st_sample.tick, tick);
  ASSERT_EQ(est->lastRowTick(), tick);
  State st = State::zero(model);
  st.q = st_sample.q;
  st.base_orientation = st_sample.imu_orientation.normalized();
  Data data(model);
  computeJointTorqueRegressor(model, data, st);
  const Eigen::VectorXd dx = out.base_params.head(m) - s.base.base_map * model.phi;
  const double column = est->lastK()(r, model.nparams());  // F(tanh(v / w)) of the published sample
  for (int j = 0; j < model.njoints; ++j) {
    const int row = model.jointRow(j);
    double ff = row == r ? column * out.base_params[m] : 0.0;
    for (int k = 0; k < m; ++k) ff += data.K(row, s.base.independent[k]) * dx[k];
    EXPECT_NEAR(out.tau_correction[row], ff, 1e-9 * (1.0 + std::fabs(ff))) << model.joint_names[j];
  }
}

// Undeclared viscous damping (5 N m s/rad, right knee): the rigid model already carries a viscous column per joint
// (fv, prior 0 +- 0.25), and the sidecar's column (the same signal v) takes the value over (its prior is 10 x
// wider) and predicts the held-out run better. Without the sidecar the 3 moves, counted per independent sample
// (the default row weighting), inform fv about as much as its prior, which puts it 20 sigma off: fv moves more
// than 40 % of the way (measured 2.84 of 5; with WLS-R weights, which count every 1 kHz row, all the way).
TEST(OnlineEffects, SidecarViscousColumnTakesOverTheRigidModelsOwn) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  const int m = s.base.rank, knee = model.jointIndex("right_knee");
  const char* scenario = "scenarios/diagnose/viscous_right_knee_5.yaml";
  const Log train = record(model, 1, 3, scenario), held = record(model, 2, 2, scenario);
  std::unique_ptr<OnlineEstimator> keep;
  OnlineEstimator* est = nullptr;
  const Compared c = compare(train, held, {EffectKind::Viscous, knee, 4.84}, &est, &keep);
  int fv = -1;
  for (int j = 0; j < m; ++j)
    if (s.base.independent[j] == model.frictionParamIndex(knee)) fv = j;
  ASSERT_GE(fv, 0);
  constexpr double kSeeded = 5.0;
  std::printf("viscous right knee (seeded %.1f): online + sidecar column %.3f + fv %.3f, online rigid fv %.3f\n"
              "held-out right-knee RMSE: online + sidecar %.4f, online rigid %.4f N m\n",
              kSeeded, c.effect, c.with.base_params[fv], c.without.base_params[fv], c.knee_with, c.knee_without);
  EXPECT_NEAR(c.effect + c.with.base_params[fv], kSeeded, 0.15 * kSeeded);
  EXPECT_GT(c.without.base_params[fv], 0.4 * kSeeded);
  EXPECT_LT(c.without.base_params[fv], 1.15 * kSeeded);
  EXPECT_GT(c.effect, 0.9 * (c.effect + c.with.base_params[fv]));
  EXPECT_LT(c.knee_with, 0.7 * c.knee_without);  // measured 0.0548 against 0.1007 N m
}

TEST(OnlineEffects, BadSidecarsAreRefusedWithTheReason) {
  Model model;
  std::string err;
  ASSERT_TRUE(controller::testing::loadModel(model, &err)) << err;
  const std::string dir = "/tmp/exoid_test_online_effects_bad_" + std::to_string(getpid());
  std::filesystem::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name) << text;
    return dir + "/" + name;
  };
  EffectSet set;
  EXPECT_FALSE(readEffects(dir + "/missing.yaml", model, set, &err));
  EXPECT_NE(err.find("cannot open"), std::string::npos) << err;
  EXPECT_FALSE(readEffects(write("joint.yaml", "effects:\n  - {joint: tail, kind: viscous, value: 1}\n"), model, set, &err));
  EXPECT_NE(err.find("unknown joint 'tail'"), std::string::npos) << err;
  EXPECT_FALSE(readEffects(write("kind.yaml", "effects:\n  - {joint: right_knee, kind: magic, value: 1}\n"), model, set, &err));
  EXPECT_NE(err.find("unknown kind 'magic'"), std::string::npos) << err;
  EXPECT_FALSE(readEffects(write("yaml.yaml", "effects: [ {joint: right_knee\n"), model, set, &err));
  EXPECT_NE(err.find("YAML"), std::string::npos) << err;
  // A delay is valid in a sidecar but needs the future of the torque: the online estimator refuses it.
  ASSERT_TRUE(readEffects(write("delay.yaml", "effects:\n  - {joint: right_knee, kind: delay, value: 0.01}\n"), model, set, &err)) << err;
  OnlineEstimatorOptions opt;
  opt.effects = set;
  const BaseParameters base = computeBaseParameters(model);
  OnlineEstimator est(model, base, model.phi, opt);
  EXPECT_FALSE(est.ok());
  EXPECT_NE(est.error().find("delay (right_knee)"), std::string::npos) << est.error();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace exoid::estimator
