// Balance under model error: the 20-move protocol against the simulator library in-process, with undeclared
// effects drawn at random in the ranges of docs/controller.md ("Model error"). Seeded: the seed is printed, and
// EXOID_MODEL_ERROR_SEED=<n> reruns a draw (EXOID_MODEL_ERROR_DRAWS=<n> changes how many).
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>

#include "sim_closed_loop.hpp"

namespace exoid::controller {
namespace {

uint64_t envOr(const char* name, uint64_t fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtoull(v, nullptr, 10) : fallback;
}

/// One random scenario: each kind of effect present with probability 1/2 (at least one; so single effects and
/// combinations), values uniform in the ranges: payload <= 4 kg on any link with its CoM anywhere within 0.15 m of the link frame origin; viscous
/// damping <= 3 N m s/rad and dry friction <= 3 N m on a random subset of joints; armature <= 0.1 kg m^2;
/// torque sensor offsets <= 1 N m and gain errors <= 10 %, with the drives closing their loop on them.
sim::Scenario drawScenario(const Model& model, std::mt19937_64& rng, std::string* description) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  sim::Scenario s;
  s.name = "random";
  s.seed = rng();
  s.noise = sim::NoiseMode::Realistic;
  sim::Effects& e = s.effects;
  char buf[256];
  while (!e.any()) {
    if (u(rng) < 0.5) {
      sim::Payload p;
      p.link = model.body_names[static_cast<size_t>(rng() % static_cast<uint64_t>(model.nbodies))];
      p.mass = 4.0 * u(rng);
      Eigen::Vector3d dir;
      std::normal_distribution<double> n(0.0, 1.0);
      do dir = Eigen::Vector3d(n(rng), n(rng), n(rng)); while (dir.norm() < 1e-6);
      p.com = 0.15 * std::cbrt(u(rng)) * dir.normalized();  // uniform in the ball
      const double i = p.mass * 0.02 / 12.0;                 // a 0.1 m cube
      p.inertia << i, i, i, 0.0, 0.0, 0.0;
      std::snprintf(buf, sizeof buf, "payload %.2f kg on %s at (%.3f, %.3f, %.3f); ", p.mass, p.link.c_str(),
                    p.com.x(), p.com.y(), p.com.z());
      *description += buf;
      e.payloads.push_back(p);
    }
    for (auto [list, max, what] : {std::tuple{&e.joint_damping, 3.0, "damping"},
                                   std::tuple{&e.joint_frictionloss, 3.0, "dry friction"},
                                   std::tuple{&e.armature, 0.1, "armature"}}) {
      if (u(rng) >= 0.5) continue;
      *description += std::string(what) + " {";
      for (const std::string& j : model.joint_names) {
        if (u(rng) < 0.5) continue;
        list->push_back({j, max * u(rng)});
        std::snprintf(buf, sizeof buf, "%s %.3f, ", j.c_str(), list->back().value);
        *description += buf;
      }
      *description += "}; ";
    }
    if (u(rng) < 0.5) {
      e.drive_loop_on_sensor = true;  // the drives close their loop on them: actuation errors
      *description += "torque sensors (drive loop on them) {";
      for (int j = 0; j < model.njoints; ++j) {
        if (model.effort_limit[j] <= 0.0) continue;  // passive joints have no sensor
        sim::TorqueSensorError t{model.joint_names[static_cast<size_t>(j)], 2.0 * u(rng) - 1.0,
                                 0.9 + 0.2 * u(rng)};
        std::snprintf(buf, sizeof buf, "%s %+.3f N m x %.3f, ", t.joint.c_str(), t.offset, t.gain);
        *description += buf;
        e.torque_sensor.push_back(t);
      }
      *description += "}; ";
    }
  }
  return s;
}

TEST(ModelError, RandomUndeclaredEffectsKeepBalance) {
  std::string err;
  Model model;
  ASSERT_TRUE(testing::loadModel(model, &err)) << err;
  ControllerConfig cfg;
  ASSERT_TRUE(testing::loadConfig(cfg, &err)) << err;
  const uint64_t seed = envOr("EXOID_MODEL_ERROR_SEED", 20261129);
  const uint64_t draws = envOr("EXOID_MODEL_ERROR_DRAWS", 3);
  std::printf("model-error draws: EXOID_MODEL_ERROR_SEED=%llu EXOID_MODEL_ERROR_DRAWS=%llu\n",
              static_cast<unsigned long long>(seed), static_cast<unsigned long long>(draws));
  std::mt19937_64 rng(seed);
  for (uint64_t k = 0; k < draws; ++k) {
    std::string what;
    const sim::Scenario scenario = drawScenario(model, rng, &what);
    const uint64_t move_seed = 1 + rng() % 1000;
    std::printf("draw %llu (move seed %llu): %s\n", static_cast<unsigned long long>(k),
                static_cast<unsigned long long>(move_seed), what.c_str());
    const testing::ScenarioRunMetrics m = testing::runScenarioClosedLoop(model, cfg, scenario, move_seed, &err);
    ASSERT_TRUE(m.loaded) << err;
    testing::printMetrics("  result", m);
    EXPECT_FALSE(m.fell) << what;
    EXPECT_EQ(m.moves_done, cfg.trajectory.moves) << what;
    EXPECT_LE(m.slip, 1e-3) << what;
    EXPECT_LE(m.model_com_rmse, 5e-3) << what;
  }
}

}  // namespace
}  // namespace exoid::controller
