// config/controller.yaml loading: every field is read and checked, errors name the field.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "controller_test_util.hpp"

namespace exoid::controller {
namespace {

std::string readDefaultConfig() {
  std::ifstream in(testing::configPath("controller.yaml"));
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The default file with the first line matching `key:` (after indentation) replaced by `replacement`.
std::string withLine(const std::string& text, const std::string& key, const std::string& replacement) {
  std::istringstream in(text);
  std::ostringstream out;
  std::string line;
  bool done = false;
  while (std::getline(in, line)) {
    const auto p = line.find_first_not_of(' ');
    if (!done && p != std::string::npos && line.compare(p, key.size() + 1, key + ":") == 0) {
      if (!replacement.empty()) out << line.substr(0, p) << replacement << "\n";
      done = true;
      continue;
    }
    out << line << "\n";
  }
  EXPECT_TRUE(done) << key;
  return out.str();
}

TEST(ControllerConfig, DefaultFileLoadsWithTheDocumentedValues) {
  ControllerConfig c;
  std::string err;
  ASSERT_TRUE(testing::loadConfig(c, &err)) << err;
  EXPECT_DOUBLE_EQ(c.loop.period, 0.001);
  EXPECT_EQ(c.trajectory.moves, 20);
  EXPECT_EQ(c.contact.right_sole_frame, "right_sole");
  EXPECT_DOUBLE_EQ(c.contact.sole_half_length, 0.14);
  EXPECT_DOUBLE_EQ(c.contact.sole_half_width, 0.06);
  EXPECT_EQ(c.momentum.kp_com.size(), 3);
  EXPECT_GT(c.momentum.kp_com.minCoeff(), 0.0);
  EXPECT_TRUE(c.estimate.enabled && c.estimate.use_feedforward && c.estimate.use_com);
  EXPECT_DOUBLE_EQ(c.estimate.max_abs, 150.0);
  EXPECT_EQ(c.estimate.max_age_ticks, 120);
  EXPECT_EQ(c.estimate.lag_ticks, 70);
  EXPECT_DOUBLE_EQ(c.estimate.blend_time, 1.0);
  EXPECT_DOUBLE_EQ(c.estimate.max_relative_mass_change, 0.5);
  EXPECT_DOUBLE_EQ(c.estimate.trust_sigmas, 3.0);
  EXPECT_DOUBLE_EQ(c.estimate.trust_sigmas_horizontal_com, 0.0);
  EXPECT_TRUE(c.com_observer.enabled);
  EXPECT_TRUE(c.com_observer.upper_body_momentum);
  EXPECT_DOUBLE_EQ(c.com_observer.crossover_hz, 0.2);
  EXPECT_EQ(c.com_observer.anchor, ComObserverConfig::Anchor::kModel);
  EXPECT_DOUBLE_EQ(c.com_observer.anchor_time_constant, 5.0);
  EXPECT_DOUBLE_EQ(c.com_observer.settle_time, 3.0);
  EXPECT_TRUE(usesForcePlates(c));
  EXPECT_TRUE(validateControllerConfig(c, &err)) << err;
}

TEST(ControllerConfig, ErrorsNameTheField) {
  const std::string text = readDefaultConfig();
  ControllerConfig c;
  std::string err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "kp_com", ""), "cfg", c, &err));
  EXPECT_EQ(err, "cfg: momentum.kp_com: missing");
  EXPECT_FALSE(parseControllerConfig(withLine(text, "kp_com", "kp_com: [1, 2]"), "cfg", c, &err));
  EXPECT_NE(err.find("momentum.kp_com"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "period", "period: fast"), "cfg", c, &err));
  EXPECT_NE(err.find("loop.period"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "friction_coefficient", "friction_coefficent: 0.7"), "cfg", c, &err));
  EXPECT_NE(err.find("contact.friction_coefficent: unknown key"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "friction_coefficient", "friction_coefficient: -0.1"), "cfg", c, &err));
  EXPECT_NE(err.find("contact.friction_coefficient: must be > 0"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "moves", "moves: 2.5"), "cfg", c, &err));
  EXPECT_NE(err.find("trajectory.moves"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "joint_velocity_cutoff_hz", "joint_velocity_cutoff_hz: 900"), "cfg", c, &err));
  EXPECT_NE(err.find("Nyquist"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "blend_time", "blend_time: -1"), "cfg", c, &err));
  EXPECT_NE(err.find("estimate.blend_time: must be >= 0"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "lag_ticks", "lag_ticks: 120"), "cfg", c, &err));
  EXPECT_NE(err.find("estimate.lag_ticks: must be >= 0 and below estimate.max_age_ticks"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "max_relative_mass_change", "max_relative_mass_change: 0"), "cfg",
                                     c, &err));
  EXPECT_NE(err.find("estimate.max_relative_mass_change: must be > 0"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "trust_sigmas_horizontal_com", "trust_sigmas_horizontal_com: -1"),
                                     "cfg", c, &err));
  EXPECT_NE(err.find("estimate.trust_sigmas_horizontal_com: must be >= 0"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "trust_sigmas_horizontal_com", ""), "cfg", c, &err));
  EXPECT_EQ(err, "cfg: estimate.trust_sigmas_horizontal_com: missing");
  EXPECT_FALSE(parseControllerConfig(withLine(text, "use_com", "use_centre: true"), "cfg", c, &err));
  EXPECT_NE(err.find("estimate.use_centre: unknown key"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "use_feedforward", "use_feedforward: maybe"), "cfg", c, &err));
  EXPECT_NE(err.find("estimate.use_feedforward"), std::string::npos) << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "crossover_hz", "crossover_hz: 30"), "cfg", c, &err));
  EXPECT_NE(err.find("com_observer.crossover_hz: must be > 0 and at most 1/50 of the control rate"), std::string::npos)
      << err;
  EXPECT_FALSE(parseControllerConfig(withLine(text, "anchor_time_constant", "anchor_time_constant: 0"), "cfg", c, &err));
  EXPECT_NE(err.find("com_observer.anchor_time_constant: must be > 0"), std::string::npos) << err;
  ControllerConfig m;
  EXPECT_TRUE(parseControllerConfig(withLine(text, "anchor", "anchor: plates"), "cfg", m, &err)) << err;
  EXPECT_EQ(m.com_observer.anchor, ComObserverConfig::Anchor::kPlates);
  EXPECT_FALSE(parseControllerConfig(withLine(text, "anchor", "anchor: soles"), "cfg", c, &err));
  EXPECT_EQ(err, "cfg: com_observer.anchor: expected one of plates, model, got 'soles'");
  EXPECT_FALSE(parseControllerConfig(withLine(text, "anchor", ""), "cfg", c, &err));
  EXPECT_EQ(err, "cfg: com_observer.anchor: missing");
  EXPECT_FALSE(parseControllerConfig(withLine(text, "settle_time", ""), "cfg", c, &err));
  EXPECT_EQ(err, "cfg: com_observer.settle_time: missing");
  EXPECT_FALSE(parseControllerConfig("loop: [1, 2", "cfg", c, &err));
  EXPECT_NE(err.find("YAML"), std::string::npos) << err;
  EXPECT_EQ(err.find('\n'), std::string::npos) << "one line";
  EXPECT_FALSE(loadControllerConfig("/nonexistent/controller.yaml", c, &err));
  EXPECT_NE(err.find("/nonexistent/controller.yaml"), std::string::npos);
}

// Found by fuzz_controller_config: an unknown key with a line break in it (a quoted YAML key) made the
// error two lines. Control characters are now escaped in every message.
TEST(ControllerConfig, ErrorQuotingAKeyWithALineBreakIsOneLine) {
  ControllerConfig c;
  std::string err;
  EXPECT_FALSE(parseControllerConfig("\"loop\\nx\": 1\n", "cfg", c, &err));
  EXPECT_EQ(err, "cfg: loop\\nx: unknown key");
  EXPECT_FALSE(parseControllerConfig(withLine(readDefaultConfig(), "period", "\"per\\riod\": 0.001"), "cfg", c, &err));
  EXPECT_NE(err.find("loop.per\\riod: unknown key"), std::string::npos) << err;
  EXPECT_EQ(err.find_first_of("\r\n"), std::string::npos) << "one line: " << err;
}

TEST(ControllerConfig, NumbersAreStrict) {
  const std::string text = readDefaultConfig();
  ControllerConfig c;
  std::string err;
  const std::pair<std::string, std::string> bad[] = {
      {"period: 13,5", "cfg: loop.period: expected a finite number, got '13,5' (not a number)"},
      {"period: .nan", "cfg: loop.period: expected a finite number, got '.nan' (not finite)"},
      {"period: -.Inf", "cfg: loop.period: expected a finite number, got '-.Inf' (not finite)"},
      {"period: 1e400", "cfg: loop.period: expected a finite number, got '1e400' (too large for a double)"},
      {"period: 0.001x", "cfg: loop.period: expected a finite number, got '0.001x' (not a number)"},
      {"period: ''", "cfg: loop.period: expected a finite number, got '' (empty, expected a number)"},
      {"kp_com: [100.0, .inf, 100.0]", "cfg: momentum.kp_com[1]: expected a finite number, got '.inf' (not finite)"},
      {"moves: 99999999999", "cfg: trajectory.moves: expected an integer, got '99999999999' (out of range"},
      {"moves: 0x14", "cfg: trajectory.moves: expected an integer, got '0x14' (not an integer)"},
  };
  for (const auto& [line, expect] : bad) {
    const std::string key = line.substr(0, line.find(':'));
    EXPECT_FALSE(parseControllerConfig(withLine(text, key, line), "cfg", c, &err)) << line;
    EXPECT_EQ(err.rfind(expect, 0), 0u) << err;
  }
  // A subnormal is a number (it used to be refused as not one).
  ASSERT_TRUE(parseControllerConfig(withLine(text, "min_normal_force", "min_normal_force: 1e-320"), "cfg", c, &err))
      << err;
  EXPECT_EQ(c.contact.min_normal_force, std::strtod("1e-320", nullptr));
}

TEST(ControllerConfig, DuplicateKeysAreRefusedAtEveryLevel) {
  const std::string text = readDefaultConfig();
  ControllerConfig c;
  std::string err;
  // yaml-cpp keeps both pairs and a lookup returns the first: the second value used to be ignored silently.
  EXPECT_FALSE(parseControllerConfig(withLine(text, "period", "period: 0.001\n  period: 0.002"), "cfg", c, &err));
  EXPECT_EQ(err.rfind("cfg: loop.period: duplicate key (line 8; first on line 7)", 0), 0u) << err;
  EXPECT_FALSE(parseControllerConfig(text + "loop: {period: 0.002}\n", "cfg", c, &err));
  EXPECT_EQ(err.rfind("cfg: loop: duplicate key", 0), 0u) << err;
}

}  // namespace
}  // namespace exoid::controller
