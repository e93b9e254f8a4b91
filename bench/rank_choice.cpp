// exoid_rank_choice: how well each rank rule does (thesis protocol or sensors only) over random priors:
// estimation error against the URDF's parameters (the simulated truth) and validation generalized-force
// RMSE, per method and rule (all four methods; `exoid study` measures WLS-RC with every metric, docs/identification.md).
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <random>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"

using namespace exoid;

namespace {
// Thesis IV-B attribute 5: mean over the parameters with a nonzero true value of |(est - true) / true|, in %.
double estimationError(const Model& m, const Eigen::VectorXd& est) {
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < m.nInertialParams(); ++i)
    if (std::abs(m.phi[i]) > 1e-12) sum += std::abs((est[i] - m.phi[i]) / m.phi[i]), ++n;
  return 100.0 * sum / n;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Rank-rule comparison over random priors (docs/identification.md)", "exoid_rank_choice");
  std::vector<std::string> train, validate;
  std::string model_path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf", pipeline = "truth";
  double cutoff = 0.0, noise = 0.0, perturb = 0.25;
  int priors = 20, folds = 5;
  bool fixed = false;
  app.add_option("--train", train, "training logs/CSVs")->required();
  app.add_option("--validate", validate, "validation logs/CSVs (ideal)")->required();
  app.add_option("--model", model_path, "URDF whose parameters are the truth");
  app.add_flag("--fixed-base", fixed, "fixed-base model");
  app.add_option("--pipeline", pipeline, "training pipeline: truth or sensors");
  app.add_option("--cutoff", cutoff, "Butterworth cutoff, Hz (0: none)");
  std::string mode = "inputs";
  app.add_option("--filter-mode", mode, "inputs or parallel");
  app.add_option("--noise", noise, "encoder noise sigma on the training q");
  app.add_option("--perturb", perturb, "prior within +-perturb of the truth");
  app.add_option("--priors", priors, "number of random priors");
  app.add_option("--folds", folds, "time-block folds");
  CLI11_PARSE(app, argc, argv);
  Model model;
  std::string err;
  if (!buildModelFromUrdfFile(model_path, !fixed, model, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
  const BaseParameters base = computeBaseParameters(model);
  tools::SourceOptions so;
  so.pipeline = pipeline == "truth" ? intake::LogPipeline::Truth : intake::LogPipeline::Sensors;
  so.dataset.cutoff_hz = cutoff;
  so.dataset.encoder_noise = noise;
  so.dataset.filter = mode == "parallel" ? estimator::FilterMode::Parallel : estimator::FilterMode::Inputs;
  so.dataset.derive = noise > 0.0 || pipeline == "sensors";
  estimator::AccumulatorOptions ao;
  ao.folds = folds;
  ao.chunk = 2000;
  estimator::LsqAccumulator acc(model, base, ao);
  for (const auto& f : train) {
    intake::InputStats st;
    if (!tools::accumulateFile(f, model, so, acc, st, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
  }
  acc.flush();
  tools::SourceOptions vo;
  vo.pipeline = intake::LogPipeline::Truth;
  estimator::AccumulatorOptions va = ao;
  va.folds = 1;
  estimator::LsqAccumulator vacc(model, base, va);
  for (const auto& f : validate) {
    intake::InputStats st;
    if (!tools::accumulateFile(f, model, vo, vacc, st, &err)) return std::fprintf(stderr, "%s\n", err.c_str()), 2;
  }
  vacc.flush();
  const estimator::LsqFactor vf = estimator::toStandard(vacc.mergedBase(), base.base_map);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-perturb, perturb);
  const char* rules[] = {"full", "validation", "cv-min", "cv-1se", "gcv", "jackknife"};
  struct Acc { double err = 0, rmse = 0, z = 0; };
  Acc ref, res[4][6];
  for (int k = 0; k < priors; ++k) {
    Eigen::VectorXd prior = model.phi;
    for (int i = 0; i < prior.size(); ++i) prior[i] *= 1.0 + u(rng);
    ref.err += estimationError(model, prior) / priors;
    ref.rmse += estimator::rmse(vf, prior) / priors;
    int mi = 0;
    for (estimator::Method m : {estimator::Method::Ols, estimator::Method::WlsR, estimator::Method::WlsC, estimator::Method::WlsRC}) {
      const estimator::ScaledProblem sp = estimator::scaleProblem(acc, model, prior, m);
      int zs[6];
      zs[5] = estimator::rankByJackknife(acc, model, prior, m, perturb).best;
      zs[0] = sp.numericalRank();
      zs[1] = estimator::rankByValidation(sp, vf).best;
      zs[2] = estimator::rankByCrossValidation(acc, model, prior, m, estimator::CvRule::Minimum).best;
      zs[3] = estimator::rankByCrossValidation(acc, model, prior, m, estimator::CvRule::OneStandardError).best;
      zs[4] = estimator::rankByGcv(sp).best;
      for (int r = 0; r < 6; ++r) {
        const Eigen::VectorXd phi = estimator::solveAtRank(sp, zs[r]);
        res[mi][r].err += estimationError(model, phi) / priors;
        res[mi][r].rmse += estimator::rmse(vf, phi) / priors;
        res[mi][r].z += double(zs[r]) / priors;
      }
      ++mi;
    }
  }
  std::printf("%d priors within +-%.1f %%, %s pipeline, cutoff %g Hz (%s filtering), noise %g; base parameters %d\n",
              priors, 100 * perturb, pipeline.c_str(), cutoff, mode.c_str(), noise, base.rank);
  std::printf("%-8s %-11s %8s %14s %12s\n", "method", "rank rule", "mean z", "val RMSE", "est. err %");
  std::printf("%-8s %-11s %8s %14.6g %12.3f\n", "Ref", "-", "-", ref.rmse, ref.err);
  const char* mn[] = {"OLS", "WLS-R", "WLS-C", "WLS-RC"};
  for (int mi = 0; mi < 4; ++mi)
    for (int r = 0; r < 6; ++r)
      std::printf("%-8s %-11s %8.1f %14.6g %12.3f\n", mn[mi], rules[r], res[mi][r].z, res[mi][r].rmse, res[mi][r].err);
  return 0;
}
