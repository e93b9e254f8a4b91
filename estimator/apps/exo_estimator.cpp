// exo_estimator: the online inertial-parameter estimator as an LCM process (docs/estimator.md).
// EXO_STATE + EXO_PLATE_RIGHT/LEFT (sensors only) -> OnlineEstimator -> EXO_ESTIMATE at --publish-hz.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <exoid/common/cli.hpp>
#include <exoid/common/strict_number.hpp>
#include <exoid/lcm/channels.hpp>
#include <fstream>
#include <memory>
#include <string>

#include "estimator_node.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/signal/filters.hpp"

namespace {

using exoid::common::kExitBadInput;
using exoid::common::kExitOk;
using exoid::common::kExitRuntime;
constexpr int kExitIdle = 3;
constexpr int kPollSliceMs = 50;

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
  std::fprintf(stderr, "exo_estimator: error: %s\n", message.c_str());
  return kExitBadInput;
}

// name,prior,estimate,stddev per standard parameter (what `exoid experiment` compares with the batch estimate).
bool writeFinal(const std::string& path, const exoid::Model& model, const Eigen::VectorXd& prior,
                const exoid::EstimatorOutputSample& out, std::string* error) {
  std::ofstream f(path);
  const std::vector<std::string> names = model.paramNames();
  f << "name,prior,estimate,stddev\n";
  f.precision(17);
  for (size_t i = 0; i < names.size(); ++i)
    f << names[i] << ',' << prior[i] << ',' << out.params[i] << ',' << out.param_stddev[i] << '\n';
  f.close();
  if (f.fail()) {
    *error = path + ": cannot write the final estimate";
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace exoid;
  using namespace exoid::estimator;
  namespace common = exoid::common;

  std::string model_path = defaultPath("exo.urdf"), prior_path, url = LcmEndpoint::defaultUrl(), forgetting_name = "none",
              row_weights_text, checkpoint, final_path, effects_path;
  double change_threshold = estimator::OnlineEstimatorOptions{}.change_threshold,
         change_keep = estimator::OnlineEstimatorOptions{}.change_keep;
  double prior_relative = 0.25, cutoff = estimator::OnlineEstimatorOptions{}.cutoff_hz, lambda = 0.9999, block_threshold = 1e-3, excited_gain = 3.0,
         min_excitation = 0.2, publish_hz = 100.0, checkpoint_every_s = 5.0;
  int64_t derivative_half_window = estimator::OnlineEstimatorOptions{}.derivative_half_window,
          gyro_half_window = estimator::OnlineEstimatorOptions{}.gyro_half_window;
  std::string base_rate = "legs";
  int64_t filter_order = estimator::OnlineEstimatorOptions{}.filter_order, forget_every = 100, idle_timeout_ms = 0, consistent_every = 10, consistent_iterations = 30;
  double consistent_tolerance = 2.0, effect_prior_factor = 10.0;
  bool quiet = false;

  CLI::App app{
      "Online estimator of the exoskeleton's inertial and friction parameters: the structural base parameters\n"
      "updated with every 1 kHz sample by recursive weighted least squares (information form, started from the\n"
      "prior), from the sensors only (encoders, joint torque sensors, IMU, force plates), published with their\n"
      "uncertainty, a physical-consistency verdict, an excitation indicator, residual statistics and the\n"
      "generalized-force correction tau_correction for the controller. Documentation: docs/estimator.md.",
      "exo_estimator"};
  common::configureCli(app);
  app.add_option("--model", model_path,
                 "URDF of the robot: the controller's model (tau_correction = K (phi_hat - phi_model))")->type_name("PATH");
  app.add_option("--prior", prior_path, "URDF whose inertials are the prior (default: --model)")->type_name("PATH");
  app.add_option("--prior-uncertainty", prior_relative,
                 "one-sigma relative uncertainty of every prior parameter (zero priors: their kind's scale)")
      ->transform(common::strictNumber(1e-6, 1e3))->type_name("R");
  app.add_option("--cutoff-hz", cutoff,
                 "cutoff of the causal Butterworth applied alike to the regressor rows and the measured\n"
                 "generalized forces (0: none)")
      ->transform(common::strictNumber(0.0, 499.0))->type_name("HZ");
  app.add_option("--filter-order", filter_order,
                 "its order, even: 4 attenuates the twice-differenced encoder and once-differenced gyro\n"
                 "noise in the rows, which biases the estimate (errors in the variables; docs/estimator.md)")
      ->transform(common::strictInteger(2, Biquad::kMaxOrder))
      ->check([](const std::string& s) { return std::stol(s) % 2 == 0 ? std::string() : std::string("must be even"); })
      ->type_name("N");
  app.add_option("--derivative-half-window", derivative_half_window,
                 "joint velocities and accelerations are the slope and curvature of a least-squares quadratic\n"
                 "through the encoders over 2L + 1 ticks (Savitzky-Golay; 1 = central differences); the rows\n"
                 "are then L ticks late. The squared noise of differenced encoders in the regressor's velocity\n"
                 "products is a bias no filter after it removes (docs/estimator.md, \"State\")")
      ->transform(common::strictInteger(1, 500))->type_name("L");
  app.add_option("--gyro-half-window", gyro_half_window,
                 "with --base-rate gyro: the same fit for the gyro's value and slope")
      ->transform(common::strictInteger(1, 500))->type_name("L");
  app.add_option("--base-rate", base_rate,
                 "where the base's angular velocity and acceleration come from: 'legs' (default: the feet stand\n"
                 "flat on the plates, so the base turns as the leg kinematics say; the encoders' precision) or\n"
                 "'gyro' (the IMU; its noise in the angular acceleration biases the CoM height by ~6 mm)")
      ->check(CLI::IsMember({"legs", "gyro"}))->type_name("legs|gyro");
  app.add_option("--forgetting", forgetting_name,
                 "none: exact minimiser of the batch regularised cost; stabilised: every direction's\n"
                 "data decays by --lambda per sample; selective: only the base-parameter axes the\n"
                 "latest block re-informed are forgotten (no windup when the excitation stops)")
      ->check(CLI::IsMember({"none", "stabilised", "selective"}))->type_name("none|stabilised|selective");
  app.add_option("--lambda", lambda, "forgetting factor per sample (memory 1 / (1 - lambda) samples)")
      ->transform(common::strictNumber(0.5, 1.0))->type_name("L");
  app.add_option("--change-threshold", change_threshold,
                 "residual-triggered forgetting: when a coordinate's innovation y - K x, averaged over 0.25 s, exceeds\n"
                 "this many times that average's long-run RMS (10 s), the data the estimate holds are discounted to\n"
                 "--change-keep of their weight and the estimate re-converges (a payload attached, a tool\n"
                 "changed); armed 2 s after the start and after each detection; 0: off (docs/estimator.md,\n"
                 "\"Change detection\")")
      ->transform(common::strictNumber(0.0, 1e9))->type_name("Z");
  app.add_option("--change-keep", change_keep, "fraction of the data's weight kept at a detected change")
      ->transform(common::strictNumber(1e-12, 1.0))->type_name("K");
  app.add_option("--forget-every", forget_every, "selective: samples per forgetting block")
      ->transform(common::strictInteger(1, 1000000))->type_name("N");
  app.add_option("--block-threshold", block_threshold,
                 "selective: a block informs an axis when it adds at least this fraction of the\n"
                 "prior's information on it (and at least what forgetting removes)")
      ->transform(common::strictNumber(1e-12, 1e6))->type_name("F");
  app.add_option("--row-weights", row_weights_text,
                 "WLS-R weights 1/sigma, one per generalized coordinate (base_nx..base_fz, then joints),\n"
                 "separated by spaces, e.g. from `exoid identify`'s summary.json row_weight (default: ones)")
      ->type_name("\"W1 W2 ...\"");
  app.add_option("--excited-gain", excited_gain,
                 "a base parameter counts as excited when the data cut its variance to 1 / (1 + G) of\n"
                 "the prior's")
      ->transform(common::strictNumber(1e-6, 1e12))->type_name("G");
  app.add_option("--min-excitation", min_excitation, "`valid` needs the excited fraction >= this")
      ->transform(common::strictNumber(0.0, 1.0))->type_name("F");
  app.add_option("--consistent-every", consistent_every,
                 "publications between two solves for physically consistent standard parameters that reproduce\n"
                 "the base estimate (log-Cholesky, damped Newton, warm-started; a few ms each); 0: never (the\n"
                 "published parameters are then the prior's conditional mean)")
      ->transform(common::strictInteger(0, 1000000))->type_name("N");
  app.add_option("--consistent-iterations", consistent_iterations, "Newton iterations per consistent solve")
      ->transform(common::strictInteger(1, 10000))->type_name("N");
  app.add_option("--consistent-tolerance", consistent_tolerance,
                 "`consistent` needs the consistent parameters' misfit ratio, sqrt of (B phi - x)^T A (B phi - x)\n"
                 "(A the estimate's information) over the weighted residual cost of the estimate, <= this")
      ->transform(common::strictNumber(0.0, 1e6))->type_name("RHO");
  app.add_option("--effects", effects_path,
                 "sidecar effects.yaml of `exoid diagnose` (docs/diagnose.md): each viscous, coulomb,\n"
                 "stribeck, offset or armature effect becomes an extra estimated parameter (prior 0, one-sigma\n"
                 "--effect-prior-factor x its value) whose column is the diagnosis's signal at the sample's\n"
                 "state; a torque-sensor gain corrects that sensor's torque; tau_correction adds the friction and\n"
                 "offset effects at their estimates (not armature); a time delay is refused (exit 2)")
      ->type_name("FILE");
  app.add_option("--effect-prior-factor", effect_prior_factor,
                 "one-sigma prior of each --effects column = this x |the sidecar's value| (prior mean 0)")
      ->transform(common::strictNumber(1e-3, 1e6))->type_name("F");
  app.add_option("--publish-hz", publish_hz, "EXO_ESTIMATE rate, per 1 kHz of folded samples")
      ->transform(common::strictNumber(0.01, 1000.0))->type_name("HZ");
  app.add_option("--checkpoint", checkpoint,
                 "checkpoint file: restored at start when it exists (refused -> exit 2), written every\n"
                 "--checkpoint-every-s and on exit (PATH.tmp, then renamed)")
      ->type_name("PATH");
  app.add_option("--checkpoint-every-s", checkpoint_every_s, "wall seconds between checkpoints (0: only on exit)")
      ->transform(common::strictNumber(0.0, 1e6))->type_name("S");
  app.add_option("--final", final_path, "on exit, write the last estimate as CSV name,prior,estimate,stddev")
      ->type_name("PATH");
  app.add_option("--lcm-url", url,
                 "LCM URL; udpm URLs must have ttl=0 (added when absent); the default is\n$LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--idle-timeout-ms", idle_timeout_ms, "exit with code 3 when no robot state arrives for N ms (0: wait)")
      ->transform(common::strictInteger(0, 24LL * 3600 * 1000))->type_name("N");
  app.add_flag("--quiet", quiet, "no start-up line on stderr (errors and the summary are still printed)");
  app.footer(
      "channels:\n"
      "  subscribes  EXO_STATE             exoid_lcm.robot_state_t      encoders [rad], torque sensors [N m],\n"
      "                                                                 IMU orientation, gyro, accelerometer\n"
      "              EXO_PLATE_RIGHT/LEFT  exoid_lcm.force_plate_t      force [N], moment [N m] ON the plate\n"
      "  publishes   EXO_ESTIMATE          exoid_lcm.estimator_output_t valid, consistent, counters by reason,\n"
      "                                                                 excitation, parameters and base\n"
      "                                                                 parameters with one-sigma stddev,\n"
      "                                                                 tau_correction [nv], residual RMS [nv]\n"
      "Never reads EXO_TRUTH. Undecodable, non-finite, duplicate and out-of-order messages are rejected and\n"
      "counted; a tick missing a message is skipped (counted as missing).\n"
      "\n"
      "exit codes:\n"
      "  0  stopped by SIGINT/SIGTERM (checkpoint and --final written)\n"
      "  1  LCM failure, or the checkpoint / --final could not be written at exit\n"
      "  2  bad input: option, URDF, prior, row weights, effects sidecar (missing, malformed, unknown joint\n"
      "     or kind, a delay), or a checkpoint that does not belong to this estimator (other effects included)\n"
      "  3  no robot state for --idle-timeout-ms");
  if (const int code = common::parseCli(app, argc, argv); code >= 0) return code;

  Model model, prior_model;
  std::string err;
  if (!buildModelFromUrdfFile(model_path, true, model, &err)) return badInput("--model " + model_path + ": " + err);
  Eigen::VectorXd prior = model.phi;
  if (!prior_path.empty()) {
    if (!buildModelFromUrdfFile(prior_path, true, prior_model, &err)) return badInput("--prior " + prior_path + ": " + err);
    if (prior_model.paramNames() != model.paramNames())
      return badInput("--prior " + prior_path + ": its links and joints differ from --model's");
    prior = prior_model.phi;
  }
  OnlineEstimatorOptions opt;
  opt.cutoff_hz = cutoff;
  opt.filter_order = static_cast<int>(filter_order);
  opt.derivative_half_window = static_cast<int>(derivative_half_window);
  opt.gyro_half_window = static_cast<int>(gyro_half_window);
  opt.base_rate_from_legs = base_rate == "legs";
  opt.prior_relative = prior_relative;
  parseForgetting(forgetting_name, opt.forgetting);
  opt.lambda = lambda;
  opt.change_threshold = change_threshold;
  opt.change_keep = change_keep;
  opt.forget_every = static_cast<int>(forget_every);
  opt.block_threshold = block_threshold;
  opt.excited_gain = excited_gain;
  opt.min_excitation = min_excitation;
  opt.consistent_every = static_cast<int>(consistent_every);
  opt.consistent_iterations = static_cast<int>(consistent_iterations);
  opt.consistent_tolerance = consistent_tolerance;
  if (!row_weights_text.empty()) {
    if (!common::parseDoubleList(row_weights_text, model.nv, opt.row_weight, &err))
      return badInput("--row-weights: " + err + " (" + std::to_string(model.nv) + " numbers expected)");
    for (double w : opt.row_weight)
      if (!(w > 0.0)) return badInput("--row-weights: every weight must be > 0");
  }
  if (!effects_path.empty()) {
    if (!readEffects(effects_path, model, opt.effects, &err)) return badInput("--effects " + err);
    opt.effect_prior_factor = effect_prior_factor;
  }
  const BaseParameters base = computeBaseParameters(model);
  OnlineEstimator est(model, base, prior, opt);
  if (!est.ok()) return badInput(est.error());
  // A checkpoint that exists must be this estimator's: refused before anything starts (never silently
  // started over).
  bool resumed = false;
  if (std::error_code ec; !checkpoint.empty() && std::filesystem::exists(checkpoint, ec)) {
    if (!est.loadCheckpoint(checkpoint, &err)) return badInput("--checkpoint: " + err);
    resumed = true;
  }
  std::string normalised;
  if (!LcmEndpoint::checkUrl(url, &normalised, &err)) return badInput("--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> lcm = LcmEndpoint::create(normalised, &err);
  if (!lcm) {
    std::fprintf(stderr, "exo_estimator: LCM: %s\n", err.c_str());
    return kExitRuntime;
  }
  NodeOptions nopt;
  nopt.publish_every = std::max(1, static_cast<int>(std::lround(1000.0 / publish_hz)));
  nopt.checkpoint = checkpoint;
  nopt.checkpoint_every_s = checkpoint_every_s;
  EstimatorNode node(*lcm, model, est, nopt);
  if (!node.ok()) {
    std::fprintf(stderr, "exo_estimator: LCM: %s\n", node.error().c_str());
    return kExitRuntime;
  }

  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  if (!quiet)
    std::fprintf(stderr, "exo_estimator: %d base parameters%s, forgetting %s, state fit over %d ticks (base rate from the %s), cutoff %.1f Hz (order %d), EXO_ESTIMATE every %d samples%s, on %s\n",
                 base.rank,
                 effects_path.empty() ? ""
                                      : (" + " + std::to_string(est.effectColumnCount()) + " effect columns of " + effects_path).c_str(),
                 forgettingName(opt.forgetting), 2 * opt.derivative_half_window + 1, base_rate.c_str(),
                 cutoff, opt.filter_order, nopt.publish_every,
                 resumed ? (", resumed from " + checkpoint + " at tick " + std::to_string(est.rlsData().last_tick)).c_str() : "",
                 lcm->url().c_str());

  int exit_code = kExitOk;
  const char* outcome = "stopped";
  while (!g_stop) {
    const auto idle = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() -
                                                                            node.lastState()).count();
    if (idle_timeout_ms > 0 && idle >= idle_timeout_ms) {
      std::fprintf(stderr, "exo_estimator: no %s for %lld ms, exiting\n", channels::kState, static_cast<long long>(idle));
      exit_code = kExitIdle;
      outcome = "idle timeout";
      break;
    }
    if (node.poll(kPollSliceMs, &err) < 0) {
      std::fprintf(stderr, "exo_estimator: LCM: %s\n", err.c_str());
      exit_code = kExitRuntime;
      outcome = "lcm error";
      break;
    }
  }
  if (!node.writeCheckpoint(&err)) {
    std::fprintf(stderr, "exo_estimator: error: %s\n", err.c_str());
    if (exit_code == kExitOk) exit_code = kExitRuntime;
  }
  EstimatorOutputSample last = node.lastOutput();
  if (!final_path.empty()) {
    if (node.publications() == 0) {  // nothing published yet: the estimate as it stands (the prior if no data)
      est.prepare(last);
      est.publish(last);
    }
    if (!writeFinal(final_path, model, prior, last, &err)) {
      std::fprintf(stderr, "exo_estimator: error: %s\n", err.c_str());
      if (exit_code == kExitOk) exit_code = kExitRuntime;
    }
  }
  const MessageGate& gate = node.gate();
  std::printf("exo_estimator: %s: samples %lld, rejected %llu (non-finite %llu, malformed %llu, duplicate %llu, "
              "out of order %llu), missing %lld, publications %ld, publish errors %ld, checkpoints %ld (errors %ld), "
              "valid publications %ld, consistent solves %ld, last: tick %lld valid %d consistent %d excitation %.2f "
              "misfit ratio %.4g, changes detected %ld (last at tick %ld, largest statistic %.3g)\n",
              outcome, static_cast<long long>(est.rlsData().accepted),
              static_cast<unsigned long long>(gate.rejectedTotal() + est.rejected(InputStatus::NonFinite) +
                                              est.rejected(InputStatus::Duplicate) + est.rejected(InputStatus::OutOfOrder) +
                                              est.rejected(InputStatus::Malformed)),
              static_cast<unsigned long long>(gate.rejected(RejectReason::NonFinite) + est.rejected(InputStatus::NonFinite)),
              static_cast<unsigned long long>(gate.rejected(RejectReason::Malformed) + est.rejected(InputStatus::Malformed)),
              static_cast<unsigned long long>(gate.rejected(RejectReason::Duplicate) + est.rejected(InputStatus::Duplicate)),
              static_cast<unsigned long long>(gate.rejected(RejectReason::OutOfOrder) + est.rejected(InputStatus::OutOfOrder)),
              static_cast<long long>(est.rlsData().missing), node.publications(), node.publishErrors(),
              node.checkpointsWritten(), node.checkpointErrors(), node.validPublications(), est.reconciles(),
              static_cast<long long>(last.tick), last.valid ? 1 : 0, last.consistent ? 1 : 0, last.excitation,
              est.misfitRatio(), est.changesDetected(), est.lastChangeTick(),
              est.largestChangeStatistic());
  std::fflush(stdout);
  return exit_code;
}
