// The one tick assembly (tick_assembly.hpp): release order, the lag window, duplicates, out-of-order messages,
// capacity overflow and every counter, against hand-counted message sequences; and alignByTick on it.
#include <gtest/gtest.h>

#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/online/online_estimator.hpp"
#include "exoid/model/urdf.hpp"
#include "synthetic_sensors.hpp"
#include "exoid/estimator/tick_assembly.hpp"
#include "support/alloc_counter.hpp"

namespace exoid::estimator {
namespace {

constexpr unsigned kSensors = (1u << kTickState) | (1u << kTickPlateRight) | (1u << kTickPlateLeft);

// Every tick released now, in order: (tick, complete) pairs.
std::vector<std::pair<int64_t, bool>> drain(TickAssembly& a, bool flush = false) {
  std::vector<std::pair<int64_t, bool>> out;
  ReleasedTick r;
  while (a.release(r, flush)) out.emplace_back(r.tick, r.complete);
  return out;
}

using Released = std::vector<std::pair<int64_t, bool>>;

TEST(TickAssembly, InOrderTicksLeaveAsSoonAsComplete) {
  TickAssembly a(kSensors, 0, 2);
  for (int64_t k = 0; k < 5; ++k) {
    EXPECT_EQ(a.place(kTickPlateLeft, k, nullptr), TickPlacement::Accepted);
    EXPECT_EQ(a.place(kTickState, k, nullptr), TickPlacement::Accepted);
    EXPECT_TRUE(drain(a).empty());  // not complete yet
    int slot = -1;
    EXPECT_EQ(a.place(kTickPlateRight, k, &slot), TickPlacement::Accepted);
    EXPECT_GE(slot, 0);
    ReleasedTick r;
    ASSERT_TRUE(a.release(r));
    EXPECT_EQ(r.tick, k);
    EXPECT_EQ(r.slot, slot);
    EXPECT_TRUE(r.complete);
    EXPECT_EQ(r.present, kSensors);
    EXPECT_FALSE(a.release(r));
  }
  EXPECT_EQ(a.counts().accepted, 15);
  EXPECT_EQ(a.counts().complete, 5);
  EXPECT_EQ(a.counts().incomplete + a.counts().duplicates + a.counts().out_of_order + a.counts().overflow, 0);
}

TEST(TickAssembly, AChannelLaggingWithinTheWindowCompletesEveryTickInOrder) {
  // The left plate arrives 3 ticks late; window 3 waits for it.
  TickAssembly a(kSensors, 3, 5);
  Released got;
  for (int64_t k = 0; k < 10; ++k) {
    a.place(kTickState, k, nullptr);
    a.place(kTickPlateRight, k, nullptr);
    if (k >= 3) a.place(kTickPlateLeft, k - 3, nullptr);
    for (auto& t : drain(a)) got.push_back(t);
  }
  for (int64_t k = 7; k < 10; ++k) a.place(kTickPlateLeft, k, nullptr);
  for (auto& t : drain(a, true)) got.push_back(t);
  ASSERT_EQ(got.size(), 10u);
  for (int64_t k = 0; k < 10; ++k) EXPECT_EQ(got[k], std::make_pair(k, true)) << k;
  EXPECT_EQ(a.counts().complete, 10);
  EXPECT_EQ(a.counts().incomplete, 0);
  EXPECT_EQ(a.counts().out_of_order, 0);
}

TEST(TickAssembly, AChannelLaggingBeyondTheWindowLeavesIncompleteTicksAndIsOutOfOrder) {
  // Lag 4 > window 3: tick k is declared incomplete when tick k + 4 arrives, before its left plate.
  TickAssembly a(kSensors, 3, 5);
  Released got;
  long out_of_order = 0;
  for (int64_t k = 0; k < 10; ++k) {
    a.place(kTickState, k, nullptr);
    a.place(kTickPlateRight, k, nullptr);
    for (auto& t : drain(a)) got.push_back(t);
    if (k >= 4) out_of_order += a.place(kTickPlateLeft, k - 4, nullptr) == TickPlacement::OutOfOrder;
  }
  for (auto& t : drain(a, true)) got.push_back(t);
  ASSERT_EQ(got.size(), 10u);
  for (int64_t k = 0; k < 10; ++k) EXPECT_EQ(got[k], std::make_pair(k, false)) << k;
  EXPECT_EQ(out_of_order, 6);  // ticks 0..5's left plates
  EXPECT_EQ(a.counts().out_of_order, 6);
  EXPECT_EQ(a.counts().incomplete, 10);
  EXPECT_EQ(a.counts().complete, 0);
  EXPECT_EQ(a.counts().accepted, 20);
}

TEST(TickAssembly, WindowZeroANewerTickClosesTheOlderOne) {
  TickAssembly a(kSensors, 0, 2);
  a.place(kTickState, 0, nullptr);
  a.place(kTickPlateRight, 0, nullptr);
  EXPECT_TRUE(drain(a).empty());
  a.place(kTickState, 1, nullptr);
  EXPECT_EQ(drain(a), (Released{{0, false}}));
  // The left plate of tick 0 is now late, the state of tick 0 is behind its channel's tick 1, and the right
  // plate of tick 0 again is a duplicate (its channel's last tick).
  EXPECT_EQ(a.check(kTickPlateLeft, 0), TickPlacement::OutOfOrder);
  EXPECT_EQ(a.check(kTickState, 0), TickPlacement::OutOfOrder);
  EXPECT_EQ(a.place(kTickPlateRight, 0, nullptr), TickPlacement::Duplicate);
  EXPECT_EQ(a.counts().incomplete, 1);
  EXPECT_EQ(a.counts().duplicates, 1);
  EXPECT_EQ(a.counts().out_of_order, 0);  // check() counts nothing
}

TEST(TickAssembly, DuplicatesAreRefusedWhileHeldAndAfterReleaseAndTheFirstIsKept) {
  TickAssembly a(kSensors, 2, 4);
  int first = -1, again = 7;
  EXPECT_EQ(a.place(kTickState, 5, &first), TickPlacement::Accepted);
  EXPECT_EQ(a.place(kTickState, 5, &again), TickPlacement::Duplicate);
  EXPECT_EQ(again, -1);  // nothing to store: the first message stays
  a.place(kTickPlateRight, 5, nullptr);
  a.place(kTickPlateLeft, 5, nullptr);
  EXPECT_EQ(drain(a), (Released{{5, true}}));
  EXPECT_EQ(a.place(kTickPlateLeft, 5, nullptr), TickPlacement::Duplicate);
  EXPECT_EQ(a.counts().duplicates, 2);
  EXPECT_EQ(a.counts().accepted, 3);
  EXPECT_EQ(a.counts().complete, 1);
}

TEST(TickAssembly, OutOfOrderMessagesAreCountedAndLeaveNothingBehind) {
  TickAssembly a(kSensors, 2, 4);
  for (int64_t k : {10, 11}) {
    a.place(kTickState, k, nullptr);
    a.place(kTickPlateRight, k, nullptr);
    a.place(kTickPlateLeft, k, nullptr);
  }
  EXPECT_EQ(drain(a), (Released{{10, true}, {11, true}}));
  EXPECT_EQ(a.place(kTickPlateRight, 9, nullptr), TickPlacement::OutOfOrder);   // before a released tick
  EXPECT_EQ(a.place(kTickPlateRight, -1, nullptr), TickPlacement::OutOfOrder);  // no tick
  EXPECT_EQ(a.place(kTickState, 20, nullptr), TickPlacement::Accepted);
  EXPECT_EQ(a.place(kTickState, 17, nullptr), TickPlacement::OutOfOrder);  // 3 behind the newest, window 2
  EXPECT_EQ(a.place(kTickState, 18, nullptr), TickPlacement::Accepted);   // 2 behind: within the window
  EXPECT_EQ(a.counts().out_of_order, 3);
  // Tick 18 waits for its plates (within the window) and leaves before 20, in tick order, at the flush.
  EXPECT_TRUE(drain(a).empty());
  EXPECT_EQ(drain(a, true), (Released{{18, false}, {20, false}}));
  EXPECT_EQ(a.counts().incomplete, 2);
}

TEST(TickAssembly, OverflowIsCountedAndAllocatesNothing) {
  // Capacity 2 < window + 2: a third tick held at once is refused, counted, and nothing is allocated.
  TickAssembly a(kSensors, 10, 2);
  test::AllocationCounter counter;
  EXPECT_EQ(a.place(kTickState, 0, nullptr), TickPlacement::Accepted);
  EXPECT_EQ(a.place(kTickState, 1, nullptr), TickPlacement::Accepted);
  EXPECT_EQ(a.place(kTickState, 2, nullptr), TickPlacement::Overflow);
  EXPECT_EQ(a.place(kTickPlateRight, 2, nullptr), TickPlacement::Overflow);
  EXPECT_EQ(a.place(kTickPlateRight, 1, nullptr), TickPlacement::Accepted);  // a held tick still takes messages
  ReleasedTick r;
  long released = 0;
  while (a.release(r, true)) ++released;  // ticks 0 and 1, incomplete
  for (int64_t k = 3; k < 2000; ++k) {  // a long run through the full assembly
    a.place(kTickState, k, nullptr);
    while (a.release(r, true)) ++released;
  }
  counter.stop();
  EXPECT_EQ(counter.mallocs(), 0);
  EXPECT_EQ(counter.news(), 0);
  EXPECT_EQ(a.counts().overflow, 2);
  EXPECT_EQ(a.counts().accepted, 3 + 1997);
  EXPECT_EQ(released, 2 + 1997);
  EXPECT_EQ(a.counts().incomplete, 2 + 1997);
}

TEST(TickAssembly, RestartRefusesTheResumeTickAndOlderAndKeepsTheCounts) {
  TickAssembly a(kSensors, 0, 2);
  TickAssemblyCounts c;
  c.incomplete = 4;
  a.restart(100, c);
  EXPECT_EQ(a.check(kTickState, 100), TickPlacement::Duplicate);
  EXPECT_EQ(a.check(kTickPlateLeft, 99), TickPlacement::OutOfOrder);
  EXPECT_EQ(a.place(kTickState, 101, nullptr), TickPlacement::Accepted);
  EXPECT_EQ(a.counts().incomplete, 4);
  EXPECT_EQ(a.counts().accepted, 1);
}

// alignByTick on the assembly: a repeated state tick gives one entry (the first message) and is counted.
TEST(TickAssembly, AlignByTickKeepsTheFirstOfARepeatedStateAndCountsIt) {
  std::vector<RobotStateSample> states(6);
  std::vector<ForcePlateSample> right(5), left(5);
  for (int k = 0; k < 5; ++k) {
    states[k].tick = right[k].tick = left[k].tick = k;
    states[k].utime = 1000 * k;
    right[k].plate = 0;
    left[k].plate = 1;
  }
  states[5] = states[2];       // tick 2 again, later in the log ...
  states[5].utime = 999999;    // ... with other values: the first one must be kept
  std::swap(states[3], states[5]);  // log order: 0 1 2 2' 4 3
  long skipped = -1;
  TickAssemblyCounts counts;
  const std::vector<AlignedTick> t = alignByTick(states, right, left, {}, TickNeeds{}, &skipped, &counts);
  ASSERT_EQ(t.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(t[k].state->tick, k);
    EXPECT_EQ(t[k].state->utime, 1000 * k);
    EXPECT_EQ(t[k].plate[0]->tick, k);
    EXPECT_EQ(t[k].plate[1]->tick, k);
  }
  EXPECT_EQ(skipped, 0);
  EXPECT_EQ(counts.duplicates, 1);
  EXPECT_EQ(counts.out_of_order, 0);
  EXPECT_EQ(counts.complete, 5);
  // A lost left plate: the state's tick is skipped and counted.
  left.erase(left.begin() + 1);
  EXPECT_EQ(alignByTick(states, right, left, {}, TickNeeds{}, &skipped, &counts).size(), 4u);
  EXPECT_EQ(skipped, 1);
  EXPECT_EQ(counts.incomplete, 1);
}

// A simulator's log has the truth beside the sensors: exporting the sensors (truth not needed) or the truth
// (sensors not needed) gives every tick, with the optional channel attached, and nothing counted out of order.
// Before, ties went by channel order, so the truth of a tick came after the tick was released and every
// truth message counted as out of order (`exoid export`: "5200 out-of-order messages dropped" on a clean run).
TEST(TickAssembly, AnOptionalChannelOfTheSameTickIsNotOutOfOrder) {
  std::vector<RobotStateSample> states(4);
  std::vector<ForcePlateSample> right(4), left(4);
  std::vector<GroundTruthSample> truth(4);
  for (int k = 0; k < 4; ++k) {
    states[k].tick = right[k].tick = left[k].tick = truth[k].tick = k;
    right[k].plate = 0;
    left[k].plate = 1;
  }
  for (const TickNeeds needs : {TickNeeds{true, true, false}, TickNeeds{false, false, true}}) {
    long skipped = -1;
    TickAssemblyCounts counts;
    const std::vector<AlignedTick> t = alignByTick(states, right, left, truth, needs, &skipped, &counts);
    ASSERT_EQ(t.size(), 4u);
    for (int k = 0; k < 4; ++k) {
      ASSERT_NE(t[k].truth, nullptr);
      ASSERT_NE(t[k].state, nullptr);
      EXPECT_EQ(t[k].truth->tick, k);
      EXPECT_EQ(t[k].state->tick, k);
    }
    EXPECT_EQ(skipped, 0);
    EXPECT_EQ(counts.out_of_order, 0);
    EXPECT_EQ(counts.duplicates, 0);
  }
}

// The online estimator's admit applies the gate's value rules (sample_checks.hpp, the ones fromLcm applies):
// a quaternion off unit by 2e-6 is malformed (it used to pass: admit only asked |q| > 0.5), by 5e-7 accepted;
// a torque where the joint has no sensor is malformed. A rejected message leaves its tick open for a good one.
TEST(Gate, OnlineAdmitAppliesTheGateRules) {
  Model model;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  OnlineEstimator est(model, computeBaseParameters(model), model.phi, OnlineEstimatorOptions());
  ASSERT_TRUE(est.ok()) << est.error();
  testing::SensorTick t = testing::makeSensorTick(model);
  std::mt19937_64 rng(3);
  testing::fillSensorTick(model, 0, 0.3, 1.0, rng, t);
  RobotStateSample s = t.state;
  s.imu_orientation.coeffs() *= 1.0 + 2e-6;
  EXPECT_EQ(checkStateValues(s), SampleFault::Malformed);
  EXPECT_EQ(est.addState(s), InputStatus::Malformed);
  s = t.state;
  s.has_tau[1] = false;
  s.tau[1] = 0.5;
  EXPECT_EQ(est.addState(s), InputStatus::Malformed);
  ForcePlateSample p = t.plate[0];
  p.plate_orientation.coeffs() *= 1.0 - 2e-6;
  EXPECT_EQ(est.addPlate(p), InputStatus::Malformed);
  p = t.plate[0];
  p.cop.y() = std::nan("");
  EXPECT_EQ(est.addPlate(p), InputStatus::NonFinite);
  s = t.state;
  s.imu_orientation.coeffs() *= 1.0 + 5e-7;
  EXPECT_EQ(est.addState(s), InputStatus::Accepted);
  EXPECT_EQ(est.addPlate(t.plate[0]), InputStatus::Accepted);
  EXPECT_EQ(est.rejected(InputStatus::Malformed), 3);
  EXPECT_EQ(est.rejected(InputStatus::NonFinite), 1);
  EXPECT_EQ(est.rejected(InputStatus::Duplicate), 0);
}

}  // namespace
}  // namespace exoid::estimator
