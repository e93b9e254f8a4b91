// exo_estimator's loop (estimator/apps/estimator_node.hpp) in-process over memq://: sensor messages in,
// EXO_ESTIMATE out equal to the OnlineEstimator fed the same samples directly; bad messages (undecodable,
// non-finite, duplicate, out of order) rejected and counted in the message; checkpoint written and resumed.
#include <gtest/gtest.h>

#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/channels.hpp>
#include <filesystem>
#include <random>
#include <unistd.h>

#include "estimator_node.hpp"
#include "exoid/model/urdf.hpp"
#include "synthetic_sensors.hpp"

namespace exoid::estimator {
namespace {

struct ExoSetup {
  Model model;
  BaseParameters base;
};

const ExoSetup& setup() {
  static const ExoSetup s = [] {
    ExoSetup x;
    std::string err;
    EXPECT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, x.model, &err)) << err;
    x.base = computeBaseParameters(x.model);
    return x;
  }();
  return s;
}

void drain(EstimatorNode& node) {
  std::string err;
  while (node.poll(0, &err) > 0) {
  }
}

// Publishes `ticks` synthetic sensor ticks (state, right and left plates) of noise seed `seed` on `lcm`, the node
// receiving each.
void feedTicks(LcmEndpoint& lcm, EstimatorNode& node, const Model& model, uint64_t seed, long ticks) {
  testing::SensorTick t = testing::makeSensorTick(model);
  std::mt19937_64 rng(seed);
  exoid_lcm::robot_state_t sm;
  exoid_lcm::force_plate_t pm;
  for (long k = 0; k < ticks; ++k) {
    testing::fillSensorTick(model, k, 0.3, 1.0, rng, t);
    toLcm(t.state, model.joint_names, sm);
    lcm.publish(channels::kState, sm);
    for (int i = 0; i < 2; ++i) {
      toLcm(t.plate[i], pm);
      lcm.publish(i == 0 ? channels::kPlateRight : channels::kPlateLeft, pm);
    }
    drain(node);
  }
}

TEST(ExoEstimatorLcm, PublishesWhatTheEstimatorComputesAndCountsBadMessages) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  LcmEndpoint lcm("memq://");
  OnlineEstimatorOptions opt;
  OnlineEstimator est(model, s.base, model.phi, opt), ref(model, s.base, model.phi, opt);
  ASSERT_TRUE(est.ok()) << est.error();
  NodeOptions nopt;
  nopt.publish_every = 20;
  nopt.reconcile_async = false;  // bit-for-bit against the estimator fed directly
  EstimatorNode node(lcm, model, est, nopt);
  std::vector<EstimatorOutputSample> received;
  long refused = 0;
  const std::vector<std::string> params = model.paramNames(), coords = model.coordinateNames();
  lcm.subscribe<exoid_lcm::estimator_output_t>(channels::kEstimate, [&](const char*, const exoid_lcm::estimator_output_t& m) {
    EstimatorOutputSample o;
    std::string why;
    // base_params: the base parameters, then the sensor columns (one offset and one gain per joint)
    if (fromLcm(m, params, static_cast<size_t>(s.base.rank + est.sensorOffsetColumnCount()), coords, o, &why))
      received.push_back(o);
    else ADD_FAILURE() << why, ++refused;
  });
  EstimatorOutputSample expected;
  ref.sizeOutput(expected);
  std::vector<EstimatorOutputSample> expected_all;
  OnlineEstimator::ReconcileJob jobs[2];
  bool begun[2] = {false, false};
  int due = 0;

  testing::SensorTick t = testing::makeSensorTick(model);
  std::mt19937_64 rng(3);
  exoid_lcm::robot_state_t sm;
  exoid_lcm::force_plate_t pm;
  auto send_state = [&](const RobotStateSample& st) {
    toLcm(st, model.joint_names, sm);
    lcm.publish(channels::kState, sm);
    drain(node);
  };
  auto send_plate = [&](const ForcePlateSample& p) {
    toLcm(p, pm);
    lcm.publish(p.plate == 0 ? channels::kPlateRight : channels::kPlateLeft, pm);
    drain(node);
  };
  const long lag = 2 * opt.derivative_half_window;  // ticks that only fill the state fit's window
  for (long k = 0; k < 400 + lag; ++k) {
    testing::fillSensorTick(model, k, 0.3, 1.0, rng, t);
    if (k == 100) {  // a NaN state and undecodable bytes before the good state of this tick
      RobotStateSample bad = t.state;
      bad.imu_gyro[1] = std::nan("");
      send_state(bad);
      const char junk[5] = {1, 2, 3, 4, 5};
      lcm.publishRaw(channels::kState, junk, sizeof junk);
      drain(node);
    }
    send_state(t.state);
    if (k == 200) send_state(t.state);  // duplicate
    send_plate(t.plate[0]);
    send_plate(t.plate[1]);
    if (k == 300) {  // an old plate: out of order
      testing::SensorTick old = t;
      old.plate[1].tick = k - 10;
      send_plate(old.plate[1]);
    }
    ref.addState(t.state);
    ref.addPlate(t.plate[0]);
    ref.addPlate(t.plate[1]);
    // Published at the rows r with (r + 1) % publish_every == 0; the consistent solve begun at a due publication
    // is adopted at the second due one after (used from the publication after that).
    if (ref.samplesSincePublication() > 0 && (ref.lastRowTick() + 1) % nopt.publish_every == 0) {
      ref.fillOutput(expected);
      if (ref.reconcileDue()) {
        const int j = due++ % 2;
        if (begun[j]) ref.finishReconcile(jobs[j]);
        begun[j] = ref.beginReconcile(jobs[j]);
        if (begun[j]) ref.solveReconcile(jobs[j]);
      }
      expected_all.push_back(expected);
    }
  }
  ASSERT_EQ(received.size(), expected_all.size());
  ASSERT_EQ(received.size(), 20u);  // rows 30..429 folded, published at rows 39, 59, ..., 419
  EXPECT_EQ(refused, 0);
  for (size_t i = 0; i < received.size(); ++i) {
    EXPECT_EQ(received[i].params, expected_all[i].params) << i;
    EXPECT_EQ(received[i].tau_correction, expected_all[i].tau_correction) << i;
    EXPECT_EQ(received[i].tick, expected_all[i].tick);
    EXPECT_EQ(received[i].utime, 1000 * received[i].tick);
  }
  const EstimatorOutputSample& last = received.back();
  EXPECT_EQ(last.rejected_nonfinite, 2);  // the NaN state and the undecodable bytes
  EXPECT_EQ(last.rejected_duplicate, 1);
  EXPECT_EQ(last.rejected_out_of_order, 1);
  EXPECT_EQ(last.samples_rejected, 4);
  EXPECT_EQ(last.tick, 419);
  EXPECT_EQ(last.samples_used, 390);
  EXPECT_EQ(last.samples_missing, 0);
  EXPECT_EQ(node.publications(), 20);
  EXPECT_EQ(node.publishErrors(), 0);
}

// What the node publishes depends on the messages alone: at the tick-aligned rows (after a lost tick, the first
// row past the aligned one it skipped), and the consistent solve on a worker thread gives the same publications
// bit for bit as the solve in the publishing call, whenever the worker finishes.
TEST(ExoEstimatorLcm, PublicationsAreTickAlignedAndIndependentOfTheWorkersTiming) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  OnlineEstimatorOptions opt;
  const long L = opt.derivative_half_window;
  const long lost = 300, ticks = 700;  // every message of tick 300 lost
  std::vector<EstimatorOutputSample> runs[2];
  long waits = 0;
  for (int async = 0; async < 2; ++async) {
    LcmEndpoint lcm("memq://");
    OnlineEstimator est(model, s.base, model.phi, opt);
    NodeOptions nopt;
    nopt.reconcile_async = async == 1;
    EstimatorNode node(lcm, model, est, nopt);
    const std::vector<std::string> params = model.paramNames(), coords = model.coordinateNames();
    lcm.subscribe<exoid_lcm::estimator_output_t>(channels::kEstimate, [&](const char*, const exoid_lcm::estimator_output_t& m) {
      EstimatorOutputSample o;
      std::string why;
      if (fromLcm(m, params, static_cast<size_t>(s.base.rank + est.sensorOffsetColumnCount()), coords, o, &why))
        runs[async].push_back(o);
      else ADD_FAILURE() << why;
    });
    testing::SensorTick t = testing::makeSensorTick(model);
    std::mt19937_64 rng(5);
    exoid_lcm::robot_state_t sm;
    exoid_lcm::force_plate_t pm;
    for (long k = 0; k < ticks; ++k) {
      testing::fillSensorTick(model, k, 0.3, 1.0, rng, t);
      if (k == lost) continue;
      toLcm(t.state, model.joint_names, sm);
      lcm.publish(channels::kState, sm);
      for (int i = 0; i < 2; ++i) {
        toLcm(t.plate[i], pm);
        lcm.publish(i == 0 ? channels::kPlateRight : channels::kPlateLeft, pm);
      }
      drain(node);
    }
    if (async == 1) waits = node.reconcileWaits();
    EXPECT_GE(est.reconciles(), 4);  // solves begun at publications 1, 11, ..., adopted twenty later
  }
  // Rows L .. lost - 1 - L, then, the fit's window refilled after the gap, lost + 1 + L .. ticks - 1 - L.
  std::vector<long> rows;
  for (long r = 39; r <= lost - 1 - L; r += 10) rows.push_back(r);
  rows.push_back(lost + 1 + L);  // 331: the first row past the skipped aligned rows 279 .. 329
  for (long r = 339; r <= ticks - 1 - L; r += 10) rows.push_back(r);
  ASSERT_EQ(runs[0].size(), rows.size());
  ASSERT_EQ(runs[1].size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(runs[0][i].tick, rows[i]) << i;
    EXPECT_EQ(runs[1][i].tick, rows[i]) << i;
    EXPECT_EQ(runs[1][i].params, runs[0][i].params) << "publication " << i;
    EXPECT_EQ(runs[1][i].tau_correction, runs[0][i].tau_correction) << i;
    EXPECT_EQ(runs[1][i].valid, runs[0][i].valid) << i;
    EXPECT_EQ(runs[1][i].consistent, runs[0][i].consistent) << i;
  }
  std::printf("consistent solves the async node waited for: %ld\n", waits);
}

TEST(ExoEstimatorLcm, CheckpointIsWrittenAndResumed) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("exoid_node_ckpt_" + std::to_string(::getpid()) + ".bin")).string();
  std::filesystem::remove(path);
  OnlineEstimatorOptions opt;
  const long L = opt.derivative_half_window;
  NodeOptions nopt;
  nopt.checkpoint = path;
  nopt.checkpoint_every_s = 0.0;  // only on demand
  long accepted = 0;
  {
    LcmEndpoint lcm("memq://");
    OnlineEstimator est(model, s.base, model.phi, opt);
    EstimatorNode node(lcm, model, est, nopt);
    bool resumed = true;
    std::string err;
    ASSERT_TRUE(node.resume(&resumed, &err)) << err;
    EXPECT_FALSE(resumed);  // no file yet: a fresh start
    feedTicks(lcm, node, model, 4, 150);
    ASSERT_TRUE(node.writeCheckpoint(&err)) << err;
    EXPECT_EQ(node.checkpointsWritten(), 1);
    accepted = est.rlsData().accepted;
    EXPECT_EQ(accepted, 150 - 2 * L);  // every tick is the middle of a fit window but the first and last L
  }
  LcmEndpoint lcm("memq://");
  OnlineEstimator est(model, s.base, model.phi, opt);
  EstimatorNode node(lcm, model, est, nopt);
  bool resumed = false;
  std::string err;
  ASSERT_TRUE(node.resume(&resumed, &err)) << err;
  EXPECT_TRUE(resumed);
  EXPECT_EQ(est.rlsData().accepted, accepted);
  EXPECT_EQ(est.rlsData().last_tick, 149 - L);
  // Another estimator's options: refused, the caller decides (exo_estimator exits 2).
  OnlineEstimatorOptions other = opt;
  other.forgetting = Forgetting::Selective;
  OnlineEstimator est2(model, s.base, model.phi, other);
  EstimatorNode node2(lcm, model, est2, nopt);
  EXPECT_FALSE(node2.resume(&resumed, &err));
  EXPECT_NE(err.find("other options"), std::string::npos) << err;
  std::filesystem::remove(path);
}

// exo_estimator --effects: the checkpoint records the sidecar. The same sidecar resumes; another one is refused
// naming the effects (other gain, same columns) or the parameter count (other columns).
TEST(ExoEstimatorLcm, CheckpointRecordsTheSidecarsEffects) {
  const ExoSetup& s = setup();
  const Model& model = s.model;
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("exoid_node_ckpt_fx_" + std::to_string(::getpid()) + ".bin")).string();
  std::filesystem::remove(path);
  const int knee = model.jointIndex("right_knee");
  ASSERT_GE(knee, 0);
  OnlineEstimatorOptions opt;
  opt.effects.effects = {{EffectKind::Coulomb, knee, 3.0}, {EffectKind::GainError, knee, 0.1}};
  NodeOptions nopt;
  nopt.checkpoint = path;
  nopt.checkpoint_every_s = 0.0;
  std::string err;
  Eigen::VectorXd x;
  {
    LcmEndpoint lcm("memq://");
    OnlineEstimator est(model, s.base, model.phi, opt);
    ASSERT_TRUE(est.ok()) << est.error();
    EstimatorNode node(lcm, model, est, nopt);
    feedTicks(lcm, node, model, 5, 150);
    EstimatorOutputSample out;
    est.sizeOutput(out);
    est.fillOutput(out);  // a solve with every sample, then the checkpoint of the same state and weights
    x = out.base_params;
    ASSERT_TRUE(node.writeCheckpoint(&err)) << err;
  }
  ASSERT_EQ(x.size(), s.base.rank + 1 + 2 * model.njoints);  // base, the sidecar's column, the sensor columns
  {  // the same sidecar: resumed (its load solves), the same estimate, effect column included
    OnlineEstimator est(model, s.base, model.phi, opt);
    ASSERT_TRUE(est.loadCheckpoint(path, &err)) << err;
    EXPECT_LT((est.baseEstimate() - x).norm(), 1e-9 * x.norm());
  }
  OnlineEstimatorOptions other_gain = opt, other_columns = opt, none;
  other_gain.effects.effects[1].value = 0.05;
  other_columns.effects.effects.push_back({EffectKind::Viscous, knee, 5.0});
  OnlineEstimator a(model, s.base, model.phi, other_gain), b(model, s.base, model.phi, other_columns),
      c(model, s.base, model.phi, none);
  EXPECT_FALSE(a.loadCheckpoint(path, &err));
  EXPECT_NE(err.find("other effects"), std::string::npos) << err;
  EXPECT_NE(err.find("right_knee gain 0.1"), std::string::npos) << err;
  EXPECT_FALSE(b.loadCheckpoint(path, &err));
  EXPECT_NE(err.find("estimates " + std::to_string(s.base.rank + 1 + 2 * model.njoints) + " parameters"),
            std::string::npos) << err;
  EXPECT_NE(err.find("2 effect column(s)"), std::string::npos) << err;
  EXPECT_FALSE(c.loadCheckpoint(path, &err));  // an estimator without the sidecar
  EXPECT_NE(err.find("different estimator"), std::string::npos) << err;
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace exoid::estimator
