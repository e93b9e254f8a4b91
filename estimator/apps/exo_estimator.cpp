// exo_estimator: the online inertial-parameter estimator as an LCM process (docs/estimator.md).
// EXO_STATE + EXO_PLATE_RIGHT/LEFT (sensors only) -> OnlineEstimator -> EXO_ESTIMATE at --publish-hz. Thin: options ->
// the estimator (OnlineEstimator) -> EstimatorNode::run (estimator_node.hpp) -> checkpoint, --final, the summary.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <exoid/common/cli.hpp>
#include <exoid/common/process_main.hpp>
#include <exoid/common/strict_number.hpp>
#include <exoid/lcm/channels.hpp>
#include <fstream>
#include <memory>
#include <string>

#include "estimator_node.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/sole_placement.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/signal/filters.hpp"

namespace {

using exoid::common::kExitOk;
using exoid::common::kExitRuntime;
constexpr int kExitIdle = 3;
constexpr char kProg[] = "exo_estimator";

constexpr char kDescription[] =
    "Online estimator of the exoskeleton's inertial and friction parameters: the structural base parameters\n"
    "updated with every 1 kHz sample by recursive weighted least squares (information form, started from the\n"
    "prior), from the sensors only (encoders, joint torque sensors, IMU, force plates), published with their\n"
    "uncertainty, a physical-consistency verdict, an excitation indicator, residual statistics and the\n"
    "generalized-force correction tau_correction for the controller. Documentation: docs/estimator.md.";

constexpr char kFooter[] =
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
    "  3  no robot state for --idle-timeout-ms";

/// exo_estimator's options.
struct Args {
  using Defaults = exoid::estimator::OnlineEstimatorOptions;
  std::string model_path = exoid::common::configPath("exo.urdf"), prior_path, url = exoid::LcmEndpoint::defaultUrl(),
              forgetting_name = "none", row_weighting_name, row_weights_text, checkpoint, final_path, effects_path;
  double change_threshold = Defaults{}.change_threshold, change_keep = Defaults{}.change_keep;
  double prior_relative = 0.25, cutoff = Defaults{}.cutoff_hz, lambda = 0.9999, block_threshold = 1e-3, excited_gain = 3.0,
         min_excitation = Defaults{}.min_excitation, publish_hz = 100.0, checkpoint_every_s = 5.0;
  int64_t derivative_half_window = Defaults{}.derivative_half_window, gyro_half_window = Defaults{}.gyro_half_window;
  std::string base_rate = "legs";
  int64_t filter_order = Defaults{}.filter_order, forget_every = 100, idle_timeout_ms = 0, consistent_every = 10,
          consistent_iterations = 30;
  double consistent_tolerance = 2.0, effect_prior_factor = 10.0, sensor_offset_sigma = Defaults{}.sensor_offset_sigma,
         sensor_gain_sigma = Defaults{}.sensor_gain_sigma;
  bool quiet = false, base_body_moves = false;
  std::array<Eigen::Vector3d, 2> sole_on_plate{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  // --sole-on-plate
};

/// The model, the prior and the state pipeline (filter, derivatives, base rate).
void addModelOptions(CLI::App& app, Args& a) {
  namespace common = exoid::common;
  using exoid::Biquad;
  app.add_option("--model", a.model_path,
                 "URDF of the robot: the controller's model (tau_correction = K (phi_hat - phi_model))")->type_name("PATH");
  app.add_option("--prior", a.prior_path, "URDF whose inertials are the prior (default: --model)")->type_name("PATH");
  app.add_option("--prior-uncertainty", a.prior_relative,
                 "one-sigma relative uncertainty of every prior parameter (zero priors: their kind's scale)")
      ->transform(common::strictNumber(1e-6, 1e3))->type_name("R");
  app.add_option("--cutoff-hz", a.cutoff,
                 "cutoff of the causal Butterworth applied alike to the regressor rows and the measured\n"
                 "generalized forces (0: none)")
      ->transform(common::strictNumber(0.0, 499.0))->type_name("HZ");
  app.add_option("--filter-order", a.filter_order,
                 "its order, even: 4 attenuates the twice-differenced encoder and once-differenced gyro\n"
                 "noise in the rows, which biases the estimate (errors in the variables; docs/estimator.md)")
      ->transform(common::strictInteger(2, Biquad::kMaxOrder))
      ->check([](const std::string& s) { return std::stol(s) % 2 == 0 ? std::string() : std::string("must be even"); })
      ->type_name("N");
  app.add_option("--derivative-half-window", a.derivative_half_window,
                 "joint velocities and accelerations are the slope and curvature of a least-squares quadratic\n"
                 "through the encoders over 2L + 1 ticks (Savitzky-Golay; 1 = central differences); the rows\n"
                 "are then L ticks late. The squared noise of differenced encoders in the regressor's velocity\n"
                 "products is a bias no filter after it removes (docs/estimator.md, \"State\")")
      ->transform(common::strictInteger(1, 500))->type_name("L");
  app.add_option("--gyro-half-window", a.gyro_half_window,
                 "with --base-rate gyro: the same fit for the gyro's value and slope")
      ->transform(common::strictInteger(1, 500))->type_name("L");
  app.add_option("--base-rate", a.base_rate,
                 "where the base's angular velocity and acceleration come from: 'legs' (default: the feet stand\n"
                 "flat on the plates, so the base turns as the leg kinematics say; the encoders' precision) or\n"
                 "'gyro' (the IMU; its noise in the angular acceleration biases the CoM height by ~6 mm)")
      ->check(CLI::IsMember({"legs", "gyro"}))->type_name("legs|gyro");
}

/// The recursive least squares: forgetting, change detection, weights, excitation, consistency, effects.
void addEstimatorOptions(CLI::App& app, Args& a) {
  namespace common = exoid::common;
  app.add_option("--forgetting", a.forgetting_name,
                 "none: exact minimiser of the batch regularised cost; stabilised: every direction's\n"
                 "data decays by --lambda per sample; selective: only the base-parameter axes the\n"
                 "latest block re-informed are forgotten (no windup when the excitation stops)")
      ->check(CLI::IsMember({"none", "stabilised", "selective"}))->type_name("none|stabilised|selective");
  app.add_option("--lambda", a.lambda, "forgetting factor per sample (memory 1 / (1 - lambda) samples)")
      ->transform(common::strictNumber(0.5, 1.0))->type_name("L");
  app.add_option("--change-threshold", a.change_threshold,
                 "residual-triggered forgetting: when a coordinate's innovation y - K x, averaged over 0.25 s, exceeds\n"
                 "this many times that average's long-run RMS (10 s), the data the estimate holds are discounted to\n"
                 "--change-keep of their weight and the estimate re-converges (a payload attached, a tool\n"
                 "changed); armed 2 s after the start and after each detection; 0: off (docs/estimator.md,\n"
                 "\"Change detection\")")
      ->transform(common::strictNumber(0.0, 1e9))->type_name("Z");
  app.add_option("--change-keep", a.change_keep, "fraction of the data's weight kept at a detected change")
      ->transform(common::strictNumber(1e-12, 1.0))->type_name("K");
  app.add_option("--forget-every", a.forget_every, "selective: samples per forgetting block")
      ->transform(common::strictInteger(1, 1000000))->type_name("N");
  app.add_option("--block-threshold", a.block_threshold,
                 "selective: a block informs an axis when it adds at least this fraction of the\n"
                 "prior's information on it (and at least what forgetting removes)")
      ->transform(common::strictNumber(1e-12, 1e6))->type_name("F");
  app.add_option("--row-weighting", a.row_weighting_name,
                 "wls-r-corr: each row weighted 1 / (sigma_c sqrt(T_c)), the residual RMS and correlation\n"
                 "time of a first, full-weight (WLS-R) fit of the same data, re-estimated at every\n"
                 "publication (the data count as their independent samples);\n"
                 "wls-r: the thesis's 1 / sigma_c (every 1 kHz row counts; where the residual is model\n"
                 "error it biases the CoM height, docs/estimator.md \"Row weights\"); fixed: --row-weights\n"
                 "throughout (what --forgetting selective always does). Default: wls-r-corr")
      ->check(CLI::IsMember({"wls-r-corr", "wls-r", "fixed"}))->type_name("wls-r-corr|wls-r|fixed");
  app.add_option("--row-weights", a.row_weights_text,
                 "row weights 1/sigma, one per generalized coordinate (base_nx..base_fz, then joints),\n"
                 "separated by spaces, e.g. from `exoid identify`'s summary.json row_weight: fixed\n"
                 "(--row-weighting fixed is implied), or where --row-weighting wls-r / wls-r-corr starts\n"
                 "(default: ones)")
      ->type_name("\"W1 W2 ...\"");
  app.add_option("--excited-gain", a.excited_gain,
                 "a base parameter counts as excited when the data cut its variance to 1 / (1 + G) of\n"
                 "the prior's")
      ->transform(common::strictNumber(1e-6, 1e12))->type_name("G");
  app.add_option("--min-excitation", a.min_excitation,
                 "`valid` needs the excited fraction >= this (0: no such gate; the controller's trust rule\n"
                 "weighs each quantity it uses by its own uncertainty). `valid` always needs 2 s of data")
      ->transform(common::strictNumber(0.0, 1.0))->type_name("F");
  app.add_option("--consistent-every", a.consistent_every,
                 "publications between two solves for physically consistent standard parameters that reproduce\n"
                 "the base estimate (log-Cholesky, damped Newton, warm-started; a few ms each); 0: never (the\n"
                 "published parameters are then the prior's conditional mean)")
      ->transform(common::strictInteger(0, 1000000))->type_name("N");
  app.add_option("--consistent-iterations", a.consistent_iterations, "Newton iterations per consistent solve")
      ->transform(common::strictInteger(1, 10000))->type_name("N");
  app.add_option("--consistent-tolerance", a.consistent_tolerance,
                 "`consistent` needs the consistent parameters' misfit ratio, sqrt of (B phi - x)^T A (B phi - x)\n"
                 "(A the estimate's information) over the weighted residual cost of the estimate, <= this")
      ->transform(common::strictNumber(0.0, 1e6))->type_name("RHO");
  app.add_option("--effects", a.effects_path,
                 "sidecar effects.yaml of `exoid diagnose` (docs/diagnose.md): each viscous, coulomb,\n"
                 "stribeck, offset or armature effect becomes an extra estimated parameter (prior 0, one-sigma\n"
                 "--effect-prior-factor x its value) whose column is the diagnosis's signal at the sample's\n"
                 "state; a torque-sensor gain corrects that sensor's torque; tau_correction adds the friction and\n"
                 "offset effects at their estimates (not armature); a time delay is refused (exit 2)")
      ->type_name("FILE");
  app.add_option("--effect-prior-factor", a.effect_prior_factor,
                 "one-sigma prior of each --effects column = this x |the sidecar's value| (prior mean 0)")
      ->transform(common::strictNumber(1e-3, 1e6))->type_name("F");
  app.add_option("--sensor-offset-sigma", a.sensor_offset_sigma,
                 "one estimated offset per joint torque sensor (prior 0, this one-sigma, N m; never fed forward):\n"
                 "an offset the model lacks would otherwise bias the CoM the estimate claims; 0: none")
      ->capture_default_str()->transform(common::strictNumber(0.0, 1e6))->type_name("NM");
  app.add_option("--sensor-gain-sigma", a.sensor_gain_sigma,
                 "one estimated gain error per joint torque sensor (its column: the measured torque; prior 0, this\n"
                 "one-sigma, relative; never fed forward); 0: none")
      ->capture_default_str()->transform(common::strictNumber(0.0, 10.0))->type_name("REL");
  app.add_flag("--base-body-moves", a.base_body_moves,
               "a body moves on the base link on its own (a wearer's trunk on the pelvis): its lag biases the\n"
               "CoM height the base rows give, so the published height uncertainty keeps the prior's (the base\n"
               "link's mcz, one sigma) and the controller leaves the height at the prior's while it takes the\n"
               "horizontal CoM (exoid experiment sets it for a scenario with a wearer)");
  app.add_option_function<std::vector<std::string>>(
         "--sole-on-plate",
         [&a](const std::vector<std::string>& specs) {
           for (const std::string& spec : specs) {
             std::string why;
             if (!exoid::estimator::parseSoleOnPlate(spec, a.sole_on_plate, &why)) throw CLI::ValidationError(why);
           }
         },
         "where a sole stands on its plate, SIDE:X,Y[,Z] (SIDE right or left; the sole frame's origin\n"
         "minus the plate's reported sensor origin, lab axes, m; once per side); without it each sole\n"
         "is centred on its plate. The base position and every base moment row rest on it: a common\n"
         "1 cm left undeclared moves the estimated CoM by 1 cm, and the fed-back robot's with it\n"
         "(docs/estimator.md \"Where the soles stand\")")
      ->type_name("SPEC");
}

/// Publication, checkpoint, final estimate, LCM, idle timeout.
void addNodeOptions(CLI::App& app, Args& a) {
  namespace common = exoid::common;
  app.add_option("--publish-hz", a.publish_hz, "EXO_ESTIMATE rate, per 1 kHz of folded samples")
      ->transform(common::strictNumber(0.01, 1000.0))->type_name("HZ");
  app.add_option("--checkpoint", a.checkpoint,
                 "checkpoint file: restored at start when it exists (refused -> exit 2), written every\n"
                 "--checkpoint-every-s and on exit (PATH.tmp, then renamed)")
      ->type_name("PATH");
  app.add_option("--checkpoint-every-s", a.checkpoint_every_s, "wall seconds between checkpoints (0: only on exit)")
      ->transform(common::strictNumber(0.0, 1e6))->type_name("S");
  app.add_option("--final", a.final_path, "on exit, write the last estimate as CSV name,prior,estimate,stddev")
      ->type_name("PATH");
  app.add_option("--lcm-url", a.url,
                 "LCM URL; udpm URLs must have ttl=0 (added when absent); the default is\n$LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--idle-timeout-ms", a.idle_timeout_ms, "exit with code 3 when no robot state arrives for N ms (0: wait)")
      ->transform(common::strictInteger(0, 24LL * 3600 * 1000))->type_name("N");
  app.add_flag("--quiet", a.quiet, "no start-up line on stderr (errors and the summary are still printed)");
}

/// The prior: --prior's inertials, or the model's.
bool readPriorModel(const Args& a, const exoid::Model& model, Eigen::VectorXd& prior, std::string* err) {
  prior = model.phi;
  if (a.prior_path.empty()) return true;
  exoid::Model prior_model;
  if (!exoid::buildModelFromUrdfFile(a.prior_path, true, prior_model, err))
    return *err = "--prior " + a.prior_path + ": " + *err, false;
  if (prior_model.paramNames() != model.paramNames())
    return *err = "--prior " + a.prior_path + ": its links and joints differ from --model's", false;
  prior = prior_model.phi;
  return true;
}

/// The OnlineEstimatorOptions of the options; false with *err (row weights, effects sidecar).
bool estimatorOptions(const Args& a, const exoid::Model& model, exoid::estimator::OnlineEstimatorOptions& opt,
                      std::string* err) {
  using namespace exoid::estimator;
  opt.cutoff_hz = a.cutoff;
  opt.filter_order = static_cast<int>(a.filter_order);
  opt.derivative_half_window = static_cast<int>(a.derivative_half_window);
  opt.gyro_half_window = static_cast<int>(a.gyro_half_window);
  opt.base_rate_from_legs = a.base_rate == "legs";
  opt.prior_relative = a.prior_relative;
  parseForgetting(a.forgetting_name, opt.forgetting);
  opt.lambda = a.lambda;
  opt.change_threshold = a.change_threshold;
  opt.change_keep = a.change_keep;
  opt.forget_every = static_cast<int>(a.forget_every);
  opt.block_threshold = a.block_threshold;
  opt.excited_gain = a.excited_gain;
  opt.min_excitation = a.min_excitation;
  opt.consistent_every = static_cast<int>(a.consistent_every);
  opt.consistent_iterations = static_cast<int>(a.consistent_iterations);
  opt.consistent_tolerance = a.consistent_tolerance;
  if (a.row_weighting_name.empty() && !a.row_weights_text.empty()) opt.row_weighting = RowWeighting::Fixed;
  if (!a.row_weighting_name.empty()) {
    parseRowWeighting(a.row_weighting_name, opt.row_weighting);
    if (opt.forgetting == Forgetting::Selective && opt.row_weighting != RowWeighting::Fixed)
      return *err = "--row-weighting " + a.row_weighting_name + ": selective forgetting keeps the weights fixed", false;
  }
  if (!a.row_weights_text.empty()) {
    if (!exoid::common::parseDoubleList(a.row_weights_text, model.nv, opt.row_weight, err))
      return *err = "--row-weights: " + *err + " (" + std::to_string(model.nv) + " numbers expected)", false;
    for (double w : opt.row_weight)
      if (!(w > 0.0)) return *err = "--row-weights: every weight must be > 0", false;
  }
  opt.sensor_offset_sigma = a.sensor_offset_sigma;
  opt.sensor_gain_sigma = a.sensor_gain_sigma;
  opt.base_body_moves = a.base_body_moves;
  opt.sole_on_plate = a.sole_on_plate;
  if (!a.effects_path.empty()) {
    if (!readEffects(a.effects_path, model, opt.effects, err)) return *err = "--effects " + *err, false;
    opt.effect_prior_factor = a.effect_prior_factor;
  }
  return true;
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

/// At exit: the checkpoint and --final (the estimate as it stands when nothing was published: the prior if no
/// data); a failure turns exit 0 into 1.
int finish(const Args& a, const exoid::Model& model, const Eigen::VectorXd& prior, exoid::estimator::OnlineEstimator& est,
           exoid::estimator::EstimatorNode& node, exoid::EstimatorOutputSample& last, int exit_code) {
  std::string err;
  if (!node.writeCheckpoint(&err)) {
    std::fprintf(stderr, "exo_estimator: error: %s\n", err.c_str());
    if (exit_code == kExitOk) exit_code = kExitRuntime;
  }
  last = node.lastOutput();
  if (!a.final_path.empty()) {
    if (node.publications() == 0) {  // nothing published yet: the estimate as it stands (the prior if no data)
      est.sizeOutput(last);
      est.fillOutput(last);
    }
    if (!writeFinal(a.final_path, model, prior, last, &err)) {
      std::fprintf(stderr, "exo_estimator: error: %s\n", err.c_str());
      if (exit_code == kExitOk) exit_code = kExitRuntime;
    }
  }
  return exit_code;
}

void printSummary(const char* outcome, const exoid::estimator::OnlineEstimator& est,
                  const exoid::estimator::EstimatorNode& node, const exoid::EstimatorOutputSample& last) {
  using namespace exoid;
  using namespace exoid::estimator;
  const MessageGate& gate = node.gate();
  std::printf("exo_estimator: %s: samples %lld, rejected %llu (non-finite %llu, malformed %llu, duplicate %llu, "
              "out of order %llu), missing %lld, publications %ld, publish errors %ld, checkpoints %ld (errors %ld), "
              "valid publications %ld, consistent solves %ld (waited for %ld: %.2f s, longest %.1f ms), last: tick %lld valid %d consistent %d excitation %.2f "
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
              node.checkpointsWritten(), node.checkpointErrors(), node.validPublications(), est.reconciles(), node.reconcileWaits(), node.reconcileWaitTotal(), 1e3 * node.reconcileWaitMax(),
              static_cast<long long>(last.tick), last.valid ? 1 : 0, last.consistent ? 1 : 0, last.excitation,
              est.misfitRatio(), est.changesDetected(), est.lastChangeTick(),
              est.largestChangeStatistic());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace exoid;
  using namespace exoid::estimator;
  CLI::App app{kDescription, kProg};
  common::configureCli(app);
  Args a;
  addModelOptions(app, a);
  addEstimatorOptions(app, a);
  addNodeOptions(app, a);
  app.footer(kFooter);
  if (const int code = common::parseCli(app, argc, argv); code >= 0) return code;
  Model model;
  Eigen::VectorXd prior;
  OnlineEstimatorOptions opt;
  std::string err;
  if (!buildModelFromUrdfFile(a.model_path, true, model, &err))
    return common::badInput(kProg, "--model " + a.model_path + ": " + err);
  if (!readPriorModel(a, model, prior, &err) || !estimatorOptions(a, model, opt, &err)) return common::badInput(kProg, err);
  const BaseParameters base = computeBaseParameters(model);
  OnlineEstimator est(model, base, prior, opt);
  if (!est.ok()) return common::badInput(kProg, est.error());
  // A checkpoint that exists must be this estimator's: refused before anything starts (never silently
  // started over).
  bool resumed = false;
  if (std::error_code ec; !a.checkpoint.empty() && std::filesystem::exists(a.checkpoint, ec)) {
    if (!est.loadCheckpoint(a.checkpoint, &err)) return common::badInput(kProg, "--checkpoint: " + err);
    resumed = true;
  }
  std::string normalised;
  if (!LcmEndpoint::checkUrl(a.url, &normalised, &err)) return common::badInput(kProg, "--lcm-url: " + err);
  std::unique_ptr<LcmEndpoint> lcm = LcmEndpoint::create(normalised, &err);
  if (!lcm) return std::fprintf(stderr, "exo_estimator: LCM: %s\n", err.c_str()), kExitRuntime;
  NodeOptions nopt;
  nopt.publish_every = std::max(1, static_cast<int>(std::lround(1000.0 / a.publish_hz)));
  nopt.checkpoint = a.checkpoint;
  nopt.checkpoint_every_s = a.checkpoint_every_s;
  EstimatorNode node(*lcm, model, est, nopt);
  if (!node.ok()) return std::fprintf(stderr, "exo_estimator: LCM: %s\n", node.error().c_str()), kExitRuntime;
  const volatile std::sig_atomic_t* stop = common::installStopSignals();
  if (!a.quiet)
    std::fprintf(stderr, "exo_estimator: %d base parameters%s + %d torque-sensor columns (offsets, gains), forgetting %s, row weighting %s, state fit over %d ticks (base rate from the %s), cutoff %.1f Hz (order %d), EXO_ESTIMATE every %d samples%s, on %s\n",
                 base.rank,
                 a.effects_path.empty() ? ""
                                        : (" + " + std::to_string(est.effectColumnCount()) + " effect columns of " + a.effects_path).c_str(),
                 est.sensorOffsetColumnCount(),
                 forgettingName(opt.forgetting), rowWeightingName(est.rowWeighting()), 2 * opt.derivative_half_window + 1, a.base_rate.c_str(),
                 a.cutoff, opt.filter_order, nopt.publish_every,
                 resumed ? (", resumed from " + a.checkpoint + " at tick " + std::to_string(est.rlsData().last_tick)).c_str() : "",
                 lcm->url().c_str());
  const EstimatorNode::Outcome outcome = node.run(a.idle_timeout_ms, stop);
  EstimatorOutputSample last;
  const int exit_code = finish(a, model, prior, est, node, last,
                               outcome == EstimatorNode::Outcome::Stopped ? kExitOk
                               : outcome == EstimatorNode::Outcome::IdleTimeout ? kExitIdle : kExitRuntime);
  printSummary(outcome == EstimatorNode::Outcome::Stopped       ? "stopped"
               : outcome == EstimatorNode::Outcome::IdleTimeout ? "idle timeout"
                                                                : "lcm error",
               est, node, last);
  return exit_code;
}
