// exoid study: the thesis's comparison protocol in one command (tools/lib study.hpp; docs/study.md).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <sstream>

#include "commands.hpp"
#include "exoid/tools/study.hpp"

namespace exoid::cli {

namespace {
constexpr char kDescription[] =
    "The thesis's comparison protocol (chapter 3 IV, Tables II and C.1; chapter 4 Table D.1's absolute priors)\n"
    "on exoid's runs: per input pipeline (thesis protocol: ground-truth states with 9e-6 rad encoder noise,\n"
    "filtered and differentiated; sensors only) and cutoff, one streamed training factor; per prior range\n"
    "--priors random priors; per prior Ref, OLS, WLS-R, WLS-C, WLS-RC (rank by the validation run, as the\n"
    "thesis), WLS-RC (cv: rank from the training data alone) and WLS-RC-PC (physically consistent), scored with\n"
    "the thesis's metrics on the ideal validation run (and a held-out test run). Record the runs first, each\n"
    "with its own CoM move seed:\n"
    "  exoid experiment --scenario config/scenarios/nominal.yaml --seed 1 --out out/train\n"
    "  exoid experiment --scenario config/scenarios/ideal.yaml --seed 2 --out out/validation\n"
    "  exoid experiment --scenario config/scenarios/nominal.yaml --seed 3 --out out/test\n"
    "Writes results.csv, table_c1.{csv,md}, table2.{csv,md} (thesis numbers beside), singular_values.csv and\n"
    "link_error.csv into --out; scripts/plot_study.py DIR draws the figures.\n\n"
    "exit codes: 0 success, 2 bad input (one-line message on stderr).";

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid study: error: %s\n", msg.c_str());
  return 2;
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
}  // namespace

int cmdStudy(int argc, char** argv) {
  CLI::App app(kDescription, "exoid study");
  tools::StudyOptions o;
  o.model_path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf";
  o.thesis_table = std::string(EXOID_DATA_DIR) + "/thesis/table2.csv";
  std::string cutoffs = "0,30,50,70,100", pipelines = "thesis,sensors", ranges = "12.5%,25%,abs0.125";
  app.add_option("--model", o.model_path, "URDF (default config/exo.urdf, floating base)");
  app.add_option("--train", o.train, "LCM log of the training run (noise: nominal.yaml)")->required();
  app.add_option("--validation", o.validation, "LCM log of the ideal validation run (ideal.yaml, another seed)")->required();
  app.add_option("--test", o.test, "LCM log of a held-out test run (another seed), scored as well");
  app.add_option("--out", o.out_dir, "output directory")->required();
  app.add_option("--priors", o.priors, "random priors per range (default 20)")->check(CLI::Range(1, 1000));
  app.add_option("--seed", o.seed, "seed of the priors and the encoder noise (default 1)");
  app.add_option("--cutoffs", cutoffs, "filter cutoffs in Hz, 0 = none (default 0,30,50,70,100)");
  app.add_option("--pipelines", pipelines, "thesis and/or sensors (default both)");
  app.add_option("--ranges", ranges, "prior ranges: 12.5%, 25% (relative) and abs0.125 (absolute), default all three");
  app.add_option("--stride", o.stride, "score every N-th tick of the validation/test runs (default 10)")->check(CLI::Range(1, 1000));
  app.add_option("--pc-iterations", o.pc_iterations, "Newton iterations of WLS-RC-PC (default 100)")->check(CLI::Range(1, 10000));
  app.add_option("--pc-nullspace-weight", o.pc_nullspace,
                 "WLS-RC-PC: weight of the prior in the directions WLS-RC does not use, relative to s_z^2 (default 1e-3)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--realistic-cutoff", o.realistic_cutoff_hz,
                 "causal velocity filter (Hz) of the realistic torque prediction on the test run (default 50)")
      ->check(CLI::Range(1.0, 499.0));
  app.add_option("--thesis-table", o.thesis_table, "the thesis's Table II as CSV (default data/thesis/table2.csv)");
  try {
    app.parse(argc - 1, argv + 1);
  } catch (const CLI::CallForHelp&) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  } catch (const CLI::ParseError& e) {
    return fail(e.what());
  }
  if (!parseList(cutoffs, o.cutoffs)) return fail("--cutoffs must be a comma-separated list of numbers");
  for (double c : o.cutoffs)
    if (!(c >= 0.0) || c >= 500.0) return fail("--cutoffs: " + std::to_string(c) + " is not in [0, 500) Hz");
  std::vector<std::string> p, r;
  if (!parseList(pipelines, p)) return fail("--pipelines must be a comma-separated list");
  o.pipelines = p;
  if (!parseList(ranges, r)) return fail("--ranges must be a comma-separated list");
  o.ranges.clear();
  for (const std::string& s : r) {
    if (s == "12.5%") o.ranges.push_back({s, 0.125, false});
    else if (s == "25%") o.ranges.push_back({s, 0.25, false});
    else if (s == "abs0.125") o.ranges.push_back({s, 0.125, true});
    else return fail("--ranges: unknown range '" + s + "' (12.5%, 25%, abs0.125)");
  }
  o.progress = [](const std::string& line) { std::fprintf(stderr, "exoid study: %s\n", line.c_str()); };
  std::string err;
  if (!tools::runStudy(o, &err)) return fail(err);
  return 0;
}

}  // namespace exoid::cli
