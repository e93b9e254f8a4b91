// exoid_rank_table: every data set x rank rule of `exoid identify` (WLS-RC-PC, its default method): held-out
// generalized-force RMSE and z, against the best rank chosen with the validation data (docs/identification.md,
// "Choosing the rank z"). Data sets: the KUKA LWR4+ runs (train 2 + 3, validate 1, prior = the URDF), synthetic
// arms with friction (tools/synthetic_arm.hpp; train on one run, validate on another motion of the same arm,
// prior = the URDF perturbed +-25 %, friction prior 0) and, when given, exoskeleton runs (--exo-train,
// --exo-validate: LCM logs of `exoid experiment`, sensors pipeline at 30 Hz, prior = config/exo.urdf perturbed
// +-25 %). Every data set is written to --out (URDF of the truth, URDF of the prior, training and validation CSV)
// so that `exoid identify --fixed-base --model OUT/armN_prior.urdf --data OUT/armN_train.csv --validate
// OUT/armN_validate.csv --rank RULE` reproduces a row. Not a timing benchmark.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/tools/perturb_inertials.hpp"
#include "exoid/tools/synthetic_arm.hpp"
#include "exoid/tools/urdf_inertials.hpp"

using namespace exoid;
namespace fs = std::filesystem;

namespace {
struct DataSet {
  std::string name;
  Model model;
  Eigen::VectorXd prior;
  std::vector<std::string> train, validate;
  tools::SourceOptions train_options, validate_options;
  double rate = 200.0;
};

bool load(const DataSet& ds, const std::vector<std::string>& files, const tools::SourceOptions& so, int folds,
          std::unique_ptr<estimator::LsqAccumulator>& acc, const BaseParameters& base, std::string* err) {
  estimator::AccumulatorOptions ao;
  ao.folds = folds;
  ao.chunk = static_cast<int>(std::lround(2.0 * ds.rate));  // identify's --chunk-seconds 2
  acc = std::make_unique<estimator::LsqAccumulator>(ds.model, base, ao);
  for (const std::string& f : files) {
    intake::InputStats st;
    if (!tools::accumulateFile(f, ds.model, so, *acc, st, err)) return false;
  }
  acc->flush();
  return true;
}

struct Row {
  std::string rule;
  int z = 0;
  double rmse = 0.0, train = 0.0;
};

void evaluate(const DataSet& ds, const std::vector<std::string>& rules) {
  std::string err;
  const BaseParameters base = computeBaseParameters(ds.model);
  std::unique_ptr<estimator::LsqAccumulator> tr, va;
  if (!load(ds, ds.train, ds.train_options, 5, tr, base, &err) || !load(ds, ds.validate, ds.validate_options, 1, va, base, &err)) {
    std::fprintf(stderr, "%s: %s\n", ds.name.c_str(), err.c_str());
    return;
  }
  // The default rule's processing term, as `exoid identify` gives it (tools::processingAlternatives).
  std::vector<std::unique_ptr<estimator::LsqAccumulator>> alternatives;
  std::vector<const estimator::LsqAccumulator*> processing;
  for (const tools::ProcessingAlternative& alt : tools::processingAlternatives(ds.train_options, ds.model.floating_base)) {
    alternatives.emplace_back();
    if (!load(ds, ds.train, alt.source, 5, alternatives.back(), base, &err)) {
      std::fprintf(stderr, "%s (%s): %s\n", ds.name.c_str(), alt.what.c_str(), err.c_str());
      return;
    }
    processing.push_back(alternatives.back().get());
  }
  std::vector<Row> rows;
  double prior_rmse = 0.0;
  for (const std::string& rule : rules) {
    estimator::IdentifyOptions o;
    o.physically_consistent = true;
    if (!estimator::parseRankRule(rule, o.rank_rule)) continue;
    estimator::IdentifyResult r;
    if (!estimator::identify(*tr, ds.model, ds.prior, o, va.get(), r, &err, processing)) {
      std::fprintf(stderr, "%s %s: %s\n", ds.name.c_str(), rule.c_str(), err.c_str());
      continue;
    }
    rows.push_back({rule, r.rank, r.validation_rmse, r.training_rmse});
    prior_rmse = r.prior_validation_rmse;
  }
  // One markdown row: prior, every rule's held-out RMSE (z), the default's ratio to the validation choice and its
  // held-out / training ratio.
  double best = NAN, def = NAN, ratio = NAN;
  for (const Row& r : rows) {
    if (r.rule == "validation") best = r.rmse;
    if (r.rule == "jackknife") def = r.rmse, ratio = r.rmse / r.train;
  }
  std::printf("| %s | %.4g |", ds.name.c_str(), prior_rmse);
  for (const Row& r : rows) std::printf(" %.4g (%d) |", r.rmse, r.z);
  std::printf(" %.3f | %.2f |\n", def / best, ratio);
  std::fflush(stdout);
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Rank rules x data sets: held-out RMSE and z (docs/identification.md)", "exoid_rank_table");
  std::vector<std::string> exo_train, exo_validate, rules{"validation", "full", "cv", "cv-1se", "gcv", "jackknife"};
  std::string kuka_dir = std::string(EXOID_DATA_DIR) + "/kuka_lwr4", tmp = "out/rank_table";
  bool no_kuka = false, no_arms = false;
  int random_arms = 0;
  app.add_option("--random-arms", random_arms, "that many more synthetic arms drawn at random (seeds 101, ...)");
  app.add_option("--exo-train", exo_train, "exoskeleton training log(s) (exoid experiment's run.lcmlog)");
  app.add_option("--exo-validate", exo_validate, "exoskeleton validation log(s)");
  app.add_option("--rules", rules, "rank rules to compare");
  app.add_option("--out", tmp, "folder for the synthetic arms' URDFs and CSVs and the exoskeleton's prior URDF "
                 "(default out/rank_table)");
  app.add_flag("--no-kuka", no_kuka, "skip the KUKA data set");
  app.add_flag("--no-arms", no_arms, "skip the synthetic arms");
  CLI11_PARSE(app, argc, argv);
  std::string err;
  std::printf("| data set | prior |");
  for (const std::string& r : rules) std::printf(" %s |", r.c_str());
  std::printf(" jackknife / validation | held-out / training |\n|---|---|");
  for (size_t i = 0; i < rules.size() + 2; ++i) std::printf("---|");
  std::printf("\n");
  if (!no_kuka) {
    DataSet k;
    k.name = "KUKA LWR4+ (2+3 / 1)";
    if (!buildModelFromUrdfFile(kuka_dir + "/kuka_lwr4.urdf", false, k.model, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
    k.prior = k.model.phi;
    k.train = {kuka_dir + "/measurements_2.csv", kuka_dir + "/measurements_3.csv"};
    k.validate = {kuka_dir + "/measurements_1.csv"};
    k.rate = 1.0 / 0.00664687157;  // as identify reads it: the spacing of measurements_2's first two rows
    evaluate(k, rules);
  }
  if (!no_arms) {
    fs::create_directories(tmp);
    // vmax, train_s: a weakly exciting training run (slow, short), where truncation matters.
    struct Case { int joints; uint64_t seed; double friction, noise, offset, rate, vmax = 1.5, train_s = 40.0; };
    std::vector<Case> cases = {{6, 1, 0.2, 0.02, 0.0, 200}, {7, 2, 0.1, 0.01, 0.0, 200}, {5, 3, 0.3, 0.03, 0.0, 100},
                               {6, 4, 1.5, 0.10, 0.0, 100}, {6, 5, 1.0, 0.10, 0.05, 100}, {7, 6, 0.5, 0.05, 0.0, 100},
                               {5, 7, 2.0, 0.10, 0.0, 100}, {6, 8, 0.2, 0.02, 0.02, 200},
                               {6, 9, 0.3, 0.05, 0.0, 100, 0.3, 10.0}, {7, 10, 1.5, 0.10, 0.0, 100, 0.3, 10.0}};
    // More arms drawn at random: 5-7 joints, friction ratio log-uniform in [0.05, 3], noise 1-10 %, offsets in
    // half of them, 100 or 200 Hz (seeds 101, 102, ...).
    std::mt19937_64 rng(2026);
    const auto unit = [&]() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
    for (int k = 0; k < random_arms; ++k)
      cases.push_back({5 + static_cast<int>(unit() * 3), 101u + static_cast<uint64_t>(k), 0.05 * std::pow(60.0, unit()),
                       0.01 + 0.09 * unit(), unit() < 0.5 ? 0.05 * unit() : 0.0, unit() < 0.5 ? 100.0 : 200.0, 1.5, 40.0});
    for (const Case& c : cases) {
      tools::SyntheticArmOptions ao;
      ao.joints = c.joints, ao.seed = c.seed, ao.friction_ratio = c.friction, ao.offset_ratio = c.offset;
      tools::SyntheticArm arm;
      if (!tools::makeSyntheticArm(ao, arm, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
      DataSet d;
      char name[128];
      std::snprintf(name, sizeof name, "arm s%llu %dj f%.2f n%.0f%%%s %gHz%s", static_cast<unsigned long long>(c.seed), c.joints,
                    c.friction, 100 * c.noise, c.offset > 0 ? " off" : "", c.rate, c.train_s < 40.0 ? " weak" : "");
      d.name = name;
      d.model = arm.model;
      d.rate = c.rate;
      const std::string stem = tmp + "/arm" + std::to_string(c.seed);
      if (!tools::perturbInertials(arm.model, 0.25, c.seed, d.prior, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
      std::ofstream(stem + ".urdf") << arm.urdf;
      if (!tools::writeUrdfWithInertials(stem + ".urdf", arm.model, d.prior, stem + "_prior.urdf", &err))
        return std::fprintf(stderr, "%s\n", err.c_str()), 2;
      for (int run = 0; run < 2; ++run) {
        tools::ArmRunOptions ro;
        ro.seed = 1000 * c.seed + run;
        ro.rate = c.rate;
        ro.duration = run == 0 ? c.train_s : 20.0;
        if (run == 0) ro.max_velocity = c.vmax;
        ro.torque_noise = c.noise;
        const std::string path = stem + (run == 0 ? "_train.csv" : "_validate.csv");
        if (!tools::writeArmRunCsv(path, arm.model, tools::simulateArmRun(arm, ro), &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
        (run == 0 ? d.train : d.validate).push_back(path);
      }
      evaluate(d, rules);
    }
  }
  if (!exo_train.empty() && !exo_validate.empty()) {
    DataSet e;
    e.name = "exoskeleton";
    if (!buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, e.model, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
    if (!tools::perturbInertials(e.model, 0.25, 1, e.prior, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
    fs::create_directories(tmp);
    if (!tools::writeUrdfWithInertials(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", e.model, e.prior, tmp + "/exo_prior.urdf", &err))
      return std::fprintf(stderr, "%s\n", err.c_str()), 2;
    e.train = exo_train, e.validate = exo_validate;
    e.rate = 1000.0;
    e.train_options.pipeline = intake::LogPipeline::Sensors;
    e.train_options.dataset.cutoff_hz = 30.0;
    tools::applyBaseSignals(tools::BaseSignals{}, e.train_options);  // exoid identify's defaults
    e.validate_options.pipeline = intake::LogPipeline::Truth;
    evaluate(e, rules);
  }
  return 0;
}
