// The run-log reader and the export table on a synthetic log written with LCM's own event-log writer:
// every event is accounted for (decoded, rejected with a reason, or on an unknown channel); the table
// aligns channels by tick, skips ticks with a missing message, and converts plate readings to wrenches on
// the feet about the world origin.
#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <cstring>
#include <fstream>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/run_log.hpp"
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

  tools::RunLog run;
  std::string err;
  ASSERT_TRUE(tools::readRunLog(path, model_.joint_names, run, &err)) << err;
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

TEST_F(RunLogTest, NotALogIsAnError) {
  std::ofstream(dir_.file("text.lcmlog")) << "this is not an LCM log\n";
  tools::RunLog run;
  std::string err;
  EXPECT_FALSE(tools::readRunLog(dir_.file("text.lcmlog"), model_.joint_names, run, &err));
  EXPECT_FALSE(tools::readRunLog(dir_.file("missing.lcmlog"), model_.joint_names, run, &err));
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
  for (const char* s : {"--log", "--out", "--truth", "--filter", "fp_<right|left>_fx", "base_ax", "tau_<joint>", "exit codes"})
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
