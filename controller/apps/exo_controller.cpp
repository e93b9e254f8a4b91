// exo_controller: the centroidal balance controller as an LCM process (docs/controller.md).
// EXO_STATE (robot_state_t, tick k) -> BalanceController::tick -> EXO_COMMAND (joint_command_t, tick k + 1) and
// EXO_CONTROLLER_STATUS (controller_status_t), every tick. EXO_ESTIMATE (estimator_output_t) goes to
// BalanceController::setEstimate (feedforward and CoM). Exits 0 once the CoM trajectory and the final hold are
// over, with a summary line and the estimate's line.
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exoid/common/cli.hpp>
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/channels.hpp>
#include <exoid/lcm/lcm_endpoint.hpp>
#include <exoid/lcm/message_gate.hpp>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller/run_options.hpp"
#include "exoid/model/urdf.hpp"

namespace {

using exoid::common::kExitBadInput;  // bad arguments, URDF or config
using exoid::common::kExitOk;
using exoid::common::kExitRuntime;  // LCM failure or interrupted
constexpr int kExitIdle = 3;        // no state for --idle-timeout-ms
constexpr int kDefaultIdleTimeoutMs = 5000;
constexpr int kPollSliceMs = 50;   // longest single wait inside the loop (keeps signals responsive)
constexpr int kMaxReportedRejections = 5;

volatile std::sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

std::string defaultPath(const char* file) {
#ifdef EXOID_CONFIG_DIR
  return exoid::common::defaultConfigPath(file, EXOID_CONFIG_DIR);
#else
  return exoid::common::defaultConfigPath(file, nullptr);
#endif
}

int badInput(const std::string& message) {
  std::fprintf(stderr, "exo_controller: error: %s\n", message.c_str());
  return kExitBadInput;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace exoid;
  using namespace exoid::controller;
  namespace common = exoid::common;

  std::string model_path = defaultPath("exo.urdf");
  std::string config_path = defaultPath("controller.yaml");
  std::string url = LcmEndpoint::defaultUrl();
  unsigned long long seed = 1;
  int64_t idle_timeout_ms = kDefaultIdleTimeoutMs;
  bool use_estimate = true, quiet = false, print_duration = false;
  int64_t moves = 0;  // 0: the configuration's

  CLI::App app{
      "Centroidal (momentum-based) balance controller of the exoskeleton standing on both feet (Vallinas et al.,\n"
      "ICORR 2023): tracks the seed thesis's protocol of straight-line CoM moves inside the support polygon, with\n"
      "ProxQP solving the whole-body QP every tick. Documentation: docs/controller.md.",
      "exo_controller"};
  common::configureCli(app);
  bool no_estimate = false;
  app.add_option("--model", model_path, "URDF of the robot")->type_name("PATH");
  app.add_option("--config", config_path, "controller configuration")->type_name("PATH");
  app.add_option("--moves", moves, "number of CoM moves (0: trajectory.moves of the configuration, 20)")
      ->transform(common::strictInteger(0, kMaxMoves))->type_name("N");
  app.add_option("--seed", seed,
                 "seed of the CoM move sequence; use different seeds for training and validation runs")
      ->transform(common::strictInteger(kMinSeed, kMaxSeed))->type_name("N");
  app.add_option("--lcm-url", url,
                 "LCM URL; udpm URLs must have ttl=0 (added when absent); the default is\n$LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--idle-timeout-ms", idle_timeout_ms, "exit with code 3 when no robot state arrives for N ms")
      ->transform(common::strictInteger(1, 24LL * 3600 * 1000))->type_name("N");
  app.add_flag("--no-estimate", no_estimate, "ignore EXO_ESTIMATE (the controller runs on its URDF alone)");
  app.add_flag("--quiet", quiet, "no progress lines on stderr (errors and the summary are still printed)");
  app.add_flag("--print-duration", print_duration,
               "print the planned run time in seconds (start-up latch + moves + holds, from the\n"
               "config; set the simulator's --duration to at least this) and exit 0");
  app.footer(
      "channels:\n"
      "  subscribes  EXO_STATE              exoid_lcm.robot_state_t      robot state of tick k (SI: rad, N m,\n"
      "                                                                  rad/s, m/s^2; IMU quaternion w x y z)\n"
      "              EXO_ESTIMATE           exoid_lcm.estimator_output_t optional: while fresh (estimate.\n"
      "                                                                  max_age_ticks), valid and consistent,\n"
      "                                                                  tau_correction [nv; N, N m] enters the QP's\n"
      "                                                                  dynamics and params give the CoM\n"
      "                                                                  (blended in/out, estimate.blend_time)\n"
      "              EXO_PLATE_RIGHT/LEFT   exoid_lcm.force_plate_t      force plates (N, N m ON the plate, plate\n"
      "                                                                  frame): the disturbance observer's\n"
      "                                                                  measured contact wrenches when\n"
      "                                                                  disturbance.force_plates\n"
      "  publishes   EXO_COMMAND            exoid_lcm.joint_command_t    tick k+1, source_tick k; tau [N m]\n"
      "                                                                  (0 on the passive ankle in/eversion),\n"
      "                                                                  tau_ff [N m], mode 0 torque / 1 hold\n"
      "                                                                  last safe / 2 damping\n"
      "              EXO_CONTROLLER_STATUS  exoid_lcm.controller_status_t every tick: QP status, iterations,\n"
      "                                                                  solve and tick time [us], CoM reference\n"
      "                                                                  and estimate [m, m/s, world], momentum\n"
      "                                                                  [kg m/s, kg m^2/s] and its desired rate,\n"
      "                                                                  contact wrenches [N, N m], counters\n"
      "\n"
      "Timing: the state of tick k is answered by the command for tick k + 1.\n"
      "A state that fails the input checks (NaN, malformed) is answered by the fallback command (hold the last\n"
      "safe command, then joint damping); duplicate or out-of-order states are counted and not answered.\n"
      "\n"
      "exit codes:\n"
      "  0  trajectory done and final hold over (summary line on stdout, then\n"
      "     'exo_controller: estimate: accepted N, refused N (...), withdrawn N (...), weight W, mass M kg')\n"
      "  1  LCM failure or interrupted (SIGINT/SIGTERM)\n"
      "  2  bad input: unknown option or bad value, unreadable/invalid URDF or config (one-line error naming the\n"
      "     field), or no move sequence fits the support polygon with the configured margins\n"
      "  3  no robot state for --idle-timeout-ms");
  if (const int code = common::parseCli(app, argc, argv); code >= 0) return code;
  use_estimate = !no_estimate;

  // ---- setup (allocations allowed) ---------------------------------------------------------------------
  Model model;
  std::string err;
  if (!buildModelFromUrdfFile(model_path, true, model, &err)) return badInput("--model " + model_path + ": " + err);
  ControllerConfig cfg;
  if (!loadControllerConfig(config_path, cfg, &err)) return badInput(err);
  if (moves > 0) cfg.trajectory.moves = static_cast<int>(moves);
  if (print_duration) {
    std::printf("%.3f\n", plannedRunDuration(cfg));
    return kExitOk;
  }
  BalanceController ctrl(model, cfg, seed);
  if (!ctrl.ok()) return badInput(config_path + ": " + ctrl.error());
  std::string normalised;
  if (!LcmEndpoint::checkUrl(url, &normalised, &err)) return badInput("--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> lcm = LcmEndpoint::create(normalised, &err);
  if (!lcm) {
    std::fprintf(stderr, "exo_controller: LCM: %s\n", err.c_str());
    return kExitRuntime;
  }

  const std::vector<std::string>& joint_names = model.joint_names;
  const std::vector<std::string> param_names = model.paramNames();
  const std::vector<std::string> coord_names = model.coordinateNames();
  MessageGate gate({channels::kState, channels::kEstimate, channels::kPlateRight, channels::kPlateLeft});
  const int ch_state = gate.channelIndex(channels::kState);
  const int ch_estimate = gate.channelIndex(channels::kEstimate);
  const int ch_plate[2] = {gate.channelIndex(channels::kPlateRight), gate.channelIndex(channels::kPlateLeft)};

  RobotStateSample state, bad_state;
  state.q = Eigen::VectorXd::Zero(model.njoints);
  state.tau = Eigen::VectorXd::Zero(model.njoints);
  state.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model.njoints, true);
  bad_state = state;
  bad_state.q.setConstant(std::nan(""));  // a sample the controller rejects: it answers with its fallback
  EstimatorOutputSample estimate;
  estimate.params = Eigen::VectorXd::Zero(model.nparams());
  estimate.param_stddev = Eigen::VectorXd::Zero(model.nparams());
  estimate.tau_correction = Eigen::VectorXd::Zero(model.nv);
  ForcePlateSample plate;
  exoid_lcm::force_plate_t plate_msg;
  exoid_lcm::robot_state_t state_msg;
  exoid_lcm::estimator_output_t estimate_msg;
  exoid_lcm::joint_command_t command_msg;
  exoid_lcm::controller_status_t status_msg;
  JointCommandSample command;
  ctrl.prepare(command);
  ControllerStatus status;
  // Pre-size the outgoing messages once (toLcm reuses their vectors afterwards).
  toLcm(command, joint_names, command_msg);
  toLcm(static_cast<const ControllerStatusSample&>(status), status_msg);
  lcm->reserve(static_cast<size_t>(std::max(command_msg.getEncodedSize(), status_msg.getEncodedSize())) + 1024);

  // Statistics for the summary (no allocation per tick).
  long long ticks = 0, answered_bad = 0, unanswered = 0, publish_errors = 0;
  double se_com = 0.0, max_com_err = 0.0, tick_sum = 0.0, tick_max = 0.0;
  long long com_samples = 0;
  int reported = 0;
  bool done = false;
  auto last_state = std::chrono::steady_clock::now();

  auto answer = [&](const RobotStateSample& s) {
    ctrl.tick(s, command, status);
    ++ticks;
    tick_sum += status.tick_us;
    tick_max = std::max(tick_max, status.tick_us);
    toLcm(command, joint_names, command_msg);
    toLcm(static_cast<const ControllerStatusSample&>(status), status_msg);
    if (!lcm->publish(channels::kCommand, command_msg)) ++publish_errors;
    if (!lcm->publish(channels::kControllerStatus, status_msg)) ++publish_errors;
    if (status.trajectory_ready && !status.trajectory_done && status.mode == CommandMode::Torque) {
      const double e = (status.com_ref - status.com).norm();
      se_com += e * e;
      max_com_err = std::max(max_com_err, e);
      ++com_samples;
    }
    if (status.trajectory_ready &&
        status.trajectory_time >= ctrl.trajectoryDuration() + cfg.trajectory.final_hold)
      done = true;
    if (status.trajectory_failed) done = true;
  };

  lcm->subscribeRaw(channels::kState, [&](const char*, const void* data, int size, int64_t) {
    last_state = std::chrono::steady_clock::now();
    std::string* why = reported < kMaxReportedRejections ? &err : nullptr;
    if (gate.admitEncoded(ch_state, data, size, state_msg, state, why, joint_names)) {
      answer(state);
      return;
    }
    if (why) {
      std::fprintf(stderr, "exo_controller: rejected %s: %s\n", channels::kState, err.c_str());
      ++reported;
    }
    // A decodable state with a new tick that failed the checks gets the fallback answer; duplicates and
    // out-of-order states do not (the command for their tick was already sent).
    int64_t last = 0;
    const bool has_last = gate.lastTick(ch_state, &last);
    if (size > 0 && state_msg.tick > (has_last ? last : -1) && state_msg.tick >= 0) {
      bad_state.tick = state_msg.tick;
      bad_state.utime = state_msg.utime;
      answer(bad_state);
      ++answered_bad;
    } else {
      ++unanswered;
    }
  });
  if (cfg.disturbance.enabled && cfg.disturbance.force_plates) {
    // The plates of tick k arrive after the state of tick k: the observer pairs them with the wrench it planned
    // for that tick, so they are used one tick later.
    for (int i = 0; i < 2; ++i) {
      const char* channel = i == 0 ? channels::kPlateRight : channels::kPlateLeft;
      lcm->subscribeRaw(channel, [&, i](const char*, const void* data, int size, int64_t) {
        if (gate.admitEncoded(ch_plate[i], data, size, plate_msg, plate, nullptr, i)) ctrl.setForcePlate(plate);
      });
    }
  }
  if (use_estimate) {
    lcm->subscribeRaw(channels::kEstimate, [&](const char*, const void* data, int size, int64_t) {
      // Every decoded estimate goes to the controller, which refuses (and counts) an unusable one.
      if (gate.admitEncoded(ch_estimate, data, size, estimate_msg, estimate, nullptr, param_names, kAnyNumBase,
                            coord_names))
        ctrl.setEstimate(estimate);
    });
  }

  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  if (!quiet)
    std::fprintf(stderr, "exo_controller: seed %llu, %d moves, waiting for %s on %s\n", seed, cfg.trajectory.moves,
                 channels::kState, lcm->url().c_str());

  int exit_code = kExitOk;
  const char* outcome = "done";
  while (!done) {
    if (g_stop) {
      exit_code = kExitRuntime;
      outcome = "interrupted";
      break;
    }
    const auto idle = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() -
                                                                            last_state).count();
    if (idle >= idle_timeout_ms) {
      std::fprintf(stderr, "exo_controller: no %s for %lld ms, exiting\n", channels::kState,
                   static_cast<long long>(idle));
      exit_code = kExitIdle;
      outcome = "idle timeout";
      break;
    }
    const int wait = static_cast<int>(std::min<long long>(kPollSliceMs, idle_timeout_ms - idle));
    if (lcm->handleTimeout(std::max(wait, 1), &err) < 0) {
      std::fprintf(stderr, "exo_controller: LCM: %s\n", err.c_str());
      exit_code = kExitRuntime;
      outcome = "lcm error";
      break;
    }
  }

  if (status.trajectory_failed) {
    std::fprintf(stderr,
                 "exo_controller: %s: trajectory: no %d targets fit the support polygon shrunk by "
                 "trajectory.polygon_margin with trajectory.min/max_move_distance (held the start-up CoM)\n",
                 config_path.c_str(), cfg.trajectory.moves);
    exit_code = kExitBadInput;
    outcome = "trajectory generation failed";
  }
  const double rmse = com_samples > 0 ? std::sqrt(se_com / static_cast<double>(com_samples)) : 0.0;
  std::printf(
      "exo_controller: %s: seed %llu, moves %d/%d, ticks %lld, CoM ref-vs-estimate RMSE %.3f mm (max %.3f mm), "
      "tick mean %.1f us max %.1f us, fallbacks %d, qp failures %d, rejected %d (answered %lld, unanswered %lld), "
      "stale %d, publish errors %lld\n",
      outcome, seed, status.moves_done, cfg.trajectory.moves, ticks, 1e3 * rmse, 1e3 * max_com_err,
      ticks > 0 ? tick_sum / static_cast<double>(ticks) : 0.0, tick_max, status.fallbacks, status.qp_failures,
      status.rejected_inputs, answered_bad, unanswered, status.stale_inputs, publish_errors);
  printEstimateUse(stdout, "exo_controller", status.estimate);
  std::fflush(stdout);
  return exit_code;
}
