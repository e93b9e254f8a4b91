// exoid diagnose: what the rigid-body model leaves out, found from the residual (docs/diagnose.md). Options -> the
// segments of the input files -> estimator::diagnose (and the online comparison) -> the writers (diagnose_report.hpp).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <set>

#include "commands.hpp"
#include "base_signal_options.hpp"
#include "diagnose_report.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"

namespace exoid::cli {

namespace est = exoid::estimator;
namespace fs = std::filesystem;

namespace cmd_diagnose {  // this file's own names: the exoid binary is a unity build
constexpr char kDescription[] =
    "Finds what the declared rigid-body model leaves out (docs/diagnose.md). Identifies the declared model on\n"
    "the training data, analyses the residual per joint (size against the noise, autocorrelation, correlation\n"
    "with candidate signals), tests a library of candidate effects per joint (viscous, Coulomb with a smooth\n"
    "sign, Stribeck, constant offset, armature, torque-sensor gain error, time delay, joint elasticity: a linear\n"
    "and an exponential spring about the mean angle, a neighbouring joint's angle; opt-in, an exponential of the\n"
    "joint's and a neighbour's angles) by forward selection with one-sided paired tests over held-out time-block\n"
    "folds (t-test and signed-rank; Bonferroni over the candidates of each step: false-alarm rate <= --alpha per\n"
    "data set; where the folds do not tell a finding from another kind of effect on its joint, both are named:\n"
    "\"...; or <kind> <value>: the data do not tell the two apart\"; beside a coupling that is not significant with\n"
    "the other joints' candidates in the model, the strongest effect on the joint whose angle it reads, which the\n"
    "identified link parameters carry into its row), re-identifies with the\n"
    "accepted effects and reports the torque RMSE before and after on the validation data, per joint and pooled.\n"
    "A last stage asks whether what remains of each joint's residual is predictable from the state at all (sparse\n"
    "regression over a dictionary of the state, gradient-boosted trees; held-out time blocks, Bonferroni over the\n"
    "joints) and names the state variables. With a floating base, a stage asks whether an unmeasured body moves on\n"
    "the base on a spring (a wearer's trunk): the base rows' residual against a resonant response to the base's own\n"
    "motion, beyond a rigid null, held out.\n\n"
    "Writes to --out: report.md (findings in words, tables, plots), summary.json, rmse.csv, candidates.csv,\n"
    "residual_<segment>.csv, effects.yaml (the sidecar of the augmented model) next to a copy of the URDF,\n"
    "plot_diagnose.py and its PNGs (rmse.png, residual_vs_signal.png, spectra.png; python3 with matplotlib);\n"
    "the last stage's predictability.csv, predictability_series.csv, plot_predictability.py, predictability.png;\n"
    "the base rows' unmeasured_body.csv, unmeasured_body_series.csv, plot_unmeasured_body.py, unmeasured_body.png.\n\n"
    "exit codes: 0 success, 2 bad input or data that cannot identify the declared model (one line on stderr),\n"
    "            3 the log is damaged (damaged stretches, a cut-off tail, rejected events; nothing written; see\n"
    "            --allow-partial).";

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid diagnose: error: %s\n", msg.c_str());
  return 2;
}

// --declared-model: the same kinematic tree as --model (names, parents, joint placements and axes), else why not.
std::string differentTree(const Model& a, const Model& b) {
  if (a.nbodies != b.nbodies || a.njoints != b.njoints) return "another number of links or joints";
  for (int i = 0; i < a.nbodies; ++i) {
    if (a.body_names[i] != b.body_names[i] || a.parent[i] != b.parent[i]) return "link '" + a.body_names[i] + "' differs";
    if ((a.tree_position[i] - b.tree_position[i]).norm() > 1e-9)
      return "the joint origin of link '" + a.body_names[i] + "' differs";
    if ((a.tree_rotation[i] - b.tree_rotation[i]).norm() > 1e-9 || (a.joint_axis[i] - b.joint_axis[i]).norm() > 1e-9)
      return "the joint frame or axis of link '" + a.body_names[i] + "' differs";
  }
  for (int j = 0; j < a.njoints; ++j)
    if (a.joint_names[j] != b.joint_names[j]) return "joint '" + a.joint_names[j] + "' differs";
  return "";
}

// The command line: what to read and write (DiagnoseInputs) and how (DiagnoseOptions plus the intake's choices).
struct DiagnoseArgs {
  DiagnoseInputs in;
  est::DiagnoseOptions opt;
  std::vector<std::string> kinds;
  std::string pipeline = "sensors", filter_mode = "parallel";
  // Sensors pipeline, floating base: the IMU's orientation, gyro and accelerometer, not identify's legs and plates.
  // Measured on the 16 diagnosis scenarios (docs/diagnose.md "The base's signals"): the legs' and plates' signals
  // lower the clean held-out floor 3.4x but name processing artefacts as effects (a "body moving on the base" at
  // 4 Hz with the legs' acceleration, a "biarticular elasticity" on an ankle with the plates' orientation).
  tools::BaseSignals base_signals{"imu", "gyro", "accelerometer", 5.0};
  bool floating = false, skip_bad = false, allow_partial = false, no_predictability = false, no_unmeasured_body = false;
  double gravity = 9.81, cutoff = -1.0;
  int folds = est::DiagnoseOptions{}.folds, max_effects = est::DiagnoseOptions{}.max_effects;
  size_t row_memory_mb = 2048;
  CLI::Option* width_opt = nullptr;
};

// The options of `exoid diagnose` (its --help), into a.
void addDiagnoseOptions(CLI::App& app, DiagnoseArgs& a) {
  app.add_option("--model", a.in.model_path, "robot URDF")->required();
  app.add_flag("--floating-base", a.floating, "the root link is on a 6-dof free joint (default: fixed to the world)");
  app.add_option("--train", a.in.train_files, "training data: measured CSVs (docs/identification.md) and/or LCM logs of "
                 "`exoid experiment`")->required();
  app.add_option("--validate", a.in.val_files, "held-out data for the before/after report (same kinds); without it the "
                 "training data are reported and only the fold test guards the choice");
  app.add_option("--calibration", a.in.calib_files, "more training data: LCM logs of `exoid calibrate` (the pelvis held in a "
                 "harness, the legs swinging; needs --floating-base). Their base rows are left out (the harness's wrench "
                 "is not measured) and the base is taken at rest. Swinging legs separate a constant torque offset from "
                 "the links' first moments, which balancing data cannot (docs/diagnose.md)")->type_name("LOG");
  app.add_option("--validate-calibration", a.in.val_calib_files, "more held-out data: logs of `exoid calibrate` (another "
                 "--seed), read like --calibration; the before/after figures pool them with --validate")->type_name("LOG");
  app.add_option("--out", a.in.out_dir, "output directory (created)")->required();
  app.add_option("--gravity", a.gravity, "gravity magnitude, m/s^2, along -z of the world / root link")->transform(common::strictNumber(0.0, 100.0));
  app.add_option("--declared", a.in.declared, "declared model: 'rigid' (URDF rigid-body parameters; default) or "
                 "'rigid+friction' (plus fv, fc of every joint)")->check(CLI::IsMember({"rigid", "rigid+friction"}));
  app.add_option("--declared-model", a.in.declared_model_path, "hold the declared rigid-body parameters at this URDF's values "
                 "(e.g. identified.urdf of `exoid identify` on earlier data; the links and joints of --model) instead of "
                 "identifying them: the residual is y - K phi_declared, so a change of the robot since then is a finding; "
                 "with it each link is also tested for a payload (a rigid body fixed to it: mass and CoM; admissible with a mass "
                 "above 3 standard errors and the CoM within --payload-com-bound of the link frame), which an identified "
                 "declared model absorbs. Training and validation rows both become y - K phi_declared (docs/diagnose.md)")
      ->type_name("URDF");
  app.add_option("--payload-com-bound", a.opt.payload_com_bound, "m: an admissible payload's CoM lies within this distance "
                 "of its link frame's origin (default 0.5)")->transform(common::strictNumber(1e-6, 1e3));
  app.add_option("--effects", a.kinds, "candidate kinds to test (default all): viscous coulomb stribeck offset armature gain delay elastic "
                 "elastic_exp elastic_coupled elastic_exp_coupled");
  app.add_option("--alpha", a.opt.alpha, "false-alarm rate per data set (family-wise per selection step; default 0.01)")
      ->transform(common::strictNumber(1e-9, 0.5));
  app.add_option("--folds", a.folds, "time-block folds for the held-out test (default 20)")
      ->transform(common::strictInteger(3, 100));
  app.add_option("--chunk-seconds", a.opt.chunk_seconds, "length of one time chunk; chunks are dealt to the folds in turn "
                 "(default 0.25 s)")->transform(common::strictNumber(1e-3, 1e6));
  app.add_option("--min-explained", a.opt.min_explained, "an effect must remove at least this fraction of its joint's "
                 "held-out residual (default 0.02)")->transform(common::strictNumber(0.0, 1.0));
  app.add_option("--max-effects", a.max_effects, "at most this many effects (default 30)")->transform(common::strictInteger(0, 1000));
  a.width_opt = app.add_option("--coulomb-width", a.opt.shape.coulomb_width,
                                   "rad/s: one Coulomb width tanh(v / width) for every joint (default: each joint's width is\n"
                                   "profiled on the training data over 0.001 ... 0.1 rad/s, the one whose signal, beside v,\n"
                                   "would remove the most of that joint's residual; docs/diagnose.md)")
      ->transform(common::strictNumber(1e-9, 1e3));
  app.add_option("--stribeck-velocity", a.opt.shape.stribeck_velocity, "rad/s: Stribeck decay exp(-(v / vs)^2) (default 0.1)")
      ->transform(common::strictNumber(1e-9, 1e3));
  app.add_option("--torque-noise", a.opt.torque_noise, "known torque noise sigma (N m) for the size check (default: "
                 "estimated from the residual's sample-to-sample differences)")->transform(common::strictNumber(0.0, 1e6));
  app.add_option("--pipeline", a.pipeline, "LCM logs: 'sensors' (default) or 'truth'")->check(CLI::IsMember({"sensors", "truth"}));
  addBaseSignalOptions(app, a.base_signals);
  app.add_option("--cutoff", a.cutoff, "zero-phase Butterworth cutoff in Hz for the dataset pipeline (0: none). Default: 5 Hz "
                 "with --floating-base (exoskeleton logs: differenced encoders and gyro; docs/diagnose.md), none otherwise")
      ->transform(common::strictNumber(0.0, 1e6));
  app.add_option("--filter-mode", a.filter_mode, "'parallel' (default: inputs only differenced, the same filter on every "
                 "column of W and on y, so filter lag and attenuation cancel) or 'inputs' (filter q, differentiate, filter "
                 "again, y unfiltered: leaves the filtered-away motion in the residual); docs/identification.md")
      ->check(CLI::IsMember({"inputs", "parallel"}));
  app.add_flag("--skip-bad-rows", a.skip_bad, "CSV: drop and count bad rows instead of failing at the first (the count and "
               "the first are reported on stdout, in summary.json and report.md)");
  app.add_flag("--allow-partial", a.allow_partial, "LCM logs (--train, --validate, --calibration, --validate-calibration): a "
               "damaged log (damaged stretches, a cut-off tail, events the adapters reject) is refused (exit 3, the damage "
               "on stderr); with this flag its readable part is used and the damage reported on stdout, in summary.json "
               "and report.md");
  app.add_flag("--no-plots", a.in.no_plots, "do not run the plot script (it is still written) nor draw the runs' keyframes");
  app.add_option("--scene", a.in.scene_mjcf, "MJCF of the scene for the runs' keyframe strips in report.md (LCM-log inputs; "
                 "default config/exo.xml)")->type_name("MJCF");
  app.add_flag("--no-predictability", a.no_predictability, "skip the last stage, which asks whether the residual left after "
               "augmentation is predictable from the state (sparse regression over a dictionary of q, v, a of each joint "
               "and its neighbours, their products and history; gradient-boosted trees; docs/diagnose.md)");
  app.add_option("--predictability-block", a.opt.predictability.block_seconds, "s: held-out blocks of the last stage's test "
                 "and the guard between its training and held-out data; longer than the time over which noise in the "
                 "residual is correlated (default 5)")->transform(common::strictNumber(0.01, 1e6));
  app.add_flag("--no-unmeasured-body", a.no_unmeasured_body, "skip the floating base's stage that asks whether an "
               "unmeasured body moves on the base on a spring (a wearer's trunk: the base rows' residual against a body's "
               "resonant response to the base's motion, 0.5-4 Hz, beyond a rigid null; docs/diagnose.md)");
  app.add_option("--unmeasured-body-block", a.opt.unmeasured_body.block_seconds, "s: held-out blocks of the unmeasured-body "
                 "stage's test and the guard between its training and held-out data (default 2.5; a 6-move run is ~19 s)")
      ->transform(common::strictNumber(0.01, 1e6));
  app.add_option("--row-memory-mb", a.row_memory_mb, "MB of memory for keeping the runs' rows (K, y) between the "
                 "diagnosis's passes over them, read once instead of four times (default 2048: a 1 kHz exoskeleton log "
                 "takes 17 MB per second, so 120 s of runs; a run beyond it is read again at each pass, with the same "
                 "result; 0: every run at every pass)")->transform(common::strictInteger(0, 1 << 24))->type_name("MB");
  app.add_option("--python", a.in.python, "python interpreter for the plots (default python3; needs matplotlib and numpy)");
}
// The options parsed into the diagnosis's: one Coulomb width when given, the kinds, the declared model. False with
// *error on an unknown kind.
bool finishOptions(DiagnoseArgs& a, std::string* error) {
  est::DiagnoseOptions& opt = a.opt;
  if (a.width_opt->count() > 0) opt.coulomb_widths = {opt.shape.coulomb_width};  // one width, as asked
  opt.folds = a.folds;
  opt.predictability.enabled = !a.no_predictability;
  opt.unmeasured_body.enabled = !a.no_unmeasured_body;
  opt.max_effects = a.max_effects;
  opt.declared_friction = a.in.declared == "rigid+friction";
  if (a.kinds.empty()) return true;
  opt.kinds.clear();
  for (const std::string& k : a.kinds) {
    est::EffectKind kind;
    if (!est::parseEffectKind(k, kind)) return *error = "--effects: unknown kind '" + k + "'", false;
    opt.kinds.push_back(kind);
  }
  return true;
}

// The input files as the diagnosis's segments, read through the intake (tools::streamFileRows) with what it skipped
// counted per file in `stats` (train, calibration, validation, validation-calibration). Not copyable: the segments'
// streams point into it.
struct DiagnoseSources {
  tools::SourceOptions so, so_held;
  Eigen::VectorXd held_phi;  // --declared-model: its parameters, taken off y (friction too, unless it is fitted)
  std::vector<intake::InputStats> stats;
  std::vector<est::Segment> train, validate;
  std::set<std::string> names;  // segment names name the residual_<name>.csv files: unique
  std::shared_ptr<est::RowMemory> memory = std::make_shared<est::RowMemory>();  // --row-memory-mb: every segment's
  DiagnoseSources() = default;
  DiagnoseSources(const DiagnoseSources&) = delete;

  est::Segment segment(const Model& model, const std::string& path, size_t k, bool held) {
    est::Segment s;
    const fs::path p(path);
    s.name = p.stem().string();
    if (names.count(s.name)) s.name = p.parent_path().filename().string() + "_" + s.name;  // e.g. two run.lcmlog
    for (int i = 2; names.count(s.name); ++i) s.name = p.stem().string() + "_" + std::to_string(i);
    names.insert(s.name);
    s.held_base = held;
    s.stream = [this, &model, path, k, held](const est::DiagnosisRowSink& sink, std::string* e) {
      stats[k] = intake::InputStats{};
      return tools::streamFileRows(path, model, held ? so_held : so, sink, stats[k], e);
    };
    s.stream_state = [this, &model, path, k, held](const est::DiagnosisStateSink& sink, std::string* e) {
      stats[k] = intake::InputStats{};
      return tools::streamFileStateRows(path, model, held ? so_held : so, sink, stats[k], e);
    };
    return est::keptInMemory(std::move(s), memory);  // read once, replayed at the diagnosis's later passes
  }
};

// The intake's options, the declared model (--declared-model: held, the same tree as --model) and the segments.
bool makeSources(const Model& model, const DiagnoseArgs& a, est::DiagnoseOptions& opt, Model& declared_model,
                 DiagnoseSources& src, std::string* err) {
  const DiagnoseInputs& in = a.in;
  src.so.pipeline = a.pipeline == "truth" ? intake::LogPipeline::Truth : intake::LogPipeline::Sensors;
  tools::applyBaseSignals(a.base_signals, src.so);
  src.so.dataset.cutoff_hz = a.cutoff >= 0.0 ? a.cutoff : a.floating ? 5.0 : 0.0;
  src.so.dataset.filter = a.filter_mode == "parallel" ? est::FilterMode::Parallel : est::FilterMode::Inputs;
  src.so.dataset.trim_edges = true;  // the filter's start-up transient is no residual of the model
  src.so.skip_bad_rows = a.skip_bad;
  src.so.allow_partial = a.allow_partial;
  if (!in.declared_model_path.empty()) {
    if (!buildModelFromUrdfFile(in.declared_model_path, a.floating, declared_model, err, a.gravity)) return false;
    const std::string why = differentTree(model, declared_model);
    if (!why.empty())
      return *err = "--declared-model " + in.declared_model_path + ": not the tree of " + in.model_path + ": " + why, false;
    src.held_phi = declared_model.phi;
    if (opt.declared_friction) src.held_phi.tail(model.nparams() - model.nInertialParams()).setZero();  // fitted instead
    src.so.held_phi = &src.held_phi;
    opt.hold_declared = true;
  }
  if ((!in.calib_files.empty() || !in.val_calib_files.empty()) && !a.floating)
    return *err = "--calibration and --validate-calibration need --floating-base (an exoskeleton held in a harness)", false;
  src.so_held = src.so;
  src.so_held.held_base = true;
  src.stats.resize(in.train_files.size() + in.calib_files.size() + in.val_files.size() + in.val_calib_files.size());
  src.memory->budget_bytes = a.row_memory_mb << 20;
  size_t k = 0;
  for (const std::string& f : in.train_files) src.train.push_back(src.segment(model, f, k++, false));
  for (const std::string& f : in.calib_files) src.train.push_back(src.segment(model, f, k++, true));
  for (const std::string& f : in.val_files) src.validate.push_back(src.segment(model, f, k++, false));
  for (const std::string& f : in.val_calib_files) src.validate.push_back(src.segment(model, f, k++, true));
  return true;
}
}  // namespace cmd_diagnose

int cmdDiagnose(int argc, char** argv) {
  using namespace cmd_diagnose;
  CLI::App app(kDescription, "exoid diagnose");
  common::configureCli(app);
  DiagnoseArgs a;
  addDiagnoseOptions(app, a);
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  if (!finishOptions(a, &err)) return fail(err);
  Model model, declared_model;
  if (!buildModelFromUrdfFile(a.in.model_path, a.floating, model, &err, a.gravity)) return fail(err);
  DiagnoseSources src;
  if (!makeSources(model, a, a.opt, declared_model, src, &err)) return fail(err);
  est::DiagnosisResult res;
  if (!est::diagnose(model, src.train, src.validate, a.opt, res, &err)) {
    for (const intake::InputStats& st : src.stats)
      if (st.refused_damaged) return fail(err), 3;
    return fail(err);
  }
  {  // --sole-on-plate fit: what each file gave (segments in the order their statistics were made)
    std::vector<std::string> files = a.in.train_files;
    for (const auto* v : {&a.in.calib_files, &a.in.val_files, &a.in.val_calib_files})
      files.insert(files.end(), v->begin(), v->end());
    for (size_t k = 0; k < src.stats.size() && k < files.size(); ++k) {
      const est::SolePlacement& sp = src.stats[k].sole_placement;
      if (sp.fitted || !sp.why_not.empty())
        std::printf("%s: the soles' common offset on their plates, %s\n", files[k].c_str(),
                    est::describeSolePlacement(sp).c_str());
    }
  }
  est::OnlineComparison online;
  if (!est::compareOnline(model, a.opt, src.train, src.validate, res, effectSetOf(a.in.model_path, a.opt, res), online, &err))
    return fail(err);
  if (!writeDiagnosis(model, declared_model, a.opt, a.in, src.stats, res, online, &err)) return fail(err);
  return 0;
}

}  // namespace exoid::cli
