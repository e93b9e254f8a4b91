// LcmEndpoint: URL policy (ttl=0 only), memq:// publish/subscribe round trip, bounded waiting.
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/lcm_endpoint.hpp>
#include <exoid/lcm/message_gate.hpp>

#include "test_helpers.hpp"

#include <chrono>
#include <cstdlib>

namespace exoid {
namespace {

using test::jointNames;

TEST(LcmUrl, UdpmWithTtlAboveZeroIsRefused) {
  std::string normalised = "unchanged", why;
  EXPECT_FALSE(LcmEndpoint::checkUrl("udpm://239.255.76.67:7667?ttl=1", &normalised, &why));
  EXPECT_EQ(normalised, "unchanged");
  EXPECT_NE(why.find("ttl=1 refused"), std::string::npos) << why;
  EXPECT_EQ(why.find('\n'), std::string::npos);
  EXPECT_FALSE(LcmEndpoint::checkUrl("udpm://239.255.76.67:7667?recv_buf_size=65536&ttl=255", nullptr, &why));
  EXPECT_NE(why.find("ttl=255"), std::string::npos) << why;

  try {
    LcmEndpoint e("udpm://239.255.76.67:7667?ttl=1");
    FAIL() << "a ttl=1 URL was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("ttl=1"), std::string::npos) << e.what();
  }
  EXPECT_EQ(LcmEndpoint::create("udpm://239.255.76.67:7667?ttl=1", &why), nullptr);
}

TEST(LcmUrl, UdpmWithoutTtlGetsTtlZero) {
  std::string normalised, why;
  ASSERT_TRUE(LcmEndpoint::checkUrl("udpm://239.255.76.67:7667", &normalised, &why)) << why;
  EXPECT_EQ(normalised, "udpm://239.255.76.67:7667?ttl=0");
  ASSERT_TRUE(LcmEndpoint::checkUrl("udpm://239.255.76.67:7667?recv_buf_size=65536", &normalised, &why)) << why;
  EXPECT_EQ(normalised, "udpm://239.255.76.67:7667?recv_buf_size=65536&ttl=0");
  ASSERT_TRUE(LcmEndpoint::checkUrl(channels::kDefaultUrl, &normalised, &why)) << why;
  EXPECT_EQ(normalised, channels::kDefaultUrl);
}

TEST(LcmUrl, OtherBadUrls) {
  std::string why;
  EXPECT_FALSE(LcmEndpoint::checkUrl("", nullptr, &why));
  EXPECT_FALSE(LcmEndpoint::checkUrl("239.255.76.67:7667", nullptr, &why));
  EXPECT_NE(why.find("provider://"), std::string::npos) << why;
  EXPECT_FALSE(LcmEndpoint::checkUrl("tcpq://example.org:7700", nullptr, &why));
  EXPECT_NE(why.find("'tcpq' is not allowed"), std::string::npos) << why;
  EXPECT_FALSE(LcmEndpoint::checkUrl("udpm://?ttl=0", nullptr, &why));
  EXPECT_FALSE(LcmEndpoint::checkUrl("udpm://239.255.76.67:7667?ttl", nullptr, &why));
  EXPECT_TRUE(LcmEndpoint::checkUrl("memq://", nullptr, &why)) << why;
}

TEST(LcmUrl, DefaultHonoursEnvironment) {
  const char* saved = std::getenv("LCM_DEFAULT_URL");
  const std::string saved_value = saved ? saved : "";
  ::unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(LcmEndpoint::defaultUrl(), channels::kDefaultUrl);
  ::setenv("LCM_DEFAULT_URL", "memq://", 1);
  EXPECT_EQ(LcmEndpoint::defaultUrl(), "memq://");
  LcmEndpoint e;  // default argument: from the environment
  EXPECT_EQ(e.url(), "memq://");
  if (saved) ::setenv("LCM_DEFAULT_URL", saved_value.c_str(), 1);
  else ::unsetenv("LCM_DEFAULT_URL");
}

TEST(LcmEndpointMemq, TypedPublishSubscribeRoundTrip) {
  LcmEndpoint lcm("memq://");
  RobotStateSample received;
  int calls = 0;
  std::string channel_seen;
  lcm.subscribe<exoid_lcm::robot_state_t>(channels::kState, [&](const char* ch, const exoid_lcm::robot_state_t& m) {
    ++calls;
    channel_seen = ch;
    std::string why;
    EXPECT_TRUE(fromLcm(m, jointNames(), received, &why)) << why;
  });

  const RobotStateSample sent = test::makeState();
  exoid_lcm::robot_state_t msg;
  toLcm(sent, jointNames(), msg);
  std::string why;
  ASSERT_TRUE(lcm.publish(channels::kState, msg, &why)) << why;
  ASSERT_EQ(lcm.handleTimeout(1000, &why), 1) << why;
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(channel_seen, channels::kState);
  EXPECT_TRUE(test::sameMat(received.q, sent.q));
  EXPECT_TRUE(test::sameMat(received.tau, sent.tau));
  EXPECT_TRUE(test::sameMat(received.has_tau, sent.has_tau));
  EXPECT_EQ(received.tick, sent.tick);
  EXPECT_EQ(received.utime, sent.utime);
  EXPECT_NEAR(received.imu_orientation.angularDistance(sent.imu_orientation), 0.0, 1e-15);
  // Nothing else queued.
  EXPECT_EQ(lcm.handleTimeout(0), 0);
}

TEST(LcmEndpointMemq, RawSubscriptionThroughGateAndChannelFiltering) {
  LcmEndpoint lcm("memq://");
  MessageGate gate({channels::kState});
  exoid_lcm::robot_state_t scratch;
  RobotStateSample out;
  std::vector<int64_t> accepted_ticks;
  lcm.subscribeRaw(channels::kState, [&](const char* ch, const void* data, int size, int64_t recv_utime) {
    EXPECT_GT(recv_utime, 0);
    std::string why;
    if (gate.admitEncoded(gate.channelIndex(ch), data, size, scratch, out, &why, jointNames()))
      accepted_ticks.push_back(out.tick);
  });
  exoid_lcm::robot_state_t msg;
  toLcm(test::makeState(), jointNames(), msg);
  for (int64_t tick : {1, 2, 2, 1, 3}) {
    msg.tick = tick;
    ASSERT_TRUE(lcm.publish(channels::kState, msg));
  }
  ASSERT_TRUE(lcm.publish(channels::kCommand, msg));  // not subscribed: memq drops it at publish
  const uint8_t garbage[5] = {1, 2, 3, 4, 5};
  ASSERT_TRUE(lcm.publishRaw(channels::kState, garbage, sizeof garbage));
  int handled = 0;
  while (lcm.handleTimeout(100) == 1) ++handled;
  EXPECT_EQ(handled, 6);  // 5 states + the garbage; the EXO_COMMAND message never reached the queue
  EXPECT_EQ(accepted_ticks, (std::vector<int64_t>{1, 2, 3}));
  EXPECT_EQ(gate.rejected(0, RejectReason::Duplicate), 1u);
  EXPECT_EQ(gate.rejected(0, RejectReason::OutOfOrder), 1u);
  EXPECT_EQ(gate.rejected(0, RejectReason::Malformed), 1u);
}

TEST(LcmEndpointMemq, PublishBufferGrowsOnceThenStays) {
  LcmEndpoint lcm("memq://", 16);
  EXPECT_EQ(lcm.bufferSize(), 16u);
  std::vector<int> sizes;
  lcm.subscribeRaw(channels::kState, [&](const char*, const void*, int size, int64_t) { sizes.push_back(size); });
  exoid_lcm::robot_state_t msg;
  toLcm(test::makeState(), jointNames(), msg);
  ASSERT_TRUE(lcm.publish(channels::kState, msg));
  EXPECT_EQ(lcm.bufferSize(), static_cast<size_t>(msg.getEncodedSize()));
  ASSERT_TRUE(lcm.publish(channels::kState, msg));
  EXPECT_EQ(lcm.bufferSize(), static_cast<size_t>(msg.getEncodedSize()));
  lcm.reserve(1 << 20);
  EXPECT_EQ(lcm.bufferSize(), size_t{1} << 20);
  EXPECT_EQ(lcm.handleAvailable(), 2);
  EXPECT_EQ(sizes, (std::vector<int>{msg.getEncodedSize(), msg.getEncodedSize()}));
}

TEST(LcmEndpointMemq, UnsubscribeStopsDelivery) {
  LcmEndpoint lcm("memq://");
  int calls = 0;
  const int id = lcm.subscribeRaw(channels::kTruth, [&](const char*, const void*, int, int64_t) { ++calls; });
  const uint8_t byte = 0;
  lcm.publishRaw(channels::kTruth, &byte, 1);
  EXPECT_EQ(lcm.handleTimeout(100), 1);
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(lcm.unsubscribe(id));
  EXPECT_FALSE(lcm.unsubscribe(id));
  lcm.publishRaw(channels::kTruth, &byte, 1);
  lcm.handleTimeout(100);
  EXPECT_EQ(calls, 1);
}

TEST(LcmEndpointMemq, HandleTimeoutIsBounded) {
  LcmEndpoint lcm("memq://");
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(lcm.handleTimeout(50), 0);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(ms, 45.0);
  EXPECT_LT(ms, 1000.0);
  std::string why;
  EXPECT_EQ(lcm.handleTimeout(-1, &why), -1);
  EXPECT_NE(why.find("negative timeout"), std::string::npos) << why;
}

}  // namespace
}  // namespace exoid
