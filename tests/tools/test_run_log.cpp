// The run-log reader and the export table on a synthetic log written with LCM's own event-log writer:
// every event is accounted for (decoded, rejected with a reason, or on an unknown channel); the table
// aligns channels by tick, skips ticks with a missing message, and converts plate readings to wrenches on
// the feet about the world origin.
#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/controller/base_state_observer.hpp"
#include "exoid/tools/experiment_run.hpp"
#include "exoid/tools/experiment_summary.hpp"
#include "exoid/intake/run_log.hpp"
#include "exoid/tools/run_table.hpp"
#include "support/paths.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

class RunLogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(test::configPath("exo.urdf"), true, model_, &err)) << err;
  }
  /// A sole's origin (0: right_sole, 1: left_sole) in the base frame, the zero pose: the model's kinematics.
  Eigen::Vector3d zeroPoseSole(int side) const {
    Data kin(model_);
    forwardKinematics(model_, kin, State::zero(model_));
    const Model::Frame& fr = model_.frames[model_.frameIndex(side == 0 ? "right_sole" : "left_sole")];
    return kin.p[fr.body] + kin.R[fr.body] * fr.position;
  }
  /// A truth sample of the robot standing still in the zero pose at `base`, no contact forces.
  GroundTruthSample standingTruth(int64_t tick, const Eigen::Vector3d& base) const {
    GroundTruthSample t;
    t.tick = tick;
    t.base_position = base;
    t.q = t.v = t.a = t.tau_applied = Eigen::VectorXd::Zero(model_.njoints);
    t.foot_force = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    t.foot_moment = t.foot_force;
    return t;
  }
  template <class Msg>
  void write(lcm_eventlog_t* log, const char* channel, const Msg& msg, int64_t utime) {
    std::vector<uint8_t> buf(msg.getEncodedSize());
    msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    writeRaw(log, channel, buf, utime);
  }
  void writeRaw(lcm_eventlog_t* log, const char* channel, const std::vector<uint8_t>& buf, int64_t utime) {
    lcm_eventlog_event_t e{};
    e.timestamp = utime;
    e.channellen = static_cast<int32_t>(std::strlen(channel));
    e.channel = const_cast<char*>(channel);
    e.datalen = static_cast<int32_t>(buf.size());
    e.data = const_cast<uint8_t*>(buf.data());
    ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
  }
  RobotStateSample state(int64_t tick) {
    RobotStateSample s;
    s.tick = tick;
    s.utime = tick * 1000;
    s.q = Eigen::VectorXd::Constant(model_.njoints, 0.01 * tick);
    s.tau = Eigen::VectorXd::Zero(model_.njoints);
    s.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model_.njoints, false);
    s.imu_accel = Eigen::Vector3d(0, 0, 9.81);
    return s;
  }
  ForcePlateSample plate(int p, int64_t tick) {
    ForcePlateSample s;
    s.plate = p;
    s.tick = tick;
    s.utime = tick * 1000;
    s.force = Eigen::Vector3d(1.0, 2.0, -200.0);  // pushed down by the foot
    s.moment = Eigen::Vector3d(0.5, -0.25, 0.1);
    s.plate_position = Eigen::Vector3d(0.03, p == 0 ? -0.11 : 0.11, 0.0);
    s.plate_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
    return s;
  }
  Model model_;
  test::TempDir dir_{"run_log"};
};

// A state message repeated for the same tick (the publisher sent it twice) is one tick: the tick assembly keeps
// the first and counts the repeat; export writes one row per tick and says so (before: one row per state).
TEST_F(RunLogTest, ARepeatedStateTickExportsOneRowAndIsReported) {
  const std::string path = dir_.file("repeat.lcmlog");
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  exoid_lcm::robot_state_t sm;
  exoid_lcm::force_plate_t pm;
  for (int64_t k = 0; k < 6; ++k) {
    toLcm(state(k), model_.joint_names, sm);
    write(log, channels::kState, sm, k);
    if (k == 2) {  // tick 2's state again, with other joint values: the first must be kept
      RobotStateSample again = state(2);
      again.q.setConstant(0.7);
      toLcm(again, model_.joint_names, sm);
      write(log, channels::kState, sm, k);
    }
    for (int p = 0; p < 2; ++p) {
      toLcm(plate(p, k), pm);
      write(log, p == 0 ? channels::kPlateRight : channels::kPlateLeft, pm, k);
    }
  }
  lcm_eventlog_destroy(log);
  intake::RunLog run;
  std::string err;
  ASSERT_TRUE(intake::readRunLog(path, model_.joint_names, run, &err)) << err;
  ASSERT_EQ(run.states.size(), 7u);
  tools::RunTable table;
  ASSERT_TRUE(tools::buildRunTable(model_, run, tools::ExportOptions{}, table, &err)) << err;
  ASSERT_EQ(table.rows.size(), 6u);
  EXPECT_EQ(table.repeated_messages, 1);
  EXPECT_EQ(table.out_of_order_messages, 0);
  EXPECT_EQ(table.skipped_ticks, 0);
  const int qcol = static_cast<int>(std::find(table.header.begin(), table.header.end(), "q_right_knee") - table.header.begin());
  for (int k = 0; k < 6; ++k) {
    EXPECT_DOUBLE_EQ(table.rows[k][0], 0.001 * k) << k;
    EXPECT_DOUBLE_EQ(table.rows[k][qcol], 0.01 * k) << k;
  }
  const auto r = test::runCommand(test::exoidBinary() + " export --log " + path + " --out " + dir_.file("r.csv"), dir_.path);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("6 ticks -> "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1 repeated and 0 out-of-order messages dropped"), std::string::npos) << r.err;
}

TEST_F(RunLogTest, EveryEventIsAccountedForAndTicksAreAligned) {
  const std::string path = dir_.file("run.lcmlog");
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  exoid_lcm::robot_state_t sm;
  exoid_lcm::force_plate_t pm;
  for (int64_t k = 0; k < 10; ++k) {
    toLcm(state(k), model_.joint_names, sm);
    write(log, channels::kState, sm, k);
    for (int p = 0; p < 2; ++p) {
      if (p == 1 && k == 4) continue;  // a lost left-plate message at tick 4
      toLcm(plate(p, k), pm);
      write(log, p == 0 ? channels::kPlateRight : channels::kPlateLeft, pm, k);
    }
  }
  writeRaw(log, channels::kState, {1, 2, 3}, 11);         // garbage on a known channel
  writeRaw(log, "SOMEONE_ELSE", {1, 2, 3}, 12);           // a channel exoid does not know
  lcm_eventlog_destroy(log);

  intake::RunLog run;
  std::string err;
  ASSERT_TRUE(intake::readRunLog(path, model_.joint_names, run, &err)) << err;
  EXPECT_EQ(run.states.size(), 10u);
  EXPECT_EQ(run.plates[0].size(), 10u);
  EXPECT_EQ(run.plates[1].size(), 9u);
  EXPECT_EQ(run.rejected, 1);
  EXPECT_EQ(run.unknown_channel, 1);
  EXPECT_EQ(run.events.at(channels::kState), 11);
  EXPECT_NE(run.first_rejection.find("EXO_STATE"), std::string::npos);

  tools::RunTable table;
  ASSERT_TRUE(tools::buildRunTable(model_, run, tools::ExportOptions{}, table, &err)) << err;
  EXPECT_EQ(table.rows.size(), 9u);
  EXPECT_EQ(table.skipped_ticks, 1);
  // Tick 5 is the fifth row (tick 4 skipped); q follows its tick.
  const int qcol = static_cast<int>(std::find(table.header.begin(), table.header.end(), "q_right_knee") - table.header.begin());
  EXPECT_DOUBLE_EQ(table.rows[4][qcol], 0.05);
  EXPECT_DOUBLE_EQ(table.rows[4][0], 0.005);
  // Accelerometer reads +g at rest: the classical acceleration is zero.
  const int az = static_cast<int>(std::find(table.header.begin(), table.header.end(), "base_az") - table.header.begin());
  EXPECT_NEAR(table.rows[0][az], 0.0, 1e-12);
  // Plate -> foot wrench: force on the foot = -R F, moment about the world origin = -R M + p x f.
  const ForcePlateSample p = plate(0, 0);
  const Eigen::Matrix3d R = p.plate_orientation.toRotationMatrix();
  const Eigen::Vector3d f = -(R * p.force), n = -(R * p.moment) + p.plate_position.cross(f);
  const int fx = static_cast<int>(std::find(table.header.begin(), table.header.end(), "fp_right_fx") - table.header.begin());
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(table.rows[0][fx + i], f[i], 1e-12);
    EXPECT_NEAR(table.rows[0][fx + 3 + i], n[i], 1e-12);
  }
  // No derivative columns without a filter; they appear with one.
  EXPECT_EQ(std::count(table.header.begin(), table.header.end(), "a_right_knee"), 0);
  tools::ExportOptions filtered;
  filtered.filter_hz = 50.0;
  ASSERT_TRUE(tools::buildRunTable(model_, run, filtered, table, &err)) << err;
  EXPECT_EQ(std::count(table.header.begin(), table.header.end(), "a_right_knee"), 1);
  // --truth on a log without truth fails with a clear message.
  tools::ExportOptions truth;
  truth.truth = true;
  EXPECT_FALSE(tools::buildRunTable(model_, run, truth, table, &err));
  EXPECT_NE(err.find("EXO_TRUTH"), std::string::npos);
}

// A log written tick by tick (state + both plates per tick), with the byte offset of every event.
struct WrittenLog {
  std::string path;
  std::vector<long> offsets;  ///< start of each event
  long size = 0;
  int ticks = 0;
};

class DamagedLogTest : public RunLogTest {
 protected:
  WrittenLog writeLog(const std::string& name, int ticks) {
    WrittenLog w;
    w.path = dir_.file(name);
    w.ticks = ticks;
    lcm_eventlog_t* log = lcm_eventlog_create(w.path.c_str(), "w");
    EXPECT_NE(log, nullptr);
    exoid_lcm::robot_state_t sm;
    exoid_lcm::force_plate_t pm;
    for (int64_t k = 0; k < ticks; ++k) {
      toLcm(state(k), model_.joint_names, sm);
      std::fflush(log->f);
      w.offsets.push_back(std::ftell(log->f));
      write(log, channels::kState, sm, k);
      for (int p = 0; p < 2; ++p) {
        toLcm(plate(p, k), pm);
        std::fflush(log->f);
        w.offsets.push_back(std::ftell(log->f));
        write(log, p == 0 ? channels::kPlateRight : channels::kPlateLeft, pm, k);
      }
    }
    lcm_eventlog_destroy(log);
    w.size = static_cast<long>(std::filesystem::file_size(w.path));
    return w;
  }
  static void flip(const std::string& path, long offset, uint8_t mask) {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(offset);
    char c = 0;
    f.read(&c, 1);
    c = static_cast<char>(c ^ mask);
    f.seekp(offset);
    f.write(&c, 1);
  }
  /// Events LCM's own reader returns (it stops at the first damaged one).
  static long lcmReaderEvents(const std::string& path) {
    lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
    long n = 0;
    while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) ++n, lcm_eventlog_free_event(e);
    lcm_eventlog_destroy(log);
    return n;
  }
};

// Observed: `exoid export` on a log with flipped bits exited 0 having dropped everything after the first
// damaged event (1134 of 5200 ticks). Now the reader resumes at the next valid event and counts the damage.
TEST_F(DamagedLogTest, FlippedBitsInEventHeadersLoseOnlyThoseEvents) {
  WrittenLog w = writeLog("flipped.lcmlog", 100);
  const int total = 3 * w.ticks;
  const size_t state_40 = 3 * 40, plate_70 = 3 * 70 + 1;
  flip(w.path, w.offsets[state_40] + 1, 0x10);        // sync word of the state of tick 40
  flip(w.path, w.offsets[plate_70] + 20, 0x40);       // channel length of the right plate of tick 70 (huge)
  const long lcm_events = lcmReaderEvents(w.path);
  EXPECT_LT(lcm_events, static_cast<long>(state_40) + 1);  // the old reader stopped here
  intake::RunLog run;
  std::string err;
  ASSERT_TRUE(intake::readRunLog(w.path, model_.joint_names, run, &err)) << err;
  EXPECT_EQ(run.states.size(), static_cast<size_t>(w.ticks - 1));
  EXPECT_EQ(run.plates[0].size(), static_cast<size_t>(w.ticks - 1));
  EXPECT_EQ(run.plates[1].size(), static_cast<size_t>(w.ticks));
  EXPECT_EQ(run.damage.corrupt_events, 2);
  // Exactly the two damaged events' bytes were skipped.
  EXPECT_EQ(run.damage.corrupt_bytes, (w.offsets[state_40 + 1] - w.offsets[state_40]) + (w.offsets[plate_70 + 1] - w.offsets[plate_70]));
  EXPECT_EQ(run.damage.first_corrupt_offset, w.offsets[state_40]);
  EXPECT_FALSE(run.damage.truncated);
  EXPECT_EQ(run.damage.readable_end, w.size);
  EXPECT_EQ(run.last_tick, w.ticks - 1);
  EXPECT_FALSE(run.intact());
  const std::string report = run.damageReport();
  EXPECT_NE(report.find("2 damaged stretches skipped"), std::string::npos) << report;
  EXPECT_NE(report.find("first at byte " + std::to_string(w.offsets[state_40])), std::string::npos) << report;
  long events = 0;
  for (const auto& [ch, n] : run.events) events += n;
  EXPECT_EQ(events, total - 2);
  std::printf("events read of %d with two damaged headers: LCM's reader %ld, readRunLog %ld\n", total, lcm_events, events);
}

TEST_F(DamagedLogTest, ACutOffTailIsReportedWithWhereTheReadablePartEnds) {
  WrittenLog w = writeLog("cut.lcmlog", 50);
  const long last = w.offsets.back();  // left plate of tick 49
  std::filesystem::resize_file(w.path, static_cast<uintmax_t>(last + 30));  // header complete, body cut
  intake::RunLog run;
  std::string err;
  ASSERT_TRUE(intake::readRunLog(w.path, model_.joint_names, run, &err)) << err;
  EXPECT_TRUE(run.damage.truncated);
  EXPECT_EQ(run.damage.corrupt_events, 0);
  EXPECT_EQ(run.damage.readable_end, last);
  EXPECT_EQ(run.damage.file_bytes, last + 30);
  EXPECT_EQ(run.states.size(), 50u);
  EXPECT_EQ(run.plates[1].size(), 49u);
  EXPECT_EQ(run.last_tick, 49);
  EXPECT_NE(run.damageReport().find("cut off"), std::string::npos);
  EXPECT_NE(run.damageReport().find("readable part ends at byte " + std::to_string(last) + " of " +
                                    std::to_string(last + 30) + ", tick 49"),
            std::string::npos)
      << run.damageReport();
  // Cut inside the sync word of the last event: still a cut-off tail, not damage.
  std::filesystem::resize_file(w.path, static_cast<uintmax_t>(last + 2));
  ASSERT_TRUE(intake::readRunLog(w.path, model_.joint_names, run, &err)) << err;
  EXPECT_TRUE(run.damage.truncated);
  EXPECT_EQ(run.damage.corrupt_events, 0);
  EXPECT_EQ(run.damage.readable_end, last);
  // An intact log is intact.
  WrittenLog ok = writeLog("ok.lcmlog", 5);
  ASSERT_TRUE(intake::readRunLog(ok.path, model_.joint_names, run, &err)) << err;
  EXPECT_TRUE(run.intact());
  EXPECT_EQ(run.damageReport(), "");
  EXPECT_EQ(run.damage.readable_end, ok.size);
}

TEST_F(DamagedLogTest, ExportRefusesADamagedLogUnlessAllowPartial) {
  WrittenLog w = writeLog("damaged.lcmlog", 30);
  flip(w.path, w.offsets[3 * 10] + 2, 0x01);
  std::filesystem::resize_file(w.path, static_cast<uintmax_t>(w.offsets.back() + 5));
  const std::string cmd = test::exoidBinary() + " export --log " + w.path + " --out " + dir_.file("d.csv");
  auto r = test::runCommand(cmd, dir_.path);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("exoid export: error: " + w.path + ": 1 damaged stretch skipped"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("cut off"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("readable part ends at byte " + std::to_string(w.offsets.back())), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.file("d.csv")));
  r = test::runCommand(cmd + " --allow-partial", dir_.path);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("exoid export: warning: " + w.path + ": 1 damaged stretch skipped"), std::string::npos) << r.err;
  tools::CsvTable csv;
  std::string err;
  ASSERT_TRUE(tools::readCsv(dir_.file("d.csv"), csv, &err)) << err;
  EXPECT_EQ(csv.rows.size(), 28u);  // tick 10 lost its state, tick 29 its left plate
}

// The true-CoM figures against a direct computation: the true CoM off the reference by a horizontal wiggle
// and a vertical offset of 20 mm plus a small drift; the relative figure leaves out the offset at the first tick.
// --truth ends with the system's CoM and, for a wearer run, the trunk's state (schema.h `trunk_*`), each column the
// message's field; the empty exoskeleton's export has no trunk columns; a log mixing both is refused with the tick.
TEST_F(RunLogTest, TruthExportEndsWithTheCoMAndAWearersTrunk) {
  intake::RunLog log;
  for (int64_t k = 0; k < 3; ++k) {
    GroundTruthSample t = standingTruth(k, Eigen::Vector3d(0, 0, 1.0));
    t.utime = 1000 * k;
    const double x = static_cast<double>(k);
    t.com = Eigen::Vector3d(0.01 * x, -0.02, 0.9);
    t.has_trunk = true;
    t.trunk_angle = Eigen::Vector3d(0.1 * x, -0.2, 0.3);
    t.trunk_rate = Eigen::Vector3d(-0.4, 0.5 * x, 0.6);
    t.trunk_com = Eigen::Vector3d(0.03, 0.04, 1.2 + 0.001 * x);
    log.truth.push_back(t);
  }
  tools::ExportOptions truth;
  truth.truth = true;
  tools::RunTable table;
  std::string err;
  ASSERT_TRUE(tools::buildRunTable(model_, log, truth, table, &err)) << err;
  auto column = [&](const std::string& name) {
    const auto it = std::find(table.header.begin(), table.header.end(), name);
    EXPECT_NE(it, table.header.end()) << name;
    return static_cast<size_t>(it - table.header.begin());
  };
  ASSERT_EQ(table.rows.size(), 3u);
  EXPECT_EQ(table.header.back(), "trunk_com_z");
  for (size_t k = 0; k < 3; ++k) {
    const GroundTruthSample& t = log.truth[k];
    for (int i = 0; i < 3; ++i) {
      const std::string c(1, "xyz"[i]);
      EXPECT_EQ(table.rows[k][column("com_" + c)], t.com[i]);
      EXPECT_EQ(table.rows[k][column("trunk_angle_" + c)], t.trunk_angle[i]);
      EXPECT_EQ(table.rows[k][column("trunk_rate_" + c)], t.trunk_rate[i]);
      EXPECT_EQ(table.rows[k][column("trunk_com_" + c)], t.trunk_com[i]);
    }
  }
  log.truth[1].has_trunk = false;
  EXPECT_FALSE(tools::buildRunTable(model_, log, truth, table, &err));
  EXPECT_NE(err.find("tick 1: has_trunk false"), std::string::npos) << err;
  for (GroundTruthSample& t : log.truth) t.has_trunk = false;
  ASSERT_TRUE(tools::buildRunTable(model_, log, truth, table, &err)) << err;
  EXPECT_EQ(table.header.back(), "com_z");
  EXPECT_EQ(std::count_if(table.header.begin(), table.header.end(),
                          [](const std::string& h) { return h.rfind("trunk_", 0) == 0; }),
            0);
}

TEST_F(RunLogTest, TrueComFiguresAgainstADirectComputation) {
  intake::RunLog log;
  double sq = 0.0, sq_xy = 0.0, sq_rel = 0.0;
  const int n = 200;
  // The trunk: angles and the upper body's CoM in a yawed pelvis's frame, their spreads computed here two-pass.
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  std::vector<Eigen::Vector3d> angles, local;
  for (int64_t k = 0; k < n; ++k) {
    const double x = static_cast<double>(k);
    angles.emplace_back(0.01 * std::sin(0.2 * x), 0.1 + 0.02 * std::cos(0.13 * x), -0.003);
    local.emplace_back(0.02 + 0.004 * std::sin(0.2 * x), -0.001 * std::cos(0.3 * x), 0.3);
  }
  for (int64_t k = 0; k < n; ++k) {
    GroundTruthSample t = standingTruth(k, Eigen::Vector3d(0, 0, 1.0));
    t.base_orientation = yaw;
    t.has_trunk = true;
    t.trunk_angle = angles[static_cast<size_t>(k)];
    t.trunk_com = t.base_position + yaw * local[static_cast<size_t>(k)];
    ControllerStatusSample st;
    st.tick = k;
    st.move_index = 0;
    st.com_ref = Eigen::Vector3d(0.001 * static_cast<double>(k), -0.02, 0.9);
    const double ex = 0.003 * std::sin(0.1 * static_cast<double>(k)), ez = 0.020 + 1e-5 * static_cast<double>(k);
    t.com = st.com_ref + Eigen::Vector3d(ex, 0.0, ez);
    sq += ex * ex + ez * ez;
    sq_xy += ex * ex;
    sq_rel += ex * ex + (ez - 0.020) * (ez - 0.020);
    log.truth.push_back(t);
    log.status.push_back(st);
  }
  tools::RunFacts facts;
  const tools::ExperimentSummary s = tools::summarizeExperiment(model_, log, facts);
  EXPECT_NEAR(s.true_com_rmse_m, std::sqrt(sq / n), 1e-15);
  EXPECT_NEAR(s.true_com_rmse_xy_m, std::sqrt(sq_xy / n), 1e-15);
  EXPECT_NEAR(s.true_com_rmse_rel_m, std::sqrt(sq_rel / n), 1e-15);
  EXPECT_GT(s.true_com_rmse_m, 5.0 * s.true_com_rmse_rel_m);  // the offset dominates the absolute figure
  EXPECT_NE(tools::summaryJson(s).find("\"true_com_rmse_rel_m\""), std::string::npos);
  auto spread = [](const std::vector<Eigen::Vector3d>& v, Eigen::Vector3d& mean) {
    mean.setZero();
    for (const Eigen::Vector3d& x : v) mean += x / static_cast<double>(v.size());
    Eigen::Vector3d ss = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& x : v) ss += (x - mean).cwiseAbs2() / static_cast<double>(v.size());
    return Eigen::Vector3d(ss.cwiseSqrt());
  };
  Eigen::Vector3d angle_mean, local_mean;
  const Eigen::Vector3d angle_rms = spread(angles, angle_mean), local_rms = spread(local, local_mean);
  ASSERT_TRUE(s.has_trunk);
  EXPECT_LT((s.trunk_angle_mean_rad - angle_mean).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((s.trunk_angle_rms_rad - angle_rms).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((s.trunk_com_rms_m - local_rms).cwiseAbs().maxCoeff(), 1e-9);  // in the pelvis frame, not the world's
  EXPECT_GT(local_rms.x(), 1e-3);
  EXPECT_NE(tools::summaryJson(s).find("\"trunk_com_rms_m\""), std::string::npos);
  EXPECT_NE(tools::summaryTable(s).find("wearer's trunk on the pelvis"), std::string::npos);
}

// The controller's world is fixed at its start-up latch (tools::ControllerFrame): a robot that settled by delta before
// it is offset by delta between the simulator's world and the controller's. A true CoM that sits exactly on the
// reference in the controller's world is then 0 off, and |delta| off when the frame is unknown (the simulator's
// world taken as the controller's, as before). The offset is read at the latch tick, not before or after.
TEST_F(RunLogTest, TheTrueComIsComparedInTheControllersWorld) {
  const Eigen::Vector3d settle(-0.005, 0.0003, 0.0);  // where the base is at the latch (tick 9)
  intake::RunLog log;
  for (int64_t k = 0; k < 40; ++k) {
    const double f = std::min(1.0, static_cast<double>(k) / 9.0);  // settles over the window, then stays
    GroundTruthSample t = standingTruth(k, Eigen::Vector3d(0, 0, 1.0) + f * settle);
    ControllerStatusSample st;
    st.tick = k;
    st.move_index = k >= 20 ? 0 : -1;
    st.com_ref = Eigen::Vector3d(0.01 + 0.0001 * static_cast<double>(k), -0.02, 0.9);
    t.com = st.com_ref + settle;  // on the reference in the controller's world
    log.truth.push_back(t);
    log.status.push_back(st);
  }
  tools::RunFacts facts;
  const tools::ExperimentSummary unknown = tools::summarizeExperiment(model_, log, facts);
  EXPECT_NEAR(unknown.true_com_rmse_xy_m, settle.head<2>().norm(), 1e-15);
  EXPECT_EQ(unknown.frame_offset_m, Eigen::Vector3d::Zero());
  facts.controller_frame.latch_tick = 9;
  facts.controller_frame.ground_height = 0.0;
  const tools::ExperimentSummary s = tools::summarizeExperiment(model_, log, facts);
  EXPECT_NEAR((s.frame_offset_m.head<2>() - settle.head<2>()).norm(), 0.0, 1e-15);
  EXPECT_LT(s.true_com_rmse_xy_m, 1e-15);
  // The vertical: the soles' mean height at the latch, which the controller calls ground_height. Here the standing
  // robot's soles, from the sole frames' fixed offsets in the zero pose (the legs hang straight below the base).
  double sole_z = 0.0;
  for (int side = 0; side < 2; ++side) sole_z += 0.5 * (1.0 + zeroPoseSole(side).z());
  EXPECT_NEAR(s.frame_offset_m.z(), sole_z, 1e-12);
  EXPECT_LT(sole_z, 0.05);  // the soles stand near the floor: a frame offset of millimetres, not the base's metre
  EXPECT_NE(tools::summaryJson(s).find("\"frame_offset_m\""), std::string::npos);
}

// With the controller's latched soles known (ControllerFrame::has_soles) the worlds are aligned by the soles, not
// by the base: the controller's orientation at its latch carries the window's IMU noise, and its world's soles sit
// that error times the legs' length from where the base alignment puts them (docs/wearer.md). Here the controller
// latched its soles 0.6 mm fore and 0.4 mm right of where the base alignment would have them: a true CoM on the
// reference in the soles' world is 0 off, and the offset is the soles' (true soles from the model's kinematics).
TEST_F(RunLogTest, WithTheControllersLatchedSolesTheWorldsAreAlignedByTheSoles) {
  const Eigen::Vector3d base(0.004, -0.002, 1.0);  // the true base, still
  const Eigen::Vector2d shift(0.0006, -0.0004);    // the controller's soles minus the base alignment's
  tools::RunFacts facts;
  facts.controller_frame.latch_tick = 9;
  facts.controller_frame.base_xy = Eigen::Vector2d::Zero();
  facts.controller_frame.has_soles = true;
  for (int side = 0; side < 2; ++side) facts.controller_frame.sole_xy[side] = zeroPoseSole(side).head<2>() + shift;
  const Eigen::Vector2d offset = base.head<2>() - shift;  // true soles minus the controller's
  intake::RunLog log;
  for (int64_t k = 0; k < 30; ++k) {
    GroundTruthSample t = standingTruth(k, base);
    ControllerStatusSample st;
    st.tick = k;
    st.move_index = k >= 15 ? 0 : -1;
    st.com_ref = Eigen::Vector3d(0.02, 0.001 * static_cast<double>(k), 0.9);
    t.com = st.com_ref;
    t.com.head<2>() += offset;  // on the reference in the soles' world
    log.truth.push_back(t);
    log.status.push_back(st);
  }
  const tools::ExperimentSummary s = tools::summarizeExperiment(model_, log, facts);
  EXPECT_LT((s.frame_offset_m.head<2>() - offset).norm(), 1e-15);
  EXPECT_LT(s.true_com_rmse_xy_m, 1e-15);
  facts.controller_frame.has_soles = false;  // the base alignment: off by the shift
  EXPECT_NEAR(tools::summarizeExperiment(model_, log, facts).true_com_rmse_xy_m, shift.norm(), 1e-15);
}

// tools::controllerFrame replays the controller's base state observer over logged states: with the IMU reading a
// constant tilt and the legs in the zero pose, the observer's world puts the base at initial_base_xy and the soles at
// R p_sole (R the tilt, p_sole the sole in the base frame from the model's kinematics), x-y; before latch_ticks
// states nothing is latched; the latch tick, base and ground height are the configuration's.
TEST_F(RunLogTest, TheControllersLatchedSolesComeFromReplayingItsObserver) {
  controller::ControllerConfig cc;
  std::string err;
  ASSERT_TRUE(controller::loadControllerConfig(test::configPath("controller.yaml"), cc, &err)) << err;
  cc.observer.initial_base_xy = Eigen::Vector2d(0.01, -0.02);
  ASSERT_GE(model_.frameIndex("imu"), 0);
  controller::SoleFrame imu;
  ASSERT_TRUE(controller::resolveSoleFrame(model_, "imu", imu, &err)) << err;
  ASSERT_EQ(imu.body, 0);  // on the base: the observer reads world <- base as imu_orientation (base <- imu)^T
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.6, 0.8, 0.0)));
  std::vector<RobotStateSample> states;
  for (int64_t k = 0; k < cc.observer.latch_ticks + 5; ++k) {
    RobotStateSample st;
    st.tick = k;
    st.q = st.tau = Eigen::VectorXd::Zero(model_.njoints);
    st.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model_.njoints, false);
    st.imu_orientation = tilt * Eigen::Quaterniond(imu.rotation);
    st.imu_gyro = Eigen::Vector3d::Zero();
    st.imu_accel = Eigen::Vector3d(0, 0, 9.81);
    states.push_back(st);
  }
  const std::vector<RobotStateSample> short_log(states.begin(), states.begin() + cc.observer.latch_ticks - 1);
  EXPECT_FALSE(tools::controllerFrame(model_, cc, short_log).has_soles);
  std::reverse(states.begin(), states.end());  // log order is not tick order: replayed by tick
  const tools::ControllerFrame frame = tools::controllerFrame(model_, cc, states);
  ASSERT_TRUE(frame.has_soles);
  EXPECT_EQ(frame.latch_tick, cc.observer.latch_ticks - 1);
  EXPECT_EQ(frame.base_xy, cc.observer.initial_base_xy);
  EXPECT_EQ(frame.ground_height, cc.observer.ground_height);
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3d p = tilt * zeroPoseSole(side);
    EXPECT_LT((frame.sole_xy[side] - cc.observer.initial_base_xy - p.head<2>()).norm(), 1e-12) << side;
  }
}

// Issue 21 part 2 judges the true CoM "within 10 s of the start of standing": the settled figure is the horizontal
// RMSE over the move ticks from tick 10000 on only (a converging estimate's first seconds left out), against the
// same sums computed here; the whole-run figure keeps every move tick.
TEST_F(RunLogTest, TheSettledTrueComErrorStartsTenSecondsIn) {
  intake::RunLog log;
  double sq_all = 0.0, sq_late = 0.0;
  long n_all = 0, n_late = 0;
  for (int64_t k = 0; k < 12500; k += 5) {
    GroundTruthSample t = standingTruth(k, Eigen::Vector3d(0, 0, 1.0));
    ControllerStatusSample st;
    st.tick = k;
    st.move_index = k >= 2000 ? 0 : -1;
    st.com_ref = Eigen::Vector3d(0.01, -0.02, 0.9);
    const double ex = k < 10000 ? 0.004 : 0.001 * std::cos(0.01 * static_cast<double>(k)), ey = 0.0005;
    t.com = st.com_ref + Eigen::Vector3d(ex, ey, 0.0);
    if (st.move_index >= 0) {
      sq_all += ex * ex + ey * ey, ++n_all;
      if (k >= 10000) sq_late += ex * ex + ey * ey, ++n_late;
    }
    log.truth.push_back(t);
    log.status.push_back(st);
  }
  const tools::ExperimentSummary s = tools::summarizeExperiment(model_, log, tools::RunFacts{});
  EXPECT_EQ(s.settled_ticks, n_late);
  EXPECT_NEAR(s.true_com_rmse_xy_settled_m, std::sqrt(sq_late / n_late), 1e-15);
  EXPECT_NEAR(s.true_com_rmse_xy_m, std::sqrt(sq_all / n_all), 1e-15);
  EXPECT_GT(s.true_com_rmse_xy_m, 2.0 * s.true_com_rmse_xy_settled_m);
  EXPECT_NE(tools::summaryJson(s).find("\"true_com_rmse_xy_settled_m\""), std::string::npos);
  EXPECT_NE(tools::summaryTable(s).find("from 10 s on"), std::string::npos);
}

// The summary's figures against an independent count on a synthetic run: 150 ticks simulated, the log holds
// ticks 0..99 (the logger died), the robot "fell" at tick 80 during the third move.
TEST_F(RunLogTest, SummaryFiguresAreMeasuredAgainstTheSimulatedRunNotTheLog) {
  intake::RunLog log;
  for (int64_t k = 0; k < 100; ++k) {
    GroundTruthSample t = standingTruth(k, Eigen::Vector3d(0, 0, k < 80 ? 1.0 : 0.5));
    log.truth.push_back(t);
    if (k != 50) log.states.push_back(state(k));  // one lost state
    log.plates[0].push_back(plate(0, k));
    log.plates[1].push_back(plate(1, k));
    ControllerStatusSample st;
    st.tick = k;
    st.moves_done = static_cast<int>(k / 30);  // moves end at ticks 30, 60, 90
    st.move_index = st.moves_done;
    st.fallbacks = k >= 95 ? 7 : 0;
    log.status.push_back(st);
  }
  tools::RunFacts facts;
  facts.moves_planned = 4;
  facts.ticks_planned = 200;
  facts.sim_reported = true;
  facts.sim_ticks = 150;
  facts.sim_fall_tick = 80;
  facts.sim_held_ticks = 3;
  facts.sim_zero_ticks = 2;
  facts.sim_timeouts = 4;
  facts.sim_realtime_factor = 6.5;
  facts.failures = {"exoid_logger was killed by signal 9 (SIGKILL) at 1.0 s: the log ends there"};
  tools::ExperimentSummary s = tools::summarizeExperiment(model_, log, facts);
  EXPECT_EQ(s.outcome, "failed");
  // 50 unlogged ticks on each of 4 channels, plus the lost state: the old count (against the log's own
  // tick range) said 1, or -2 when the truth channel ran longer than another.
  EXPECT_EQ(s.missing_ticks, 4 * 50 + 1);
  EXPECT_EQ(s.ticks_simulated, 150);
  EXPECT_EQ(s.ticks_logged, 100);
  EXPECT_FALSE(s.log_complete);
  ASSERT_EQ(s.failures.size(), 2u);
  EXPECT_NE(s.failures[1].find("log incomplete: 201 of 600 sim-channel ticks missing"), std::string::npos) << s.failures[1];
  EXPECT_TRUE(s.fell);
  EXPECT_EQ(s.fall_tick, 80);
  EXPECT_EQ(s.moves_done, 2);        // at tick 80, not the 3 the log's last status says
  EXPECT_EQ(s.fall_during_move, 2);  // 0-based: the third move
  EXPECT_EQ(s.controller_fallbacks, 7);
  EXPECT_EQ(s.sim_held_ticks, 3);
  EXPECT_EQ(s.sim_zero_ticks, 2);
  EXPECT_EQ(s.sim_timeouts, 4);
  EXPECT_DOUBLE_EQ(s.realtime_factor, 6.5);  // the sim's own, not log span / supervisor wall time
  std::string table = tools::summaryTable(s);
  EXPECT_NE(table.find("during move 3 (after 2 completed)"), std::string::npos) << table;
  EXPECT_NE(table.find("| fallback ticks (sim) | 3 held, 2 zero (4 timeouts) |"), std::string::npos) << table;
  EXPECT_NE(table.find(">= 5x (lockstep)"), std::string::npos) << table;
  EXPECT_NE(table.find("FAILED: exoid_logger was killed"), std::string::npos) << table;
  // Realtime mode: no 5x target. No sim report: figures against the planned length, sim figures unknown.
  facts.lockstep = false;
  facts.sim_reported = false;
  facts.failures.clear();
  s = tools::summarizeExperiment(model_, log, facts);
  table = tools::summaryTable(s);
  EXPECT_EQ(table.find(">= 5x"), std::string::npos) << table;
  EXPECT_EQ(s.missing_ticks, 4 * 100 + 1);
  EXPECT_EQ(s.sim_held_ticks, -1);
  EXPECT_NE(table.find("| ticks simulated / planned | unknown (no sim report) / 200 |"), std::string::npos) << table;
  EXPECT_EQ(s.fall_tick, 80);  // from the log's truth channel this time
  const auto j = nlohmann::json::parse(tools::summaryJson(s));
  EXPECT_EQ(j["missing_ticks"], 401);
  EXPECT_EQ(j["mode"], "realtime");
  EXPECT_EQ(j["outcome"], "failed");  // the incomplete log is a failure on its own
  EXPECT_EQ(j["fall_tick"], 80);
  EXPECT_TRUE(j["loop_timing"].is_null());  // the sim's timing is unknown without its report
  EXPECT_NE(table.find("| loop timing | unknown (no sim report) | |"), std::string::npos) << table;
}

// The sim's loop timing (docs/sim.md, "Loop timing") reaches summary.json as the sim reported it, and summary.md
// says which figures a lockstep run has no slot for and which shape had no plugin.
TEST_F(RunLogTest, TheSimsLoopTimingReachesTheSummary) {
  intake::RunLog log;
  tools::RunFacts facts;
  facts.sim_reported = true;
  facts.lockstep = false;
  sim::LoopTiming& ft = facts.sim_timing;
  ft.overruns = 2;
  ft.deadline_misses = 7;
  ft.tick_ms_max = 1.25;
  ft.tick_ms_mean = 0.25;
  ft.tick_cpu_ms_max = 0.875;
  ft.start_delay_ms_max = 0.5;
  ft.plugin_calls = 62200;
  ft.plugin_call_us_mean = 85.5;
  ft.plugin_call_us_max = 1650.25;
  ft.plugin_call_cpu_us_max = 400.5;
  ft.plugin_budget_overruns = 9;
  ft.plugin_fallback_ticks = 11;
  tools::ExperimentSummary s = tools::summarizeExperiment(model_, log, facts);
  const auto j = nlohmann::json::parse(tools::summaryJson(s));
  const auto& t = j["loop_timing"];
  ASSERT_TRUE(t.is_object()) << j.dump();
  EXPECT_EQ(t.size(), 14u);
  EXPECT_EQ(t["overruns"], 2);
  EXPECT_EQ(t["deadline_misses"], 7);
  EXPECT_EQ(t["tick_ms_max"], 1.25);
  EXPECT_EQ(t["start_delay_ms_max"], 0.5);
  EXPECT_EQ(t["plugin_call_us_mean"], 85.5);
  EXPECT_EQ(t["plugin_call_us_max"], 1650.25);
  EXPECT_EQ(t["plugin_fallback_ticks"], 11);
  std::string table = tools::summaryTable(s);
  EXPECT_NE(table.find("| 2 / 7 | 0 / 0 |"), std::string::npos) << table;
  EXPECT_NE(table.find("| 1.250 ms (0.875 ms) / 0.250 ms; 0.500 ms |"), std::string::npos) << table;
  EXPECT_NE(table.find("| 85.5 / 1650.2 us (cpu 400.5 us); 9; 11 |"), std::string::npos) << table;
  facts.lockstep = true;  // lockstep, controller process: no slot, no plugin
  facts.sim_timing = sim::LoopTiming{};
  facts.sim_timing.overruns = 1;
  facts.sim_timing.tick_ms_mean = 0.125;
  table = tools::summaryTable(tools::summarizeExperiment(model_, log, facts));
  EXPECT_NE(table.find("| 1 / n/a (lockstep) | |"), std::string::npos) << table;  // no real-time target
  EXPECT_NE(table.find("/ 0.125 ms; n/a (lockstep) |"), std::string::npos) << table;  // the defaults: lockstep's
  EXPECT_NE(table.find("no plugin (controller process: its tick above)"), std::string::npos) << table;
}

TEST_F(RunLogTest, NotALogIsAnError) {
  std::ofstream(dir_.file("text.lcmlog")) << "this is not an LCM log\n";
  intake::RunLog run;
  std::string err;
  EXPECT_FALSE(intake::readRunLog(dir_.file("text.lcmlog"), model_.joint_names, run, &err));
  EXPECT_FALSE(intake::readRunLog(dir_.file("missing.lcmlog"), model_.joint_names, run, &err));
  EXPECT_NE(err.find("missing.lcmlog"), std::string::npos);
}

}  // namespace
}  // namespace exoid

namespace exoid {
namespace {
TEST(ExportCli, HelpDocumentsTheSchemaAndBadInputFails) {
  test::TempDir dir("export_cli");
  auto r = test::runCommand(test::exoidBinary() + " export --help", dir.path);
  EXPECT_EQ(r.exit_code, 0);
  for (const char* s : {"--log", "--out", "--truth", "--filter", "fp_<right|left>_fx", "base_ax", "tau_<joint>", "exit codes",
                        "--allow-partial", "3 the log is damaged"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
  r = test::runCommand(test::exoidBinary() + " export --log " + dir.file("none.lcmlog") + " --out " + dir.file("o.csv"), dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("none.lcmlog"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.csv")));
  r = test::runCommand(test::exoidBinary() + " export --log x --out y --filter -3", dir.path);
  EXPECT_EQ(r.exit_code, 2);
}
}  // namespace
}  // namespace exoid
