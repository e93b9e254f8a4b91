// exo_controller: the centroidal balance controller as an LCM process (docs/controller.md).
// EXO_STATE (robot_state_t, tick k) -> BalanceController::tick -> EXO_COMMAND (joint_command_t, tick k + 1) and
// EXO_CONTROLLER_STATUS (controller_status_t), every tick. EXO_ESTIMATE (estimator_output_t) goes to
// BalanceController::setEstimate (feedforward and CoM). Exits 0 once the CoM trajectory and the final hold are
// over, with a summary line and the estimate's line. Thin: options -> ControllerNode (controller_node.hpp) -> the
// summary.
#include <cmath>
#include <cstdio>
#include <exoid/common/cli.hpp>
#include <exoid/common/process_main.hpp>
#include <exoid/lcm/channels.hpp>
#include <memory>
#include <string>

#include "controller_node.hpp"
#include "exoid/controller/run_options.hpp"
#include "exoid/model/urdf.hpp"

namespace {

using exoid::common::kExitBadInput;  // bad arguments, URDF or config
using exoid::common::kExitOk;
using exoid::common::kExitRuntime;  // LCM failure or interrupted
constexpr int kExitIdle = 3;        // no state for --idle-timeout-ms
constexpr int kDefaultIdleTimeoutMs = 5000;
constexpr char kProg[] = "exo_controller";

constexpr char kDescription[] =
    "Centroidal (momentum-based) balance controller of the exoskeleton standing on both feet (Vallinas et al.,\n"
    "ICORR 2023): tracks the seed thesis's protocol of straight-line CoM moves inside the support polygon, with\n"
    "ProxQP solving the whole-body QP every tick. Documentation: docs/controller.md.";

constexpr char kFooter[] =
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
    "                                                                  disturbance.force_plates; the CoM\n"
    "                                                                  observer's CoM when com_observer.enabled\n"
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
    "  3  no robot state for --idle-timeout-ms";

/// exo_controller's options.
struct Args {
  std::string model_path = exoid::common::configPath("exo.urdf");
  std::string config_path = exoid::common::configPath("controller.yaml");
  std::string url = exoid::LcmEndpoint::defaultUrl();
  unsigned long long seed = 1;
  int64_t idle_timeout_ms = kDefaultIdleTimeoutMs;
  int64_t moves = 0;  // 0: the configuration's
  int wait_estimate_ms = 0;  // 0: never wait for the estimate
  bool no_estimate = false, quiet = false, print_duration = false;
};

void addOptions(CLI::App& app, Args& a) {
  namespace common = exoid::common;
  using namespace exoid::controller;
  app.add_option("--model", a.model_path, "URDF of the robot")->type_name("PATH");
  app.add_option("--config", a.config_path, "controller configuration")->type_name("PATH");
  app.add_option("--moves", a.moves, "number of CoM moves (0: trajectory.moves of the configuration, 20)")
      ->transform(common::strictInteger(0, kMaxMoves))->type_name("N");
  app.add_option("--seed", a.seed,
                 "seed of the CoM move sequence; use different seeds for training and validation runs")
      ->transform(common::strictInteger(kMinSeed, kMaxSeed))->type_name("N");
  app.add_option("--lcm-url", a.url,
                 "LCM URL; udpm URLs must have ttl=0 (added when absent); the default is\n$LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--idle-timeout-ms", a.idle_timeout_ms, "exit with code 3 when no robot state arrives for N ms")
      ->transform(common::strictInteger(1, 24LL * 3600 * 1000))->type_name("N");
  app.add_flag("--no-estimate", a.no_estimate, "ignore EXO_ESTIMATE (the controller runs on its URDF alone)");
  app.add_option("--wait-estimate-ms", a.wait_estimate_ms,
                 "lockstep: answer the state of tick k only once an EXO_ESTIMATE with tick >= k -\n"
                 "estimate.lag_ticks has arrived, waiting at most MS ms (the estimates the controller\n"
                 "applies then do not depend on scheduling: the run is reproducible bit for bit); after\n"
                 "a timeout it stops waiting and says so. Keep MS below the simulator's command\n"
                 "timeout. 0 (default): never wait")
      ->transform(common::strictInteger(0, 3600000))->type_name("MS");
  app.add_flag("--quiet", a.quiet, "no progress lines on stderr (errors and the summary are still printed)");
  app.add_flag("--print-duration", a.print_duration,
               "print the planned run time in seconds (start-up latch + moves + holds, from the\n"
               "config; set the simulator's --duration to at least this) and exit 0");
}

/// The summary line, then the estimate's use.
void printSummary(const char* outcome, const Args& a, const exoid::controller::ControllerConfig& cfg,
                  const exoid::controller::ControllerNode& node) {
  const exoid::controller::ControllerNodeStats& st = node.stats();
  const exoid::controller::ControllerStatus& status = node.status();
  const double rmse = st.com_samples > 0 ? std::sqrt(st.se_com / static_cast<double>(st.com_samples)) : 0.0;
  std::printf(
      "exo_controller: %s: seed %llu, moves %d/%d, ticks %lld, CoM ref-vs-estimate RMSE %.3f mm (max %.3f mm), "
      "tick mean %.1f us max %.1f us, fallbacks %d, qp failures %d, rejected %d (answered %lld, unanswered %lld), "
      "stale %d, publish errors %lld, estimate waits %lld (%.3f s, timeouts %lld%s)\n",
      outcome, a.seed, status.moves_done, cfg.trajectory.moves, st.ticks, 1e3 * rmse, 1e3 * st.max_com_err,
      st.ticks > 0 ? st.tick_sum / static_cast<double>(st.ticks) : 0.0, st.tick_max, status.fallbacks, status.qp_failures,
      status.rejected_inputs, st.answered_bad, st.unanswered, status.stale_inputs, st.publish_errors,
      st.estimate_waits, st.estimate_wait_s, st.estimate_timeouts, st.estimate_timeouts > 0 ? ": not reproducible" : "");
  exoid::controller::printEstimateUse(stdout, "exo_controller", status.estimate);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace exoid;
  using namespace exoid::controller;
  CLI::App app{kDescription, kProg};
  common::configureCli(app);
  Args a;
  addOptions(app, a);
  app.footer(kFooter);
  if (const int code = common::parseCli(app, argc, argv); code >= 0) return code;

  // ---- setup (allocations allowed) ---------------------------------------------------------------------
  Model model;
  std::string err;
  if (!buildModelFromUrdfFile(a.model_path, true, model, &err))
    return common::badInput(kProg, "--model " + a.model_path + ": " + err);
  ControllerConfig cfg;
  if (!loadControllerConfig(a.config_path, cfg, &err)) return common::badInput(kProg, err);
  if (a.moves > 0) cfg.trajectory.moves = static_cast<int>(a.moves);
  if (a.print_duration) {
    std::printf("%.3f\n", plannedRunDuration(cfg));
    return kExitOk;
  }
  BalanceController ctrl(model, cfg, a.seed);
  if (!ctrl.ok()) return common::badInput(kProg, a.config_path + ": " + ctrl.error());
  std::string normalised;
  if (!LcmEndpoint::checkUrl(a.url, &normalised, &err)) return common::badInput(kProg, "--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> lcm = LcmEndpoint::create(normalised, &err);
  if (!lcm) {
    std::fprintf(stderr, "exo_controller: LCM: %s\n", err.c_str());
    return kExitRuntime;
  }
  ControllerNode node(*lcm, model, ctrl, cfg, !a.no_estimate, a.wait_estimate_ms);
  const volatile std::sig_atomic_t* stop = common::installStopSignals();
  if (!a.quiet)
    std::fprintf(stderr, "exo_controller: seed %llu, %d moves, waiting for %s on %s\n", a.seed, cfg.trajectory.moves,
                 channels::kState, lcm->url().c_str());
  const Eigen::Vector2d& lever = ctrl.comObserver().upperBodyLever();
  if (!a.quiet && cfg.com_observer.enabled && !lever.isZero(0.0))
    std::fprintf(stderr, "exo_controller: CoM observer: the upper body turns on the lumbar pivot, lever x %.3f m, y %.3f m\n",
                 lever.x(), lever.y());

  // ---- the loop (ControllerNode: no allocation per tick) ------------------------------------------------
  const ControllerNode::Outcome outcome = node.run(a.idle_timeout_ms, stop);
  int exit_code = outcome == ControllerNode::Outcome::Done          ? kExitOk
                  : outcome == ControllerNode::Outcome::IdleTimeout ? kExitIdle
                                                                    : kExitRuntime;
  const char* what = outcome == ControllerNode::Outcome::Done          ? "done"
                     : outcome == ControllerNode::Outcome::Interrupted ? "interrupted"
                     : outcome == ControllerNode::Outcome::IdleTimeout ? "idle timeout"
                                                                       : "lcm error";
  if (node.status().trajectory_failed) {
    std::fprintf(stderr,
                 "exo_controller: %s: trajectory: no %d targets fit the support polygon shrunk by "
                 "trajectory.polygon_margin with trajectory.min/max_move_distance (held the start-up CoM)\n",
                 a.config_path.c_str(), cfg.trajectory.moves);
    exit_code = kExitBadInput;
    what = "trajectory generation failed";
  }
  printSummary(what, a, cfg, node);
  return exit_code;
}
