#include "exoid/tools/experiment_summary.hpp"

#include <algorithm>
#include <cstdio>
#include <unordered_map>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/tools/run_table.hpp"

namespace exoid::tools {

namespace {
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5));
  return v[i];
}
}  // namespace

bool summarizeExperiment(const Model& model, const RunLog& log, int moves_planned, double wall_seconds,
                         ExperimentSummary& s, std::string* error) {
  s = ExperimentSummary();
  s.moves_planned = moves_planned;
  if (log.truth.empty() || log.status.empty()) {
    if (error) *error = "the log has no ground truth or no controller status: the run did not start";
    return false;
  }
  const int sole[2] = {model.frameIndex("right_sole"), model.frameIndex("left_sole")};
  if (sole[0] < 0 || sole[1] < 0) {
    if (error) *error = "the model has no right_sole / left_sole frames";
    return false;
  }
  std::unordered_map<int64_t, const ControllerStatusSample*> status;
  for (const auto& st : log.status) status.emplace(st.tick, &st);
  DynamicsData dyn(model);
  Eigen::Vector3d sole0[2];
  const double z0 = log.truth.front().base_position.z();
  double sum_sq = 0.0, true_sum_sq = 0.0;
  long n = 0;
  for (size_t i = 0; i < log.truth.size(); ++i) {
    const GroundTruthSample& t = log.truth[i];
    forwardKinematics(model, dyn.kin, stateFromTruth(model, t));
    centroidal(model, dyn);
    const Eigen::Matrix3d R = t.base_orientation.toRotationMatrix();
    const Eigen::Vector3d com = t.base_position + R * dyn.com;
    for (int side = 0; side < 2; ++side) {
      const Model::Frame& f = model.frames[sole[side]];
      const Eigen::Vector3d p = t.base_position + R * (dyn.kin.p[f.body] + dyn.kin.R[f.body] * f.position);
      if (i == 0) sole0[side] = p;
      s.max_foot_slip_m = std::max(s.max_foot_slip_m, (p - sole0[side]).head<2>().norm());
    }
    if (t.base_position.z() < z0 - 0.25) s.fell = true;
    auto it = status.find(t.tick);
    if (it != status.end() && it->second->move_index >= 0) {
      const double e = (com - it->second->com_ref).norm();
      sum_sq += e * e;
      s.com_max_error_m = std::max(s.com_max_error_m, e);
      const double et = (t.com - it->second->com_ref).norm();  // what the model does not know shows here
      true_sum_sq += et * et;
      s.true_com_max_error_m = std::max(s.true_com_max_error_m, et);
      ++n;
    }
  }
  s.com_rmse_m = n ? std::sqrt(sum_sq / n) : 0.0;
  s.true_com_rmse_m = n ? std::sqrt(true_sum_sq / n) : 0.0;
  std::vector<double> qp, tick;
  for (const auto& st : log.status) {
    if (st.qp_status != QpStatus::NotRun) qp.push_back(st.qp_solve_us);
    tick.push_back(st.tick_us);
  }
  s.qp_solve_us_p50 = percentile(qp, 0.5);
  s.qp_solve_us_p99 = percentile(qp, 0.99);
  s.tick_us_p50 = percentile(tick, 0.5);
  s.tick_us_p99 = percentile(tick, 0.99);
  const ControllerStatusSample& last = log.status.back();
  s.moves_done = last.moves_done;
  s.fallbacks = last.fallbacks;
  s.controller_rejected = last.rejected_inputs;
  s.ticks = static_cast<long>(log.truth.size());
  s.sim_seconds = (log.truth.back().tick - log.truth.front().tick + 1) * 1e-3;
  s.realtime_factor = wall_seconds > 0 ? s.sim_seconds / wall_seconds : 0.0;
  // Lost messages: every sim channel must have every tick of the truth range.
  const int64_t first = log.truth.front().tick, last_tick = log.truth.back().tick;
  const long expected = static_cast<long>(last_tick - first + 1);
  s.missing_ticks = (expected - static_cast<long>(log.truth.size())) + (expected - static_cast<long>(log.states.size())) +
                    (expected - static_cast<long>(log.plates[0].size())) + (expected - static_cast<long>(log.plates[1].size()));
  s.log_rejected = log.rejected;
  EomResidual eom;
  if (eomResidual(model, model.phi, log, eom, nullptr)) s.eom_residual_max_rel = eom.max_relative;
  return true;
}

std::string summaryJson(const ExperimentSummary& s) {
  char buf[2048];
  std::snprintf(buf, sizeof buf,
                "{\n  \"moves_planned\": %d,\n  \"moves_done\": %d,\n  \"fell\": %s,\n  \"com_rmse_m\": %.6g,\n"
                "  \"com_max_error_m\": %.6g,\n  \"true_com_rmse_m\": %.6g,\n"
                "  \"true_com_max_error_m\": %.6g,\n  \"max_foot_slip_m\": %.6g,\n  \"qp_solve_us_p50\": %.4g,\n"
                "  \"qp_solve_us_p99\": %.4g,\n  \"tick_us_p50\": %.4g,\n  \"tick_us_p99\": %.4g,\n"
                "  \"fallbacks\": %ld,\n  \"controller_rejected_inputs\": %ld,\n  \"realtime_factor\": %.4g,\n"
                "  \"sim_seconds\": %.3f,\n  \"ticks\": %ld,\n  \"missing_ticks\": %ld,\n  \"log_rejected_events\": %ld,\n"
                "  \"eom_residual_max_rel\": %.3g\n}\n",
                s.moves_planned, s.moves_done, s.fell ? "true" : "false", s.com_rmse_m, s.com_max_error_m,
                s.true_com_rmse_m, s.true_com_max_error_m, s.max_foot_slip_m, s.qp_solve_us_p50, s.qp_solve_us_p99, s.tick_us_p50, s.tick_us_p99, s.fallbacks,
                s.controller_rejected, s.realtime_factor, s.sim_seconds, s.ticks, s.missing_ticks, s.log_rejected,
                s.eom_residual_max_rel);
  return buf;
}

std::string summaryTable(const ExperimentSummary& s) {
  char buf[2048];
  std::snprintf(buf, sizeof buf,
                "| metric | value | target |\n|---|---|---|\n"
                "| moves done | %d / %d | all |\n| fell | %s | no |\n"
                "| CoM tracking RMSE (model CoM) | %.2f mm (max %.2f mm) | <= 5 mm |\n"
                "| true CoM vs reference RMSE | %.2f mm (max %.2f mm) | |\n| max foot slip | %.3f mm | <= 1 mm |\n"
                "| QP solve p50 / p99 | %.1f / %.1f us | |\n| controller tick p50 / p99 | %.1f / %.1f us | p99 <= 250 us |\n"
                "| fallback ticks | %ld | 0 |\n| rejected inputs (controller) | %ld | 0 |\n"
                "| real-time factor | %.2fx (%.1f s simulated) | >= 5x |\n| missing ticks (all sim channels) | %ld | 0 |\n"
                "| EoM residual max rel (W phi_model - y) | %.2g | <= 1e-8 without noise/effects |\n",
                s.moves_done, s.moves_planned, s.fell ? "yes" : "no", 1e3 * s.com_rmse_m, 1e3 * s.com_max_error_m,
                1e3 * s.true_com_rmse_m, 1e3 * s.true_com_max_error_m, 1e3 * s.max_foot_slip_m, s.qp_solve_us_p50, s.qp_solve_us_p99, s.tick_us_p50, s.tick_us_p99,
                s.fallbacks, s.controller_rejected, s.realtime_factor, s.sim_seconds, s.missing_ticks,
                s.eom_residual_max_rel);
  return buf;
}

}  // namespace exoid::tools
