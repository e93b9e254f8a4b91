#include "exoid/tools/online_vs_batch.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "exoid/common/strict_number.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/estimator/dataset.hpp"

namespace exoid::tools {

namespace {

// name,prior,estimate,stddev -> estimate per model parameter; false when a parameter is missing or bad.
bool readLiveEstimate(const std::string& path, const Model& model, Eigen::VectorXd& phi, std::string* error) {
  std::ifstream in(path);
  if (!in) return *error = path + ": cannot read the online estimate", false;
  std::map<std::string, double> values;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string name, prior, estimate;
    std::getline(ss, name, ',');
    std::getline(ss, prior, ',');
    std::getline(ss, estimate, ',');
    double v = 0.0;
    if (!common::parseDouble(estimate, v)) return *error = path + ": bad estimate for '" + name + "'", false;
    values[name] = v;
  }
  const std::vector<std::string> names = model.paramNames();
  phi.resize(static_cast<Eigen::Index>(names.size()));
  for (size_t i = 0; i < names.size(); ++i) {
    auto it = values.find(names[i]);
    if (it == values.end()) return *error = path + ": no estimate for '" + names[i] + "'", false;
    phi[static_cast<Eigen::Index>(i)] = it->second;
  }
  return true;
}

double jointRmse(const Model& model, const estimator::LsqAccumulator& acc, const Eigen::VectorXd& x, long rows) {
  double sum = 0.0;
  for (int c = model.floating_base ? 6 : 0; c < model.nv; ++c) sum += acc.residual(c, x);
  const int joints = model.nv - (model.floating_base ? 6 : 0);
  return rows > 0 ? std::sqrt(sum / (static_cast<double>(rows) * joints)) : 0.0;
}

/// The logged run's ticks and what the batch and the online side share.
struct Comparison {
  const Model& model;
  const std::vector<estimator::AlignedTick>& ticks;
  const BaseParameters& base;
  const Eigen::VectorXd& prior;
  int publish_every;
  int feet[2];
  estimator::DatasetOptions dopt;
  Eigen::VectorXd prior_sigma;  ///< the online estimator's prior stddev of the base parameters (the last replay's)
};

/// Batch: the sensors pipeline (inputs filtered at 30 Hz; the IMU's orientation, gyro and accelerometer, not exoid
/// identify's legs: the comparison's figures in docs/estimator.md were measured so), ticks [from, to) into acc; the rows
/// added (-1: the pipeline refused a sample). With `effects`, the rows go through EffectCorrector first (the
/// effects at their values subtracted from y, gains divided out), so the accumulated residual is that of the
/// rigid part plus the effects.
long accumulateTicks(const Comparison& cmp, size_t from, size_t to, estimator::LsqAccumulator& acc,
                     const estimator::EffectSet* effects = nullptr) {
  using namespace estimator;
  const Model& model = cmp.model;
  long rows = 0;
  const RowSink add = [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) { rows += acc.add(K, y) ? 1 : 0; };
  std::unique_ptr<EffectCorrector> corrector;
  if (effects) corrector = std::make_unique<EffectCorrector>(model, *effects, add);
  const DatasetBuilder* self = nullptr;
  DatasetBuilder builder(model, cmp.dopt, [&](double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y) {
    if (corrector) corrector->add(t, K, y, &self->sensorTorque(), &self->jointPosition());
    else add(t, K, y);
  });
  self = &builder;
  MeasuredSample s;
  std::string err;
  for (size_t i = from; i < to; ++i) {
    const ForcePlateSample* plates[2] = {cmp.ticks[i].plate[0], cmp.ticks[i].plate[1]};
    measuredFromSensors(model, *cmp.ticks[i].state, plates, cmp.feet, s);
    if (!builder.add(s, &err)) return -1L;
  }
  if (!builder.finish(&err)) return -1L;
  if (corrector) corrector->finish();
  acc.flush();
  return rows;
}

/// The online side: the OnlineEstimator over ticks [0, to), publishing like exo_estimator (the WLS-R weights
/// follow its solves); *x: its final base estimate (effect columns after it). False: options refused.
bool replayOnline(Comparison& cmp, size_t to, Eigen::VectorXd& x, const estimator::OnlineEstimatorOptions& opts) {
  estimator::OnlineEstimator est(cmp.model, cmp.base, cmp.prior, opts);
  if (!est.ok()) return false;
  cmp.prior_sigma = est.priorBaseStddev();
  EstimatorOutputSample out;
  est.sizeOutput(out);
  for (size_t i = 0; i < to; ++i) {
    est.addState(*cmp.ticks[i].state);
    est.addPlate(*cmp.ticks[i].plate[0]);
    est.addPlate(*cmp.ticks[i].plate[1]);
    if (est.samplesSincePublication() >= cmp.publish_every) est.fillOutput(out);
  }
  est.fillOutput(out);
  x = out.base_params;
  return true;
}

/// With a diagnose sidecar: the online held-out RMSE with the effect columns' online values applied to the
/// held-out rows, and without the sidecar (rigid). False with c.error.
bool heldoutWithEffects(Comparison& cmp, size_t split, const estimator::LsqAccumulator& held, long held_rows,
                        const Eigen::VectorXd& x_online_train, const estimator::OnlineEstimatorOptions& options,
                        OnlineVsBatch& c) {
  using namespace estimator;
  const int m = cmp.base.rank;
  EffectSet fitted = options.effects;
  int e = 0;
  for (Effect& ef : fitted.effects) {
    if (isMeasurementEffect(ef.kind)) continue;
    ef.value = x_online_train[m + e++];
    c.effect_names.push_back(cmp.model.joint_names[ef.joint] + " " + effectKindName(ef.kind));
    c.effect_values.push_back(ef.value);
  }
  AccumulatorOptions one;
  one.folds = 1;
  LsqAccumulator held_fx(cmp.model, cmp.base, one);
  const long fx_rows = accumulateTicks(cmp, split, cmp.ticks.size(), held_fx, &fitted);
  if (fx_rows <= 0) return c.error = "the dataset pipeline refused the logged samples", false;
  c.heldout_rmse_online = jointRmse(cmp.model, held_fx, x_online_train.head(m), fx_rows);
  OnlineEstimatorOptions rigid = options;
  rigid.effects = EffectSet{};
  Eigen::VectorXd x_rigid;
  if (!replayOnline(cmp, split, x_rigid, rigid)) return c.error = "online estimator options refused", false;
  c.heldout_rmse_online_rigid = jointRmse(cmp.model, held, x_rigid, held_rows);
  return true;
}

/// The live exo_estimator's final estimate (its --final CSV) against the batch and the replay, in base parameters.
void compareLive(const Comparison& cmp, const std::string& live_csv, const Eigen::VectorXd& x_batch,
                 const Eigen::VectorXd& x_replay, OnlineVsBatch& c) {
  Eigen::VectorXd phi_live;
  std::string err;
  if (!live_csv.empty() && readLiveEstimate(live_csv, cmp.model, phi_live, &err)) {
    c.live_read = true;
    const Eigen::VectorXd x_live = cmp.base.base_map * phi_live;
    const double n = std::sqrt(cmp.base.rank);
    c.param_diff_live_batch = (x_live - x_batch).norm() / x_batch.norm();
    c.param_diff_live_replay = (x_live - x_replay).norm() / x_replay.norm();
    c.param_diff_live_batch_sigma = (x_live - x_batch).cwiseQuotient(cmp.prior_sigma).norm() / n;
    c.param_diff_live_replay_sigma = (x_live - x_replay).cwiseQuotient(cmp.prior_sigma).norm() / n;
  } else if (!live_csv.empty()) {
    c.error = err;
  }
}
}  // namespace

OnlineVsBatch compareOnlineBatch(const Model& model, const intake::RunLog& log, const Eigen::VectorXd& prior,
                                 const estimator::OnlineEstimatorOptions& options, int publish_every,
                                 const std::string& live_csv, double train_fraction) {
  using namespace estimator;
  OnlineVsBatch c;
  long skipped = 0;
  const std::vector<AlignedTick> ticks = alignByTick(log.states, log.plates[0], log.plates[1], {}, TickNeeds{}, &skipped);
  c.logged_ticks = static_cast<long>(ticks.size());
  const BaseParameters base = computeBaseParameters(model);
  c.base_params = base.rank;
  if (ticks.size() < 4000) {
    c.error = "too few logged ticks (" + std::to_string(ticks.size()) + ") for a held-out comparison";
    return c;
  }
  const size_t split = static_cast<size_t>(train_fraction * static_cast<double>(ticks.size()));
  c.split_tick = ticks[split].state->tick;
  Comparison cmp{model, ticks, base, prior, publish_every, {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")}, {}, {}};
  cmp.dopt.cutoff_hz = 30.0;
  cmp.dopt.filter = FilterMode::Inputs;
  cmp.dopt.footholds = defaultFootholds(model, options.sole_on_plate);  // where the estimator was told they stand
  LsqAccumulator train(model, base), whole(model, base);
  AccumulatorOptions one;
  one.folds = 1;
  LsqAccumulator held(model, base, one);
  const long held_rows = accumulateTicks(cmp, split, ticks.size(), held);
  if (accumulateTicks(cmp, 0, split, train) < 0 || held_rows <= 0 || accumulateTicks(cmp, 0, ticks.size(), whole) < 0)
    return c.error = "the dataset pipeline refused the logged samples", c;
  IdentifyResult batch_train, batch_whole;
  std::string err;
  if (!identify(train, model, prior, IdentifyOptions{}, nullptr, batch_train, &err) ||
      !identify(whole, model, prior, IdentifyOptions{}, nullptr, batch_whole, &err))
    return c.error = "batch WLS-RC: " + err, c;
  c.batch_rank = batch_train.rank;
  Eigen::VectorXd x_online_train, x_replay;
  if (!replayOnline(cmp, split, x_online_train, options) || !replayOnline(cmp, ticks.size(), x_replay, options))
    return c.error = "online estimator options refused", c;
  const int m = base.rank;
  x_replay.conservativeResize(m);  // the effect columns (if any) come after the base parameters
  cmp.prior_sigma.conservativeResize(m);
  c.param_diff_replay_batch_sigma = (x_replay - batch_whole.phi_base).cwiseQuotient(cmp.prior_sigma).norm() / std::sqrt(base.rank);
  if (options.effects.effects.empty())
    c.heldout_rmse_online = jointRmse(model, held, x_online_train, held_rows);
  else if (!heldoutWithEffects(cmp, split, held, held_rows, x_online_train, options, c))
    return c;
  c.heldout_rmse_batch = jointRmse(model, held, batch_train.phi_base, held_rows);
  c.heldout_rmse_prior = jointRmse(model, held, base.base_map * prior, held_rows);
  compareLive(cmp, live_csv, batch_whole.phi_base, x_replay, c);
  c.computed = true;
  return c;
}

std::string summaryJsonWithEstimator(const std::string& summary_json, bool ran, const OnlineVsBatch& c) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(summary_json);
  nlohmann::ordered_json e;
  e["ran"] = ran;
  if (ran) {
    e["computed"] = c.computed;
    e["error"] = c.error;
    e["logged_ticks"] = c.logged_ticks;
    e["split_tick"] = c.split_tick;
    e["batch_rank"] = c.batch_rank;
    e["base_params"] = c.base_params;
    e["heldout_joint_rmse_online_nm"] = c.heldout_rmse_online;
    e["heldout_joint_rmse_batch_nm"] = c.heldout_rmse_batch;
    e["heldout_joint_rmse_prior_nm"] = c.heldout_rmse_prior;
    if (c.heldout_rmse_online_rigid >= 0.0) {  // exo_estimator --effects: the online estimate with and without
      e["heldout_joint_rmse_online_without_effects_nm"] = c.heldout_rmse_online_rigid;
      nlohmann::ordered_json fx = nlohmann::ordered_json::array();
      for (size_t i = 0; i < c.effect_names.size(); ++i)
        fx.push_back({{"effect", c.effect_names[i]}, {"online_value", c.effect_values[i]}});
      e["effects"] = fx;
    }
    e["live_estimate_read"] = c.live_read;
    e["base_param_diff_live_vs_batch"] = c.param_diff_live_batch;
    e["base_param_diff_live_vs_batch_prior_sigmas"] = c.param_diff_live_batch_sigma;
    e["base_param_diff_live_vs_replay"] = c.param_diff_live_replay;
    e["base_param_diff_live_vs_replay_prior_sigmas"] = c.param_diff_live_replay_sigma;
    e["base_param_diff_replay_vs_batch_prior_sigmas"] = c.param_diff_replay_batch_sigma;
  }
  j["estimator"] = e;
  return j.dump(2) + "\n";
}

std::string onlineVsBatchTable(bool ran, const OnlineVsBatch& c) {
  if (!ran) return "";
  if (!c.computed) return "| online vs batch | not computed: " + c.error + " | |\n";
  auto pct = [&](double v) {
    char b[48];
    if (!c.live_read) return std::string("no live estimate");
    std::snprintf(b, sizeof b, "%.2f %%", 100.0 * v);
    return std::string(b);
  };
  char buf[1600];
  std::snprintf(buf, sizeof buf,
                "| held-out joint-torque RMSE, online / batch WLS-RC (z %d of %d) / prior | %.4f / %.4f / %.4f N m "
                "(online / batch %.3f) | online <= 1.02 x batch |\n"
                "| final online (live) vs batch, base parameters | %s, RMS %.3f prior sigmas | |\n"
                "| final online (replay of the log) vs batch, base parameters | RMS %.3f prior sigmas | |\n"
                "| live estimator (B phi of its consistent phi) vs its replay (base estimate) | %s, RMS %.3f prior sigmas | consistent projection (misfit ratio <= 2) + lost samples |\n",
                c.batch_rank, c.base_params, c.heldout_rmse_online, c.heldout_rmse_batch, c.heldout_rmse_prior,
                c.heldout_rmse_batch > 0 ? c.heldout_rmse_online / c.heldout_rmse_batch : 0.0,
                pct(c.param_diff_live_batch).c_str(), c.param_diff_live_batch_sigma, c.param_diff_replay_batch_sigma,
                pct(c.param_diff_live_replay).c_str(), c.param_diff_live_replay_sigma);
  std::string rows = buf;
  if (c.heldout_rmse_online_rigid >= 0.0) {
    std::string values;
    for (size_t i = 0; i < c.effect_names.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%s%s %.4g", i ? ", " : "", c.effect_names[i].c_str(), c.effect_values[i]);
      values += buf;
    }
    std::snprintf(buf, sizeof buf,
                  "| held-out joint-torque RMSE, online with the --effects sidecar / without | %.4f / %.4f N m | |\n"
                  "| online effect values (training part) | %s | |\n",
                  c.heldout_rmse_online, c.heldout_rmse_online_rigid, values.empty() ? "(gains only)" : values.c_str());
    rows += buf;
  }
  return rows;
}

}  // namespace exoid::tools
