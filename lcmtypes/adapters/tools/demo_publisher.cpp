// exoid_lcm_demo_publisher: publishes N plausible exoid_lcm.robot_state_t messages (the 10 exoskeleton
// joints, standing with a slow sway) at a fixed rate, for lcm-spy demos and transport checks.
// Usage: exoid_lcm_demo_publisher --help
#include <exoid/common/cli.hpp>
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/lcm_endpoint.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

const std::vector<std::string> kJointNames = {
    "right_hip_aa", "right_hip_fe", "right_knee", "right_ankle_pd", "right_ankle_ie",
    "left_hip_aa",  "left_hip_fe",  "left_knee",  "left_ankle_pd",  "left_ankle_ie"};

}  // namespace

int main(int argc, char** argv) {
  int64_t count = 200, start_tick = 0;
  double rate = 100;
  std::string url = exoid::LcmEndpoint::defaultUrl();
  std::string channel = exoid::channels::kState;
  CLI::App app{"Publishes N exoid_lcm.robot_state_t messages (the 10 exoskeleton joints, standing with a slow\n"
               "sway) at a fixed rate, ticks K, K+1, ..., for lcm-spy demos and transport checks.",
               "exoid_lcm_demo_publisher"};
  exoid::common::configureCli(app);
  app.add_option("--count", count, "messages to publish")
      ->transform(exoid::common::strictInteger(1, 1000000000))->type_name("N");
  app.add_option("--rate", rate, "messages per second")
      ->transform(exoid::common::strictNumber(1e-3, 10000.0))->type_name("HZ");
  app.add_option("--start-tick", start_tick, "tick of the first message")
      ->transform(exoid::common::strictInteger(0))->type_name("K");
  app.add_option("--url", url, "LCM URL (udpm needs ttl=0); the default is $LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--channel", channel, "channel name")->type_name("NAME");
  app.footer("exit codes: 0 published, 1 LCM failure, 2 bad option.");
  if (const int code = exoid::common::parseCli(app, argc, argv); code >= 0) return code;

  std::string why;
  auto lcm = exoid::LcmEndpoint::create(url, &why);
  if (!lcm) {
    std::fprintf(stderr, "exoid_lcm_demo_publisher: %s\n", why.c_str());
    return 1;
  }

  const int n = static_cast<int>(kJointNames.size());
  exoid::RobotStateSample s;
  s.q = Eigen::VectorXd::Zero(n);
  s.tau = Eigen::VectorXd::Zero(n);
  s.has_tau.setConstant(n, true);
  s.has_tau[4] = s.has_tau[9] = false;  // passive ankle inversion/eversion joints carry no torque sensor
  // Standing posture: slight hip and knee flexion, ankles compensating.
  const double q0[10] = {0.02, 0.20, -0.35, 0.15, 0.0, -0.02, 0.20, -0.35, 0.15, 0.0};
  const double tau0[10] = {1.5, -8.0, 22.0, -12.0, 0.0, -1.5, -8.0, 22.0, -12.0, 0.0};
  exoid_lcm::robot_state_t msg;
  toLcm(s, kJointNames, msg);  // sizes msg once
  lcm->reserve(static_cast<size_t>(msg.getEncodedSize()));

  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = std::chrono::steady_clock::now();
  const auto t_start = std::chrono::system_clock::now();
  const int64_t utime0 =
      std::chrono::duration_cast<std::chrono::microseconds>(t_start.time_since_epoch()).count();
  const long total = static_cast<long>(count);
  for (long k = 0; k < total; ++k) {
    const double t = static_cast<double>(start_tick + k) / rate;
    const double sway = std::sin(2.0 * M_PI * 0.5 * t);  // 0.5 Hz lateral sway
    for (int j = 0; j < n; ++j) {
      const double side = j < 5 ? 1.0 : -1.0;
      s.q[j] = q0[j] + 0.05 * sway * (j % 5 == 0 || j % 5 == 4 ? side : 0.3);
      s.tau[j] = s.has_tau[j] ? tau0[j] * (1.0 + 0.1 * side * sway) : 0.0;
    }
    const double roll = 0.03 * sway;
    s.imu_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
    s.imu_gyro = Eigen::Vector3d(0.03 * 2.0 * M_PI * 0.5 * std::cos(2.0 * M_PI * 0.5 * t), 0.0, 0.0);
    // Specific force while (nearly) still: +g along world z, seen in the IMU frame.
    s.imu_accel = s.imu_orientation.conjugate() * Eigen::Vector3d(0.0, 0.0, 9.81);
    s.tick = start_tick + k;
    s.utime = utime0 + static_cast<int64_t>(std::llround(static_cast<double>(k) / rate * 1e6));
    toLcm(s, kJointNames, msg);
    if (!lcm->publish(channel.c_str(), msg, &why)) {
      std::fprintf(stderr, "exoid_lcm_demo_publisher: %s\n", why.c_str());
      return 1;
    }
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  std::printf("exoid_lcm_demo_publisher: published %ld exoid_lcm.%s messages on %s (%s)\n", total,
              exoid_lcm::robot_state_t::getTypeName(), channel.c_str(), lcm->url().c_str());
  return 0;
}
