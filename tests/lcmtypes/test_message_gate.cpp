// MessageGate: each rejection increments exactly one counter (its channel, its reason) by exactly one;
// rejected messages never advance the channel nor touch the output.
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/message_gate.hpp>

#include "test_helpers.hpp"

#include <limits>

namespace exoid {
namespace {

using test::jointNames;

// All counters of a gate, to check that exactly one of them moved.
std::vector<uint64_t> snapshot(const MessageGate& g) {
  std::vector<uint64_t> v;
  for (int c = 0; c < g.numChannels(); ++c) {
    v.push_back(g.accepted(c));
    for (int r = 0; r < kNumRejectReasons; ++r) v.push_back(g.rejected(c, static_cast<RejectReason>(r)));
  }
  return v;
}
// Index of (channel, reason) in snapshot().
size_t slot(int channel, RejectReason r) { return static_cast<size_t>(channel) * (1 + kNumRejectReasons) + 1 + static_cast<size_t>(r); }
size_t acceptedSlot(int channel) { return static_cast<size_t>(channel) * (1 + kNumRejectReasons); }

void expectOnlyIncrement(const std::vector<uint64_t>& before, const std::vector<uint64_t>& after, size_t which) {
  ASSERT_EQ(before.size(), after.size());
  for (size_t i = 0; i < before.size(); ++i) EXPECT_EQ(after[i], before[i] + (i == which ? 1 : 0)) << "counter " << i;
}

class GateTest : public ::testing::Test {
 protected:
  GateTest() : gate({channels::kState, channels::kPlateRight, channels::kPlateLeft}) {}
  void SetUp() override {
    state_ch = gate.channelIndex(channels::kState);
    toLcm(test::makeState(), jointNames(), msg);
  }
  // Admit `m` on the state channel; return whether accepted.
  bool admit(const exoid_lcm::robot_state_t& m) { return gate.admit(state_ch, m, out, &why, jointNames()); }

  MessageGate gate;
  int state_ch = -1;
  exoid_lcm::robot_state_t msg;
  RobotStateSample out;
  std::string why;
};

TEST_F(GateTest, ChannelLookup) {
  EXPECT_EQ(gate.channelIndex("EXO_STATE"), 0);
  EXPECT_EQ(gate.channelIndex("EXO_PLATE_LEFT"), 2);
  EXPECT_EQ(gate.channelIndex("EXO_COMMAND"), -1);
  EXPECT_EQ(gate.channelIndex(nullptr), -1);
  EXPECT_EQ(gate.channelName(1), "EXO_PLATE_RIGHT");
  EXPECT_THROW(MessageGate({"A", "A"}), std::invalid_argument);
  EXPECT_THROW(MessageGate({""}), std::invalid_argument);
  EXPECT_THROW(gate.accepted(3), std::out_of_range);
}

TEST_F(GateTest, AcceptsIncreasingTicksAndCountsGaps) {
  for (int64_t tick : {0, 1, 2, 5}) {
    msg.tick = tick;
    ASSERT_TRUE(admit(msg)) << why;
    EXPECT_EQ(out.tick, tick);
  }
  EXPECT_EQ(gate.accepted(state_ch), 4u);
  EXPECT_EQ(gate.skipped(state_ch), 2u);  // 3 and 4
  int64_t last = -1;
  ASSERT_TRUE(gate.lastTick(state_ch, &last));
  EXPECT_EQ(last, 5);
  EXPECT_EQ(gate.rejectedTotal(), 0u);
}

TEST_F(GateTest, DuplicateCountsExactlyOnce) {
  msg.tick = 10;
  ASSERT_TRUE(admit(msg)) << why;
  for (int repeat = 0; repeat < 3; ++repeat) {
    const auto before = snapshot(gate);
    out.tick = -99;
    EXPECT_FALSE(admit(msg));
    EXPECT_EQ(out.tick, -99) << "rejected message wrote the output";
    EXPECT_NE(why.find("tick 10 repeats"), std::string::npos) << why;
    expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::Duplicate));
  }
  EXPECT_EQ(gate.rejected(state_ch, RejectReason::Duplicate), 3u);
  EXPECT_EQ(gate.rejected(RejectReason::Duplicate), 3u);
}

TEST_F(GateTest, OutOfOrderCountsExactlyOnceAndDoesNotRewind) {
  msg.tick = 10;
  ASSERT_TRUE(admit(msg)) << why;
  msg.tick = 7;
  const auto before = snapshot(gate);
  EXPECT_FALSE(admit(msg));
  EXPECT_NE(why.find("older than"), std::string::npos) << why;
  expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::OutOfOrder));
  // Still 10: tick 8 is also old, 11 is accepted.
  msg.tick = 8;
  EXPECT_FALSE(admit(msg));
  EXPECT_EQ(gate.rejected(state_ch, RejectReason::OutOfOrder), 2u);
  msg.tick = 11;
  EXPECT_TRUE(admit(msg)) << why;
}

TEST_F(GateTest, NonFiniteAndMalformedCountExactlyOnceAndDoNotAdvance) {
  msg.tick = 1;
  ASSERT_TRUE(admit(msg)) << why;

  auto nan_msg = msg;
  nan_msg.tick = 2;
  nan_msg.q[0] = std::numeric_limits<double>::quiet_NaN();
  auto before = snapshot(gate);
  EXPECT_FALSE(admit(nan_msg));
  expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::NonFinite));

  auto bad_names = msg;
  bad_names.tick = 2;
  bad_names.joint_names[1] = "hip";
  before = snapshot(gate);
  EXPECT_FALSE(admit(bad_names));
  expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::Malformed));

  auto bad_quat = msg;
  bad_quat.tick = 2;
  bad_quat.imu_orientation[0] *= 1.01;
  before = snapshot(gate);
  EXPECT_FALSE(admit(bad_quat));
  expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::Malformed));

  // None of the rejected tick-2 messages advanced the channel: a good tick 2 is accepted, not a duplicate.
  msg.tick = 2;
  before = snapshot(gate);
  EXPECT_TRUE(admit(msg)) << why;
  expectOnlyIncrement(before, snapshot(gate), acceptedSlot(state_ch));
}

TEST_F(GateTest, UndecodableBytesAreMalformed) {
  exoid_lcm::robot_state_t scratch;
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  ASSERT_GT(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);

  // Truncated, and a different type (force_plate_t) on the state channel.
  auto before = snapshot(gate);
  EXPECT_FALSE(gate.admitEncoded(state_ch, bytes.data(), static_cast<int>(bytes.size()) - 3, scratch, out, &why,
                                 jointNames()));
  EXPECT_NE(why.find("do not decode"), std::string::npos) << why;
  expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::Malformed));

  exoid_lcm::force_plate_t plate;
  toLcm(test::makePlate(0), plate);
  std::vector<uint8_t> plate_bytes(static_cast<size_t>(plate.getEncodedSize()));
  plate.encode(plate_bytes.data(), 0, static_cast<int>(plate_bytes.size()));
  before = snapshot(gate);
  EXPECT_FALSE(gate.admitEncoded(state_ch, plate_bytes.data(), static_cast<int>(plate_bytes.size()), scratch, out,
                                 &why, jointNames()));
  expectOnlyIncrement(before, snapshot(gate), slot(state_ch, RejectReason::Malformed));

  before = snapshot(gate);
  EXPECT_TRUE(gate.admitEncoded(state_ch, bytes.data(), static_cast<int>(bytes.size()), scratch, out, &why,
                                jointNames()))
      << why;
  expectOnlyIncrement(before, snapshot(gate), acceptedSlot(state_ch));
  EXPECT_EQ(out.tick, msg.tick);
}

TEST_F(GateTest, ChannelsAreIndependent) {
  const int right = gate.channelIndex(channels::kPlateRight), left = gate.channelIndex(channels::kPlateLeft);
  exoid_lcm::force_plate_t plate;
  toLcm(test::makePlate(0), plate);
  ForcePlateSample fp;
  ASSERT_TRUE(gate.admit(right, plate, fp, &why, 0)) << why;
  // Same tick on the other channel is fine, but the left channel wants the left plate.
  auto before = snapshot(gate);
  EXPECT_FALSE(gate.admit(left, plate, fp, &why, 1));
  expectOnlyIncrement(before, snapshot(gate), slot(left, RejectReason::Malformed));
  toLcm(test::makePlate(1), plate);
  EXPECT_TRUE(gate.admit(left, plate, fp, &why, 1)) << why;
  EXPECT_EQ(fp.plate, 1);
  before = snapshot(gate);
  EXPECT_FALSE(gate.admit(left, plate, fp, &why, 1));
  expectOnlyIncrement(before, snapshot(gate), slot(left, RejectReason::Duplicate));
  EXPECT_EQ(gate.rejected(right), 0u);
  EXPECT_EQ(gate.rejected(left), 2u);
  EXPECT_EQ(gate.rejectedTotal(), 2u);
}

TEST_F(GateTest, ResetForgetsTicksAndCounters) {
  msg.tick = 3;
  ASSERT_TRUE(admit(msg));
  EXPECT_FALSE(admit(msg));
  gate.reset();
  EXPECT_EQ(gate.rejectedTotal(), 0u);
  EXPECT_EQ(gate.accepted(state_ch), 0u);
  EXPECT_FALSE(gate.lastTick(state_ch, nullptr));
  EXPECT_TRUE(admit(msg)) << why;
}

}  // namespace
}  // namespace exoid
