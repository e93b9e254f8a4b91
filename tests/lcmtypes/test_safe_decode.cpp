// safeDecode: every valid message decodes; truncated, padded, hostile-count and random-corrupted bytes are
// refused without throwing (where LCM's own decode throws or would size vectors from the bogus count).
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/message_gate.hpp>
#include <exoid/lcm/safe_decode.hpp>

#include "test_helpers.hpp"

#include <random>

namespace exoid {
namespace {

using test::jointNames;
using test::coordNames;
using test::paramNames;

template <class Msg>
std::vector<uint8_t> bytesOf(const Msg& msg) {
  std::vector<uint8_t> b(static_cast<size_t>(msg.getEncodedSize()));
  EXPECT_EQ(msg.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

void putInt32(std::vector<uint8_t>& b, size_t at, int32_t v) {
  const auto u = static_cast<uint32_t>(v);
  b.at(at) = static_cast<uint8_t>(u >> 24);
  b.at(at + 1) = static_cast<uint8_t>(u >> 16);
  b.at(at + 2) = static_cast<uint8_t>(u >> 8);
  b.at(at + 3) = static_cast<uint8_t>(u);
}

// Valid bytes decode to the same message; every strict prefix and a padded copy are refused.
template <class Msg>
void checkType(const Msg& msg) {
  SCOPED_TRACE(Msg::getTypeName());
  const std::vector<uint8_t> b = bytesOf(msg);
  Msg out;
  ASSERT_TRUE(safeDecode(b.data(), static_cast<int>(b.size()), out));
  EXPECT_EQ(bytesOf(out), b);
  for (size_t len = 0; len < b.size(); ++len) {
    Msg scratch;
    EXPECT_FALSE(safeDecode(b.data(), static_cast<int>(len), scratch)) << "prefix of " << len << " bytes";
  }
  std::vector<uint8_t> padded = b;
  padded.push_back(0);
  EXPECT_FALSE(safeDecode(padded.data(), static_cast<int>(padded.size()), out));
  EXPECT_FALSE(safeDecode(nullptr, 10, out));
}

TEST(SafeDecode, EveryTypeRoundTripsAndRefusesTruncation) {
  exoid_lcm::robot_state_t rs;
  toLcm(test::makeState(), jointNames(), rs);
  checkType(rs);
  exoid_lcm::force_plate_t fp;
  toLcm(test::makePlate(1), fp);
  checkType(fp);
  exoid_lcm::joint_command_t jc;
  toLcm(test::makeCommand(), jointNames(), jc);
  checkType(jc);
  exoid_lcm::controller_status_t cs;
  toLcm(test::makeStatus(), cs);
  checkType(cs);
  exoid_lcm::estimator_output_t eo;
  toLcm(test::makeEstimate(), paramNames(), coordNames(), eo);
  checkType(eo);
  exoid_lcm::ground_truth_t gt;
  toLcm(test::makeTruth(), jointNames(), gt);
  checkType(gt);
}

TEST(SafeDecode, HostileJointCountIsRefusedWhereLcmDecodeThrows) {
  exoid_lcm::robot_state_t msg;
  toLcm(test::makeState(), jointNames(), msg);
  const std::vector<uint8_t> good = bytesOf(msg);
  constexpr size_t kNumJointsAt = 8 + 8 + 8;  // hash, utime, tick
  for (int32_t bogus : {-1, -100000, 11, 1000000, INT32_MAX}) {
    std::vector<uint8_t> b = good;
    putInt32(b, kNumJointsAt, bogus);
    exoid_lcm::robot_state_t out;
    EXPECT_FALSE(safeDecode(b.data(), static_cast<int>(b.size()), out)) << bogus;
  }
  // The hazard being guarded against: LCM's own decoder throws on a negative count.
  std::vector<uint8_t> b = good;
  putInt32(b, kNumJointsAt, -1);
  exoid_lcm::robot_state_t raw;
  EXPECT_ANY_THROW(raw.decode(b.data(), 0, static_cast<int>(b.size())));
}

TEST(SafeDecode, ZeroLengthStringIsRefusedWhereLcmDecodeThrows) {
  exoid_lcm::force_plate_t msg;
  toLcm(test::makePlate(0), msg);
  std::vector<uint8_t> b = bytesOf(msg);
  putInt32(b, 8 + 8 + 8, 0);  // plate_name length (includes the NUL, so >= 1)
  exoid_lcm::force_plate_t out;
  EXPECT_FALSE(safeDecode(b.data(), static_cast<int>(b.size()), out));
  exoid_lcm::force_plate_t raw;
  EXPECT_ANY_THROW(raw.decode(b.data(), 0, static_cast<int>(b.size())));
}

TEST(SafeDecode, RandomCorruptionNeverThrows) {
  exoid_lcm::estimator_output_t eo;
  toLcm(test::makeEstimate(), paramNames(), coordNames(), eo);
  exoid_lcm::robot_state_t rs;
  toLcm(test::makeState(), jointNames(), rs);
  const std::vector<uint8_t> eo_bytes = bytesOf(eo), rs_bytes = bytesOf(rs);
  std::mt19937 rng(7);
  int accepted = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const bool est = trial % 2 == 0;
    std::vector<uint8_t> b = est ? eo_bytes : rs_bytes;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) b[rng() % b.size()] = static_cast<uint8_t>(rng());
    const int len = static_cast<int>(b.size()) - static_cast<int>(rng() % 3);
    bool ok = false;
    if (est) {
      exoid_lcm::estimator_output_t out;
      EXPECT_NO_THROW(ok = safeDecode(b.data(), len, out));
      if (ok) {
        EXPECT_EQ(out.getEncodedSize(), len);
      }
    } else {
      exoid_lcm::robot_state_t out;
      EXPECT_NO_THROW(ok = safeDecode(b.data(), len, out));
      if (ok) {
        EXPECT_EQ(out.getEncodedSize(), len);
      }
    }
    accepted += ok;
  }
  // Flips inside double payloads keep the message decodable, so some pass; hash/count flips do not.
  EXPECT_GT(accepted, 0);
  EXPECT_LT(accepted, 4000);
}

TEST(SafeDecode, GateCountsHostileBytesAsMalformedOnce) {
  MessageGate gate({channels::kState});
  exoid_lcm::robot_state_t msg, scratch;
  toLcm(test::makeState(), jointNames(), msg);
  std::vector<uint8_t> b = bytesOf(msg);
  putInt32(b, 24, INT32_MAX);
  RobotStateSample out;
  std::string why;
  EXPECT_FALSE(gate.admitEncoded(0, b.data(), static_cast<int>(b.size()), scratch, out, &why, jointNames()));
  EXPECT_EQ(gate.rejected(0, RejectReason::Malformed), 1u);
  EXPECT_EQ(gate.rejectedTotal(), 1u);
  EXPECT_EQ(out.q.size(), 0) << "output written on rejection";
}

}  // namespace
}  // namespace exoid
