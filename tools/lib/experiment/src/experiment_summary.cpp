#include "exoid/tools/experiment_summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "exoid/estimator/measurement.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
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

// Ticks of [0, n) that a channel lacks (duplicates and ticks outside the range do not make up for them).
template <class Sample>
long missingIn(const std::vector<Sample>& samples, int64_t n) {
  std::vector<bool> seen(static_cast<size_t>(std::max<int64_t>(n, 0)), false);
  long present = 0;
  for (const Sample& s : samples)
    if (s.tick >= 0 && s.tick < n && !seen[static_cast<size_t>(s.tick)]) seen[static_cast<size_t>(s.tick)] = true, ++present;
  return static_cast<long>(n) - present;
}

// Truth-channel figures: CoM tracking against the controller's reference, foot slip, fall.
void truthFigures(const Model& model, const intake::RunLog& log, const ControllerFrame& frame, ExperimentSummary& s,
                  int64_t* first_drop_tick) {
  const int sole[2] = {model.frameIndex("right_sole"), model.frameIndex("left_sole")};
  if (log.truth.empty() || sole[0] < 0 || sole[1] < 0) return;
  std::unordered_map<int64_t, const ControllerStatusSample*> status;
  for (const auto& st : log.status) status.emplace(st.tick, &st);
  DynamicsData dyn(model);
  Eigen::Vector3d sole0[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  const double z0 = log.truth.front().base_position.z();
  double sum_sq = 0.0, true_sum_sq = 0.0, true_xy_sq = 0.0, true_rel_sq = 0.0, z_offset = 0.0, settled_xy_sq = 0.0;
  long n = 0;
  // The trunk's sums: angles and the upper body's CoM in the pelvis frame, each and squared, about the first move
  // tick's values (shifted: the raw moments would cancel to 1e-8 of a 0.3 m offset).
  Eigen::Vector3d angle_sum = Eigen::Vector3d::Zero(), angle_sq = Eigen::Vector3d::Zero(), angle0 = angle_sq;
  Eigen::Vector3d trunk_sum = Eigen::Vector3d::Zero(), trunk_sq = Eigen::Vector3d::Zero(), trunk0 = trunk_sq;
  long n_trunk = 0;
  bool frame_set = frame.latch_tick < 0;  // unknown frame: the offset stays zero
  for (size_t i = 0; i < log.truth.size(); ++i) {
    const GroundTruthSample& t = log.truth[i];
    forwardKinematics(model, dyn.kin, stateFromTruth(model, t));
    centroidal(model, dyn);
    const Eigen::Matrix3d R = t.base_orientation.toRotationMatrix();
    double sole_z = 0.0;
    Eigen::Vector2d sole_xy_offset = Eigen::Vector2d::Zero();  // the true soles minus the controller's, mean
    for (int side = 0; side < 2; ++side) {
      const Model::Frame& f = model.frames[sole[side]];
      const Eigen::Vector3d p = t.base_position + R * (dyn.kin.p[f.body] + dyn.kin.R[f.body] * f.position);
      if (i == 0) sole0[side] = p;
      s.max_foot_slip_m = std::max(s.max_foot_slip_m, (p - sole0[side]).head<2>().norm());
      sole_z += 0.5 * p.z();
      sole_xy_offset += 0.5 * (p.head<2>() - frame.sole_xy[side]);
    }
    // The controller's world is fixed at the latch tick (or the first logged tick after it): by the soles where it
    // latched them when they are known (ControllerFrame::has_soles), else by its base.
    if (!frame_set && t.tick >= frame.latch_tick) {
      s.frame_offset_m << (frame.has_soles ? sole_xy_offset : Eigen::Vector2d(t.base_position.head<2>() - frame.base_xy)),
          sole_z - frame.ground_height;
      frame_set = true;
    }
    const Eigen::Vector3d com = t.base_position + R * dyn.com - s.frame_offset_m;  // the controller's world
    const Eigen::Vector3d true_com = t.com - s.frame_offset_m;
    if (t.base_position.z() < z0 - 0.25 && *first_drop_tick < 0) *first_drop_tick = t.tick;
    auto it = status.find(t.tick);
    if (it != status.end() && it->second->move_index >= 0) {
      const double e = (com - it->second->com_ref).norm();
      sum_sq += e * e;
      s.com_max_error_m = std::max(s.com_max_error_m, e);
      const double et = (true_com - it->second->com_ref).norm();  // what the model does not know shows here
      true_sum_sq += et * et;
      true_xy_sq += (true_com - it->second->com_ref).head<2>().squaredNorm();
      if (t.tick >= ExperimentSummary::kSettleTicks) {
        settled_xy_sq += (true_com - it->second->com_ref).head<2>().squaredNorm();
        ++s.settled_ticks;
      }
      if (n == 0) z_offset = true_com.z() - it->second->com_ref.z();
      const double ez = true_com.z() - it->second->com_ref.z() - z_offset;
      true_rel_sq += (true_com - it->second->com_ref).head<2>().squaredNorm() + ez * ez;
      s.true_com_max_error_m = std::max(s.true_com_max_error_m, et);
      if (t.has_trunk) {
        const Eigen::Vector3d c = R.transpose() * (t.trunk_com - t.base_position);
        if (!s.has_trunk) {
          angle0 = t.trunk_angle;
          trunk0 = c;
          s.has_trunk = true;
        }
        angle_sum += t.trunk_angle - angle0;
        angle_sq += (t.trunk_angle - angle0).cwiseAbs2();
        trunk_sum += c - trunk0;
        trunk_sq += (c - trunk0).cwiseAbs2();
        ++n_trunk;
      }
      ++n;
    }
  }
  if (s.has_trunk) {  // RMS about the mean: sqrt(E[x^2] - E[x]^2), clamped at 0 against rounding
    const double k = static_cast<double>(n_trunk);
    s.trunk_angle_mean_rad = angle0 + angle_sum / k;
    s.trunk_angle_rms_rad = (angle_sq / k - (angle_sum / k).cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
    s.trunk_com_rms_m = (trunk_sq / k - (trunk_sum / k).cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
  }
  s.com_rmse_m = n ? std::sqrt(sum_sq / n) : 0.0;
  s.true_com_rmse_m = n ? std::sqrt(true_sum_sq / n) : 0.0;
  s.true_com_rmse_xy_m = n ? std::sqrt(true_xy_sq / n) : 0.0;
  s.true_com_rmse_rel_m = n ? std::sqrt(true_rel_sq / n) : 0.0;
  s.true_com_rmse_xy_settled_m = s.settled_ticks ? std::sqrt(settled_xy_sq / static_cast<double>(s.settled_ticks)) : 0.0;
}
// The controller's joint-torque prediction error (see ExperimentSummary) and the estimate's use.
void torquePrediction(const Model& model, const intake::RunLog& log, const Eigen::VectorXd& phi_ctrl, ExperimentSummary& s) {
  const int feet[2] = {model.bodyIndex("right_foot"), model.bodyIndex("left_foot")};
  for (const auto& c : log.commands)
    if (c.tau_ff.size() == model.njoints && c.tau_ff.cwiseAbs().maxCoeff() > 0.0) ++s.estimate_in_use_ticks;
  if (feet[0] < 0 || feet[1] < 0 || !model.floating_base || phi_ctrl.size() != model.nparams()) return;
  std::unordered_map<int64_t, const JointCommandSample*> command;
  for (const auto& c : log.commands)
    if (c.tau.size() == model.njoints && c.tau_ff.size() == model.njoints) command[c.tick] = &c;
  std::unordered_map<int64_t, int> move;
  for (const auto& st : log.status) move[st.tick] = st.move_index;
  // Joints the controller drives: those it ever commands a non-zero torque to (passive joints get 0).
  std::vector<bool> driven(static_cast<size_t>(model.njoints), false);
  for (const auto& [tick, c] : command)
    for (int j = 0; j < model.njoints; ++j) driven[j] = driven[j] || c->tau[j] != 0.0;
  Data kin(model);
  Eigen::VectorXd y(model.nv);
  double sum_ff = 0.0, sum_model = 0.0;
  long n = 0;
  for (const GroundTruthSample& t : log.truth) {
    auto c = command.find(t.tick);
    auto mv = move.find(t.tick);
    if (c == command.end() || mv == move.end() || mv->second < 0 || t.tau_applied.size() != model.njoints) continue;
    const State state = stateFromTruth(model, t);
    computeJointTorqueRegressor(model, kin, state);
    ExternalWrench w[2];
    for (int side = 0; side < 2; ++side) {
      w[side].body = feet[side];
      w[side].force = t.foot_force[side];
      w[side].moment_world_origin = t.foot_moment[side];
    }
    // y = S^T tau_applied + sum J^T w: the joint rows of y - K phi are tau_applied minus the model's prediction.
    generalizedForceFromMeasurements(model, kin, state, t.tau_applied, w, 2, y);
    const Eigen::VectorXd e = y - kin.K * phi_ctrl;
    for (int j = 0; j < model.njoints; ++j) {
      if (!driven[j]) continue;
      const double em = e[model.nv - model.njoints + j];
      const double ef = em - c->second->tau_ff[j];
      sum_model += em * em;
      sum_ff += ef * ef;
      ++n;
    }
    ++s.torque_prediction_ticks;
  }
  if (n == 0) return;
  s.joint_torque_prediction_rmse_nm = std::sqrt(sum_ff / n);
  s.joint_torque_model_rmse_nm = std::sqrt(sum_model / n);
}

// Estimates in the log; the mid-run payload's mass response.
void estimateFigures(const Model& model, const intake::RunLog& log, const RunFacts& f, ExperimentSummary& s) {
  s.payload_attach_s = f.payload_attach_s;
  s.payload_mass_kg = f.payload_mass_kg;
  std::vector<std::pair<int64_t, double>> mass;  // (tick, estimated total mass)
  for (const auto& e : log.estimates) {
    ++s.estimate_messages;
    if (e.valid) ++s.estimate_valid_messages;
    if (e.params.size() != model.nparams()) continue;
    double m = 0.0;
    for (int b = 0; b < model.nbodies; ++b) m += e.params[model.bodyParamIndex(b)];
    mass.emplace_back(e.tick, m);
  }
  if (f.payload_attach_s <= 0.0 || mass.empty()) return;
  std::sort(mass.begin(), mass.end());
  const int64_t attach = std::llround(f.payload_attach_s * 1000.0);
  double before = 0.0;
  long nb = 0;
  for (const auto& [tick, m] : mass)
    if (tick >= attach - 1000 && tick < attach) before += m, ++nb;
  if (nb == 0) return;
  s.payload_mass_before_kg = before / nb;
  s.payload_mass_final_kg = mass.back().second;
  for (const auto& [tick, m] : mass)
    if (tick >= attach && m - s.payload_mass_before_kg >= 0.95 * f.payload_mass_kg) {
      s.payload_mass_response_s = (tick - attach) * 1e-3;
      break;
    }
}

// What the sim reported of itself (its ticks, fallbacks, real-time factor, loop timing); unknown without its report.
void simFigures(const RunFacts& f, ExperimentSummary& s) {
  s.sim_reported = f.sim_reported;
  s.ticks_simulated = f.sim_reported ? f.sim_ticks : f.ticks_planned;
  s.sim_seconds = s.ticks_simulated * 1e-3;
  s.realtime_factor = f.sim_reported ? f.sim_realtime_factor : 0.0;
  s.sim_held_ticks = f.sim_reported ? f.sim_held_ticks : -1;
  s.sim_zero_ticks = f.sim_reported ? f.sim_zero_ticks : -1;
  s.sim_timeouts = f.sim_reported ? f.sim_timeouts : -1;
  s.timing = f.sim_timing;
}

/// summaryTable's rows of the sim's loop timing (docs/sim.md, "Loop timing").
std::string loopTimingRows(const ExperimentSummary& s) {
  if (!s.sim_reported) return "| loop timing | unknown (no sim report) | |\n";
  const sim::LoopTiming& t = s.timing;
  char misses[48] = "n/a (lockstep)", delay[48] = "n/a (lockstep)", plugin[200] = "no plugin (controller process: its tick above)";
  if (t.deadline_misses >= 0) std::snprintf(misses, sizeof misses, "%lld", static_cast<long long>(t.deadline_misses));
  if (t.start_delay_ms_max >= 0) std::snprintf(delay, sizeof delay, "%.3f ms", t.start_delay_ms_max);
  if (t.plugin_calls > 0)
    std::snprintf(plugin, sizeof plugin, "%.1f / %.1f us (cpu %.1f us); %lld; %lld", t.plugin_call_us_mean,
                  t.plugin_call_us_max, t.plugin_call_cpu_us_max, static_cast<long long>(t.plugin_budget_overruns),
                  static_cast<long long>(t.plugin_fallback_ticks));
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "| loop overruns (tick work > 1 ms) / deadline misses (work ended after its 1 ms slot) | %lld / %s |%s|\n"
                "| loop worst tick, wall (cpu) / mean; latest start after its slot | %.3f ms (%.3f ms) / %.3f ms; %s |%s|\n"
                "| loop thread preemptions / page faults during the run | %lld / %lld | |\n"
                "| plugin call mean / max (cpu max); over budget; host fallback ticks | %s | |\n",
                static_cast<long long>(t.overruns), misses, s.lockstep ? " " : " 0 / 0 ", t.tick_ms_max, t.tick_cpu_ms_max,
                t.tick_ms_mean, delay, s.lockstep ? " " : " <= 1 ms ",  // lockstep is not paced: no real-time target
                static_cast<long long>(t.preemptions), static_cast<long long>(t.page_faults), plugin);
  return buf;
}
}  // namespace

ExperimentSummary summarizeExperiment(const Model& model, const intake::RunLog& log, const RunFacts& f) {
  ExperimentSummary s;
  s.moves_planned = f.moves_planned;
  s.lockstep = f.lockstep;
  s.estimate_feedback = f.estimate_feedback;
  s.ticks_planned = f.ticks_planned;
  simFigures(f, s);
  s.failures = f.failures;

  int64_t first_drop_tick = -1;
  if (f.log_readable) truthFigures(model, log, f.controller_frame, s, &first_drop_tick);
  s.fall_tick = f.sim_reported ? f.sim_fall_tick : first_drop_tick;
  s.fell = s.fall_tick >= 0;
  s.fall_time_s = s.fell ? s.fall_tick * 1e-3 : -1.0;

  // Controller figures; moves count up to the fall only.
  std::vector<double> qp, tick;
  const ControllerStatusSample* at_end = nullptr;
  for (const auto& st : log.status) {
    if (st.qp_status != QpStatus::NotRun) qp.push_back(st.qp_solve_us);
    tick.push_back(st.tick_us);
    if (!s.fell || st.tick <= s.fall_tick)
      if (!at_end || st.tick >= at_end->tick) at_end = &st;
  }
  s.qp_solve_us_p50 = percentile(qp, 0.5);
  s.qp_solve_us_p99 = percentile(qp, 0.99);
  s.tick_us_p50 = percentile(tick, 0.5);
  s.tick_us_p99 = percentile(tick, 0.99);
  s.tick_us_max = tick.empty() ? 0.0 : *std::max_element(tick.begin(), tick.end());
  if (at_end) {
    s.moves_done = at_end->moves_done;
    if (s.fell) s.fall_during_move = at_end->move_index >= s.moves_planned ? s.moves_planned : at_end->move_index;
  }
  if (!log.status.empty()) {  // fallbacks and rejections over the whole run, also after a fall
    s.controller_fallbacks = std::max_element(log.status.begin(), log.status.end(), [](auto& a, auto& b) {
                               return a.fallbacks < b.fallbacks;
                             })->fallbacks;
    s.controller_rejected = std::max_element(log.status.begin(), log.status.end(), [](auto& a, auto& b) {
                              return a.rejected_inputs < b.rejected_inputs;
                            })->rejected_inputs;
  }

  // The log against what the sim simulated (not against what the log happens to hold).
  s.ticks_logged = static_cast<int64_t>(log.truth.size());
  const int64_t n = s.ticks_simulated;
  s.missing_ticks = missingIn(log.truth, n) + missingIn(log.states, n) + missingIn(log.plates[0], n) + missingIn(log.plates[1], n);
  s.log_rejected = log.rejected;
  s.log_corrupt_events = log.damage.corrupt_events;
  s.log_damage = log.damageReport();
  if (!f.log_readable) {
    s.failures.push_back("the log could not be read: " + f.log_error);
  } else {
    if (s.missing_ticks > 0) {
      char buf[300];
      std::snprintf(buf, sizeof buf,
                    "log incomplete: %ld of %lld sim-channel ticks missing (%s %lld ticks; the log's truth channel "
                    "holds %lld, up to tick %lld)",
                    s.missing_ticks, 4LL * static_cast<long long>(n),
                    f.sim_reported ? "the sim ran" : "the sim did not report its count; planned",
                    static_cast<long long>(n), static_cast<long long>(s.ticks_logged),
                    static_cast<long long>(log.truth.empty() ? -1 : log.truth.back().tick));
      s.failures.push_back(buf);
    }
    if (!log.intact()) s.failures.push_back("log damaged: " + s.log_damage);
  }
  s.log_complete = f.log_readable && s.missing_ticks == 0 && log.intact();
  EomResidual eom;
  if (f.log_readable && eomResidual(model, model.phi, log, eom, nullptr)) s.eom_residual_max_rel = eom.max_relative;
  if (f.log_readable) {
    torquePrediction(model, log, f.controller_phi.size() ? f.controller_phi : model.phi, s);
    estimateFigures(model, log, f, s);
  }

  s.outcome = f.interrupted ? "interrupted" : !s.failures.empty() ? "failed" : s.fell ? "fell" : "completed";
  return s;
}

std::string summaryJson(const ExperimentSummary& s) {
  nlohmann::ordered_json j;
  j["outcome"] = s.outcome;
  j["failures"] = s.failures;
  j["moves_planned"] = s.moves_planned;
  j["moves_done"] = s.moves_done;
  j["fell"] = s.fell;
  j["fall_tick"] = s.fall_tick;
  j["fall_time_s"] = s.fall_time_s;
  j["fall_during_move"] = s.fall_during_move;
  j["com_rmse_m"] = s.com_rmse_m;
  j["com_max_error_m"] = s.com_max_error_m;
  j["true_com_rmse_m"] = s.true_com_rmse_m;
  j["true_com_max_error_m"] = s.true_com_max_error_m;
  j["true_com_rmse_xy_m"] = s.true_com_rmse_xy_m;
  j["true_com_rmse_rel_m"] = s.true_com_rmse_rel_m;
  j["true_com_rmse_xy_settled_m"] = s.true_com_rmse_xy_settled_m;
  j["max_foot_slip_m"] = s.max_foot_slip_m;
  j["frame_offset_m"] = {s.frame_offset_m.x(), s.frame_offset_m.y(), s.frame_offset_m.z()};
  if (s.has_trunk) {
    const auto v3 = [](const Eigen::Vector3d& v) { return std::vector<double>{v.x(), v.y(), v.z()}; };
    j["trunk_angle_mean_rad"] = v3(s.trunk_angle_mean_rad);
    j["trunk_angle_rms_rad"] = v3(s.trunk_angle_rms_rad);
    j["trunk_com_rms_m"] = v3(s.trunk_com_rms_m);
  }
  j["qp_solve_us_p50"] = s.qp_solve_us_p50;
  j["qp_solve_us_p99"] = s.qp_solve_us_p99;
  j["tick_us_p50"] = s.tick_us_p50;
  j["tick_us_p99"] = s.tick_us_p99;
  j["tick_us_max"] = s.tick_us_max;
  j["controller_fallbacks"] = s.controller_fallbacks;
  j["sim_held_ticks"] = s.sim_held_ticks;
  j["sim_zero_ticks"] = s.sim_zero_ticks;
  j["sim_timeouts"] = s.sim_timeouts;
  j["controller_rejected_inputs"] = s.controller_rejected;
  j["realtime_factor"] = s.realtime_factor;
  if (s.sim_reported) {  // the sim's loop timing (docs/sim.md, "Loop timing"), as in its sim_result.json
    nlohmann::ordered_json t;
    sim::forEachTimingField(s.timing, [&](const char* key, const auto& v) { t[key] = v; });
    j["loop_timing"] = t;
  } else {
    j["loop_timing"] = nullptr;
  }
  j["mode"] = s.lockstep ? "lockstep" : "realtime";
  j["sim_seconds"] = s.sim_seconds;
  j["ticks_planned"] = s.ticks_planned;
  j["sim_reported"] = s.sim_reported;
  j["ticks_simulated"] = s.ticks_simulated;
  j["ticks_logged"] = s.ticks_logged;
  j["missing_ticks"] = s.missing_ticks;
  j["log_complete"] = s.log_complete;
  j["log_damage"] = s.log_damage;
  j["log_rejected_events"] = s.log_rejected;
  j["log_corrupt_events"] = s.log_corrupt_events;
  j["eom_residual_max_rel"] = s.eom_residual_max_rel;
  j["joint_torque_prediction_rmse_nm"] = s.joint_torque_prediction_rmse_nm;
  j["joint_torque_model_rmse_nm"] = s.joint_torque_model_rmse_nm;
  j["torque_prediction_ticks"] = s.torque_prediction_ticks;
  j["estimate_messages"] = s.estimate_messages;
  j["estimate_valid_messages"] = s.estimate_valid_messages;
  j["estimate_feedback"] = s.estimate_feedback;
  j["estimate_in_use_ticks"] = s.estimate_in_use_ticks;
  if (s.payload_attach_s > 0.0) {
    j["payload_attach_s"] = s.payload_attach_s;
    j["payload_mass_kg"] = s.payload_mass_kg;
    j["payload_mass_response_s"] = s.payload_mass_response_s;
    j["payload_mass_before_kg"] = s.payload_mass_before_kg;
    j["payload_mass_final_kg"] = s.payload_mass_final_kg;
  }
  return j.dump(2) + "\n";
}

std::string summaryTable(const ExperimentSummary& s) {
  char buf[4096];
  char fall[160] = "no";
  if (s.fell) {
    if (s.fall_during_move < 0)
      std::snprintf(fall, sizeof fall, "yes, at t %.3f s (tick %lld), before the first move", s.fall_time_s,
                    static_cast<long long>(s.fall_tick));
    else if (s.fall_during_move >= s.moves_planned)
      std::snprintf(fall, sizeof fall, "yes, at t %.3f s (tick %lld), after the last move", s.fall_time_s,
                    static_cast<long long>(s.fall_tick));
    else
      std::snprintf(fall, sizeof fall, "yes, at t %.3f s (tick %lld), during move %d (after %d completed)",
                    s.fall_time_s, static_cast<long long>(s.fall_tick), s.fall_during_move + 1, s.moves_done);
  }
  char sim_fb[96] = "unknown (no sim report)";
  if (s.sim_held_ticks >= 0)
    std::snprintf(sim_fb, sizeof sim_fb, "%ld held, %ld zero (%ld timeouts)", s.sim_held_ticks, s.sim_zero_ticks,
                  s.sim_timeouts);
  char rtf[96] = "unknown (no sim report)";
  if (s.realtime_factor > 0)
    std::snprintf(rtf, sizeof rtf, "%.2fx (%.1f s simulated)", s.realtime_factor, s.sim_seconds);
  std::snprintf(buf, sizeof buf,
                "| metric | value | target |\n|---|---|---|\n"
                "| outcome | %s | completed |\n"
                "| moves done | %d / %d | all |\n| fell | %s | no |\n"
                "| CoM tracking RMSE (model CoM) | %.2f mm (max %.2f mm) | <= 5 mm |\n"
                "| true CoM vs reference RMSE (controller's world: the truth moved by %.2f, %.2f, %.2f mm) | %.2f mm (max %.2f mm; horizontal RMSE %.2f mm, %.2f mm from 10 s on; height relative to the start %.2f mm) | |\n| max foot slip | %.3f mm | <= 1 mm |\n"
                "| QP solve p50 / p99 | %.1f / %.1f us | |\n| controller tick p50 / p99 / max | %.1f / %.1f / %.1f us | p99 <= 250 us |\n"
                "| fallback ticks (controller) | %ld | 0 |\n| fallback ticks (sim) | %s | 0 |\n"
                "| rejected inputs (controller) | %ld | 0 |\n"
                "| real-time factor | %s | %s |\n"
                "| ticks simulated / planned | %s / %lld | all |\n"
                "| missing ticks (4 sim channels, of the simulated ticks) | %ld | 0 |\n"
                "| log | %s | complete |\n"
                "| EoM residual max rel (W phi_model - y) | %.2g | <= 1e-8 without noise/effects |\n",
                s.outcome.c_str(), s.moves_done, s.moves_planned, fall, 1e3 * s.com_rmse_m, 1e3 * s.com_max_error_m,
                -1e3 * s.frame_offset_m.x(), -1e3 * s.frame_offset_m.y(), -1e3 * s.frame_offset_m.z(),
                1e3 * s.true_com_rmse_m, 1e3 * s.true_com_max_error_m, 1e3 * s.true_com_rmse_xy_m,
                1e3 * s.true_com_rmse_xy_settled_m, 1e3 * s.true_com_rmse_rel_m, 1e3 * s.max_foot_slip_m, s.qp_solve_us_p50, s.qp_solve_us_p99, s.tick_us_p50, s.tick_us_p99, s.tick_us_max,
                s.controller_fallbacks, sim_fb, s.controller_rejected, rtf, s.lockstep ? ">= 5x (lockstep)" : "",
                s.sim_reported ? std::to_string(s.ticks_simulated).c_str() : "unknown (no sim report)",
                static_cast<long long>(s.ticks_planned), s.missing_ticks,
                s.log_complete ? "complete" : ("INCOMPLETE" + (s.log_damage.empty() ? "" : ": " + s.log_damage)).c_str(),
                s.eom_residual_max_rel);
  std::string out = buf + loopTimingRows(s);
  if (s.has_trunk) {
    const Eigen::Vector3d& a = s.trunk_angle_mean_rad;
    const Eigen::Vector3d& r = s.trunk_angle_rms_rad;
    const Eigen::Vector3d c = 1e3 * s.trunk_com_rms_m;
    std::snprintf(buf, sizeof buf,
                  "| wearer's trunk on the pelvis (truth): lumbar angle x, y, z mean; RMS about it | %.4f, %.4f, %.4f "
                  "rad; %.4f, %.4f, %.4f rad | |\n"
                  "| its CoM's move on the pelvis (pelvis frame x, y, z), RMS | %.2f, %.2f, %.2f mm | |\n",
                  a.x(), a.y(), a.z(), r.x(), r.y(), r.z(), c.x(), c.y(), c.z());
    out += buf;
  }
  if (s.joint_torque_prediction_rmse_nm >= 0.0) {
    std::snprintf(buf, sizeof buf,
                  "| joint-torque prediction error (controller's model + all it fed forward; model alone) | "
                  "%.3f N m; %.3f N m | |\n"
                  "| EXO_ESTIMATE messages (valid) / fed back to the controller / ticks with a feedforward | "
                  "%ld (%ld) / %s / %ld | |\n",
                  s.joint_torque_prediction_rmse_nm, s.joint_torque_model_rmse_nm, s.estimate_messages,
                  s.estimate_valid_messages, s.estimate_feedback ? "yes" : "no", s.estimate_in_use_ticks);
    out += buf;
  }
  if (s.payload_attach_s > 0.0 && s.estimate_messages > 0) {
    char resp[64] = "never";
    if (s.payload_mass_response_s >= 0.0) std::snprintf(resp, sizeof resp, "%.2f s", s.payload_mass_response_s);
    std::snprintf(buf, sizeof buf,
                  "| mid-run payload %.2f kg at %.1f s: estimated total mass to 95 %% of it | %s (%.3f -> %.3f kg) | "
                  "<= 5 s |\n",
                  s.payload_mass_kg, s.payload_attach_s, resp, s.payload_mass_before_kg, s.payload_mass_final_kg);
    out += buf;
  }
  for (const std::string& f : s.failures) out += "\nFAILED: " + f;
  if (!s.failures.empty()) out += "\n";
  return out;
}

}  // namespace exoid::tools
