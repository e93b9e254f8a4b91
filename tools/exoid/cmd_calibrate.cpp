// exoid calibrate: a calibration run with the pelvis held in a harness and the legs swinging (docs/diagnose.md
// "Calibration run"); a thin main over tools::runCalibration.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/sim/config.hpp"
#include "exoid/tools/calibration_run.hpp"

namespace exoid::cli {

namespace cmd_calibrate {  // this file's own names: the exoid binary is a unity build
int fail(const std::string& msg) { return common::badInput("exoid calibrate", msg); }

constexpr char kDescription[] =
    "A calibration run of the simulated exoskeleton: its pelvis held still in a harness (raised by the scenario's\n"
    "harness.lift, 0.2 m when the file has no harness; passive joints pinned) and the feet free, every actuated\n"
    "joint swinging about mid-range by up to 60 % of its half range (hip abduction: 30 %, outward only, so the\n"
    "soles never meet) as a sum of sines at 0.11, 0.23 and 0.37 Hz with phases from --seed, tracked by computed\n"
    "torque on --model plus a PD (3 Hz). The scenario's undeclared\n"
    "effects and sensor noise apply as in `exoid experiment`. Why: a robot that only balances on both feet\n"
    "cannot show a constant joint-torque offset (it is a first-moment shift of the links around the joint);\n"
    "swinging legs can. Give the log to `exoid diagnose --calibration`.\n"
    "Runs in process (no LCM traffic): about 0.5 s for the default 40 s. Docs: docs/diagnose.md \"Calibration run\".\n\n"
    "Writes DIR/run.lcmlog (EXO_STATE, EXO_PLATE_RIGHT/LEFT, EXO_TRUTH, EXO_COMMAND, as `exoid experiment`) and\n"
    "DIR/calibration.txt (the figures printed). Fails (exit 2) when a foot touches a plate.";
}  // namespace cmd_calibrate

int cmdCalibrate(int argc, char** argv) {
  using namespace cmd_calibrate;
  const std::string config = EXOID_CONFIG_DIR;
  CLI::App app{kDescription, "exoid calibrate"};
  common::configureCli(app);
  std::string scenario_path, out_dir, sensors = config + "/sensors.yaml", model_path = config + "/exo.urdf",
                                      mjcf = config + "/exo.xml";
  tools::CalibrationRunOptions opt;
  int64_t seed = 1;
  app.add_option("--scenario", scenario_path, "sim scenario (config/scenarios/*.yaml): noise, undeclared effects")
      ->required()->type_name("FILE");
  app.add_option("--out", out_dir, "output directory (created)")->required()->type_name("DIR");
  app.add_option("--duration", opt.duration_s, "seconds of simulated time (default 40)")
      ->transform(common::strictNumber(1.0, 3600.0));
  app.add_option("--seed", seed, "phases of the sines (default 1; another seed: another swing, e.g. held-out data)")
      ->transform(common::strictInteger(0, INT64_MAX))->type_name("N");
  app.add_option("--sensors", sensors, "sensor noise configuration")->type_name("FILE");
  app.add_option("--model", model_path, "URDF of the drives' computed torque (the declared model)")->type_name("FILE");
  app.add_option("--mjcf", mjcf, "simulated robot")->type_name("FILE");
  app.footer("exit codes: 0 run completed, the feet free; 2 bad input, a log that cannot be written, or a foot that\n"
             "            touched a plate (one line on stderr; the log is kept for inspection)");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  opt.swing.seed = static_cast<uint64_t>(seed);
  opt.mjcf = mjcf;
  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(model_path, true, model, &err)) return fail(err);
  sim::SensorConfig realistic, noise;
  sim::Scenario scenario;
  if (!sim::loadSensorConfig(sensors, &realistic, &err) || !sim::loadScenario(scenario_path, &scenario, &err) ||
      !sim::resolveSensorConfig(scenario, realistic, &noise, &err))
    return fail(err);
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return fail("cannot create '" + out_dir + "': " + ec.message());
  opt.log_path = (std::filesystem::path(out_dir) / "run.lcmlog").string();
  std::fprintf(stderr, "exoid calibrate: %s, %.0f s, harness lift %.2f m\n", scenario.name.c_str(), opt.duration_s,
               scenario.harness.enabled ? scenario.harness.lift : sim::Harness{}.lift);
  tools::CalibrationRunResult res;
  const bool ok = tools::runCalibration(model, scenario, noise, opt, res, &err);
  if (!ok && res.ticks == 0 && res.events == 0) return fail(err);
  char buf[512];
  std::string text;
  std::snprintf(buf, sizeof buf,
                "calibration run: %lld ticks, %ld events -> %s\n"
                "pelvis held: drift %.3g m, tilt %.3g rad; tracking RMS %.4f rad (max %.4f); plates max %.2f N\n"
                "MuJoCo warnings %ld, clamped commands %ld\n",
                static_cast<long long>(res.ticks), res.events, opt.log_path.c_str(), res.base_drift_m, res.base_tilt_rad,
                res.tracking_rms_rad, res.tracking_max_rad, res.plate_force_max_n, res.mujoco_warnings, res.clamped_commands);
  text += buf;
  text += "joint ranges swept (rad):\n";
  for (int j = 0; j < model.njoints; ++j) {
    std::snprintf(buf, sizeof buf, "  %-16s %+.3f .. %+.3f\n", model.joint_names[j].c_str(), res.q_min[j], res.q_max[j]);
    text += buf;
  }
  std::fputs(text.c_str(), stdout);
  std::ofstream((std::filesystem::path(out_dir) / "calibration.txt").string()) << text;
  return ok ? 0 : fail(err);
}

}  // namespace exoid::cli
