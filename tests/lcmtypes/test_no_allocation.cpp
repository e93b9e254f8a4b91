// Real-time path of a receiver/sender: once messages and samples are sized, decoding, validating, gating,
// converting back and encoding allocate nothing (counted by tests/support/alloc_counter).
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/message_gate.hpp>
#include <exoid/lcm/safe_decode.hpp>

#include "support/alloc_counter.hpp"
#include "test_helpers.hpp"

namespace exoid {
namespace {

using test::jointNames;
using test::coordNames;
using test::paramNames;

TEST(NoAllocation, ReceiveValidateGateAndSendSteadyState) {
  MessageGate gate({channels::kState, channels::kCommand, channels::kEstimate, channels::kPlateRight});
  RobotStateSample state = test::makeState();
  JointCommandSample command = test::makeCommand();
  EstimatorOutputSample estimate = test::makeEstimate();
  ForcePlateSample plate = test::makePlate(0);
  exoid_lcm::robot_state_t state_msg, state_rx;
  exoid_lcm::joint_command_t command_msg, command_rx;
  exoid_lcm::estimator_output_t estimate_msg, estimate_rx;
  exoid_lcm::force_plate_t plate_msg, plate_rx;
  std::vector<uint8_t> buf(1 << 16);

  auto cycle = [&](int64_t tick, bool* ok) {
    state.tick = command.tick = command.source_tick = estimate.tick = plate.tick = tick;
    toLcm(state, jointNames(), state_msg);
    toLcm(command, jointNames(), command_msg);
    toLcm(estimate, paramNames(), coordNames(), estimate_msg);
    toLcm(plate, plate_msg);
    int n = state_msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    *ok = gate.admitEncoded(0, buf.data(), n, state_rx, state, nullptr, jointNames());
    n = command_msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    *ok = *ok && gate.admitEncoded(1, buf.data(), n, command_rx, command, nullptr, jointNames());
    n = estimate_msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    *ok = *ok && gate.admitEncoded(2, buf.data(), n, estimate_rx, estimate, nullptr, paramNames(), test::kNumBase, coordNames());
    n = plate_msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    *ok = *ok && gate.admitEncoded(3, buf.data(), n, plate_rx, plate, nullptr, 0);
    // Rejections (empty bytes, then a duplicate) without a reason string: no allocation either.
    *ok = *ok && !gate.admitEncoded(0, buf.data(), 0, state_rx, state, nullptr, jointNames());
    *ok = *ok && !gate.admit(0, state_rx, state, nullptr, jointNames());
  };

  bool ok = false;
  cycle(1, &ok);  // sizes everything
  ASSERT_TRUE(ok);
  const std::size_t before = test::allocationCount();
  for (int64_t tick = 2; tick < 50; ++tick) {
    cycle(tick, &ok);
    if (!ok) break;
  }
  const std::size_t allocations = test::allocationCount() - before;
  ASSERT_TRUE(ok);
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(gate.accepted(0), 49u);
  EXPECT_EQ(gate.rejected(0), 2u * 49u);

  // The counter does count: a fresh message allocates.
  const std::size_t c0 = test::allocationCount();
  exoid_lcm::robot_state_t fresh;
  toLcm(state, jointNames(), fresh);
  EXPECT_GT(test::allocationCount(), c0);
}

}  // namespace
}  // namespace exoid
