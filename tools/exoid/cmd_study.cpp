// exoid study: the thesis's comparison protocol in one command (tools/lib study.hpp; docs/study.md).
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "base_signal_options.hpp"
#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/render/run_keyframes.hpp"
#include "exoid/tools/process.hpp"
#include "exoid/tools/study.hpp"

namespace exoid::cli {

namespace cmd_study {  // this file's own names: the exoid binary is a unity build
constexpr char kDescription[] =
    "The thesis's comparison protocol (chapter 3 IV, Tables II and C.1; chapter 4 Table D.1's absolute priors)\n"
    "on exoid's runs: per input pipeline (thesis protocol: ground-truth states with 9e-6 rad encoder noise,\n"
    "filtered and differentiated; sensors only) and cutoff, one streamed training factor; per prior range\n"
    "--priors random priors; per prior Ref, OLS, WLS-R, WLS-C, WLS-RC (rank by the validation run, as the\n"
    "thesis), WLS-RC with the rank from the training data alone (jackknife, cv, cv-1se, gcv) and WLS-RC-PC\n"
    "(physically consistent), scored with the thesis's metrics on the ideal validation run (and a held-out\n"
    "test run). The runs, each with its own CoM\n"
    "move seed: with --runs DIR the study records those missing itself (reusing DIR/<run>/run.lcmlog when a\n"
    "finished one is there):\n"
    "  exoid experiment --scenario config/scenarios/nominal.yaml --seed 11 --out DIR/train\n"
    "  exoid experiment --scenario config/scenarios/ideal.yaml --seed 12 --out DIR/validation\n"
    "  exoid experiment --scenario config/scenarios/nominal.yaml --seed 13 --out DIR/test\n"
    "or give recorded logs with --train, --validation (and --test).\n"
    "Writes results.csv, table_c1.{csv,md}, table2.{csv,md} (thesis numbers beside), singular_values.csv and\n"
    "link_error.csv into --out; scripts/plot_study.py DIR draws the figures.\n\n"
    "exit codes: 0 success (with --allow-partial also from a damaged log), 2 bad input (one-line message on\n"
    "            stderr), 3 a run log is damaged (damaged stretches, a cut-off tail, rejected events; nothing\n"
    "            written; see --allow-partial).";

int fail(const std::string& msg) { return common::badInput("exoid study", msg); }

std::string selfPath() { return exoid::common::selfExecutablePath("exoid"); }

/// DIR/name/run.lcmlog of a finished run (summary.json written at its end), recorded now if missing.
bool ensureRun(const std::string& dir, const std::string& name, const std::string& scenario, int seed, int moves,
               std::string& log, std::string* error) {
  namespace fs = std::filesystem;
  const std::string out = dir + "/" + name;
  log = out + "/run.lcmlog";
  if (fs::exists(log) && fs::exists(out + "/summary.json")) {
    std::fprintf(stderr, "exoid study: reusing %s\n", log.c_str());
    return true;
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return *error = "cannot create " + dir + ": " + ec.message(), false;
  std::vector<std::string> argv{selfPath(), "experiment", "--scenario",
                                std::string(EXOID_CONFIG_DIR) + "/scenarios/" + scenario, "--seed",
                                std::to_string(seed), "--out", out, "--no-estimator"};  // the study's data only
  if (moves > 0) argv.insert(argv.end(), {"--moves", std::to_string(moves)});
  std::fprintf(stderr, "exoid study: recording %s (%s, seed %d; log %s.log)\n", out.c_str(), scenario.c_str(), seed,
               out.c_str());
  fs::remove(out + ".log", ec);
  const pid_t pid = tools::spawn(argv, out + ".log", error);
  if (pid <= 0) return false;
  int code = -1;
  tools::waitFor(pid, -1, &code);
  if (code != 0) return *error = "exoid experiment for " + out + " " + tools::describeExit(code) + " (see " + out + ".log)", false;
  return true;
}

template <class T>
bool parseList(const std::string& s, std::vector<T>& out) {
  out.clear();
  std::stringstream ss(s);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    std::stringstream cs(cell);
    T v;
    if (!(cs >> v) || !cs.eof()) return false;
    out.push_back(v);
  }
  return !out.empty();
}
/// The study's options as given: the lists still text, --runs and its moves.
struct StudyArgs {
  std::string cutoffs = "0,10,15,30,50,70,100", pipelines = "thesis,sensors", ranges = "12.5%,25%,abs0.125";
  std::string runs, sensors_filter = "inputs";
  std::string scene = std::string(EXOID_CONFIG_DIR) + "/exo.xml";
  int moves = 0;
  bool no_keyframes = false;
};

void addStudyOptions(CLI::App& app, tools::StudyOptions& o, StudyArgs& a) {
  app.add_option("--model", o.model_path, "URDF (default config/exo.urdf, floating base)");
  app.add_option("--runs", a.runs, "directory of the study's runs: train (nominal.yaml, seed 11), validation (ideal.yaml, "
                 "seed 12), test (nominal.yaml, seed 13); each recorded by exoid experiment when DIR/<run>/run.lcmlog "
                 "is missing, reused otherwise (instead of --train/--validation/--test)");
  app.add_option("--moves", a.moves, "--runs: CoM moves per recorded run (0: the controller's default)")->check(CLI::Range(0, 1000));
  app.add_flag("--no-keyframes", a.no_keyframes, "do not draw the runs' keyframe strips at the end of table2.md");
  app.add_option("--scene", a.scene, "MJCF of the scene for the keyframe strips (default config/exo.xml)");
  app.add_option("--train", o.train, "LCM log of the training run (noise: nominal.yaml)");
  app.add_option("--validation", o.validation, "LCM log of the ideal validation run (ideal.yaml, another seed)");
  app.add_option("--test", o.test, "LCM log of a held-out test run (another seed), scored as well");
  app.add_flag("--allow-partial", o.allow_partial, "a damaged log (damaged stretches, a cut-off tail, rejected events) is "
               "refused; with this flag its readable part is used and the damage reported on stderr and at the top of "
               "table_c1.md and table2.md");
  app.add_option("--out", o.out_dir, "output directory")->required();
  app.add_option("--priors", o.priors, "random priors per range (default 20)")->check(CLI::Range(1, 1000));
  app.add_option("--seed", o.seed, "seed of the priors and the encoder noise (default 1)");
  app.add_option("--cutoffs", a.cutoffs, "filter cutoffs in Hz, 0 = none (default 0,10,15,30,50,70,100: the thesis's none/30/50/70/100 plus 10 and 15)");
  app.add_option("--pipelines", a.pipelines, "thesis and/or sensors (default both)");
  app.add_option("--ranges", a.ranges, "prior ranges: 12.5%, 25% (relative) and abs0.125 (absolute), default all three");
  app.add_option("--sensors-filter", a.sensors_filter, "sensors pipeline: 'inputs' (filter q and the gyro, differentiate; "
                 "default) or 'parallel' (the same zero-phase filter on every column of W and on y)")
      ->check(CLI::IsMember({"inputs", "parallel"}));
  addBaseSignalOptions(app, o.base_signals);
  app.add_option("--threads", o.threads, "workers over the (pipeline, cutoff) jobs (default 2)")->check(CLI::Range(1, 64));
  app.add_option("--stride", o.stride, "score every N-th tick of the validation/test runs (default 10)")->check(CLI::Range(1, 1000));
  app.add_option("--pc-iterations", o.pc_iterations, "Newton iterations of WLS-RC-PC (default 100)")->check(CLI::Range(1, 10000));
  app.add_option("--pc-nullspace-weight", o.pc_nullspace,
                 "WLS-RC-PC: weight of the prior in the directions WLS-RC does not use, relative to s_z^2 (default 3e-2)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--realistic-cutoff", o.realistic_cutoff_hz,
                 "causal velocity filter (Hz) of the realistic torque prediction on the test run (default 50)")
      ->check(CLI::Range(1.0, 499.0));
  app.add_option("--thesis-table", o.thesis_table, "the thesis's Table II as CSV (default data/thesis/table2.csv)");
}

/// The runs' source (--runs or the three logs), the filter and orientation choices and the lists into o; false
/// with a one-line *error.
bool resolveStudyOptions(const StudyArgs& a, tools::StudyOptions& o, std::string* error) {
  if (a.runs.empty() && (o.train.empty() || o.validation.empty()))
    return *error = "give --runs DIR, or --train and --validation (recorded runs)", false;
  if (!a.runs.empty() && (!o.train.empty() || !o.validation.empty() || !o.test.empty()))
    return *error = "--runs records/reuses its own runs: do not combine it with --train, --validation or --test", false;
  o.parallel_filter = a.sensors_filter == "parallel";
  if (!parseList(a.cutoffs, o.cutoffs)) return *error = "--cutoffs must be a comma-separated list of numbers", false;
  for (double c : o.cutoffs)
    if (!(c >= 0.0) || c >= 500.0) return *error = "--cutoffs: " + std::to_string(c) + " is not in [0, 500) Hz", false;
  std::vector<std::string> p, r;
  if (!parseList(a.pipelines, p)) return *error = "--pipelines must be a comma-separated list", false;
  o.pipelines = p;
  if (!parseList(a.ranges, r)) return *error = "--ranges must be a comma-separated list", false;
  o.ranges.clear();
  for (const std::string& s : r) {
    if (s == "12.5%") o.ranges.push_back({s, 0.125, false});
    else if (s == "25%") o.ranges.push_back({s, 0.25, false});
    else if (s == "abs0.125") o.ranges.push_back({s, 0.125, true});
    else return *error = "--ranges: unknown range '" + s + "' (12.5%, 25%, abs0.125)", false;
  }
  return true;
}
}  // namespace cmd_study

// table2.md's last section: the runs the study used, each as its keyframe strip (start, largest CoM excursion, end;
// `exoid render --keyframes`), or why it is not drawn. False with *err when table2.md cannot be appended to.
static bool appendRunKeyframes(const tools::StudyOptions& o, const std::string& scene, std::string* err) {
  using namespace cmd_study;
  Model model;
  std::string why;
  const bool have_model = buildModelFromUrdfFile(o.model_path, true, model, &why);
  std::vector<render::ReportRun> runs;
  for (const auto& [name, log] : {std::pair<const char*, const std::string*>{"train", &o.train}, {"validation", &o.validation}, {"test", &o.test}})
    if (!log->empty()) runs.push_back({name, *log, std::string("keyframes_") + name + ".png"});
  std::ofstream md(o.out_dir + "/table2.md", std::ios::app);
  if (!md) return *err = "cannot append to '" + o.out_dir + "/table2.md'", false;
  md << "\n" << render::runKeyframesSection(runs, have_model ? &model : nullptr, why, scene, o.out_dir);
  return static_cast<bool>(md);
}

int cmdStudy(int argc, char** argv) {
  using namespace cmd_study;
  CLI::App app(kDescription, "exoid study");
  tools::StudyOptions o;
  o.model_path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf";
  o.thesis_table = std::string(EXOID_DATA_DIR) + "/thesis/table2.csv";
  StudyArgs a;
  addStudyOptions(app, o, a);
  try {
    app.parse(argc - 1, argv + 1);
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  } catch (const CLI::ParseError& e) {
    return fail(e.what());
  }
  std::string err;
  if (!resolveStudyOptions(a, o, &err)) return fail(err);
  o.progress = [](const std::string& line) { std::fprintf(stderr, "exoid study: %s\n", line.c_str()); };
  if (!a.runs.empty()) {
    if (!ensureRun(a.runs, "train", "nominal.yaml", 11, a.moves, o.train, &err) ||
        !ensureRun(a.runs, "validation", "ideal.yaml", 12, a.moves, o.validation, &err) ||
        !ensureRun(a.runs, "test", "nominal.yaml", 13, a.moves, o.test, &err))
      return fail(err);
  }
  bool damaged = false;
  if (!tools::runStudy(o, &err, &damaged)) return damaged ? (fail(err), 3) : fail(err);
  if (!a.no_keyframes && !appendRunKeyframes(o, a.scene, &err)) return fail(err);
  return 0;
}

}  // namespace exoid::cli
