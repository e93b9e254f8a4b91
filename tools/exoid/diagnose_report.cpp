// `exoid diagnose`'s writers (diagnose_report.hpp).
#include "diagnose_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "diagnose_predictability.hpp"
#include "diagnose_unmeasured_body.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/render/run_keyframes.hpp"
#include "exoid/tools/urdf_inertials.hpp"
#include "exoid/common/fail.hpp"

namespace exoid::cli {

namespace est = exoid::estimator;
namespace fs = std::filesystem;

namespace diagnose_report {  // this file's own names: the exoid binary is a unity build
// A candidate with less of its signal than this outside the declared model's span is reported as not visible.
constexpr double kHiddenSeparable = 0.01;

// Plots from the CSVs this command writes (matplotlib, headless).
constexpr char kPlotScript[] = R"PY(#!/usr/bin/env python3
# Plots of `exoid diagnose` from the CSVs next to this script (written by exoid; docs/diagnose.md).
import csv, math, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))

def read(name):
    with open(os.path.join(here, name)) as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]

h, rows = read("rmse.csv")
names = [r[0] for r in rows]
before = np.array([float(r[1]) for r in rows]); after = np.array([float(r[2]) for r in rows])
x = np.arange(len(names))
fig, ax = plt.subplots(figsize=(max(6, 0.9 * len(names) + 2), 4))
ax.bar(x - 0.2, before, 0.4, label="declared model")
ax.bar(x + 0.2, after, 0.4, label="with the accepted effects")
ax.set_xticks(x); ax.set_xticklabels(names, rotation=30, ha="right")
ax.set_ylabel("held-out torque RMSE (N m)"); ax.legend(); ax.grid(axis="y", alpha=0.3)
ax.set_title("Torque prediction error per coordinate (held-out data)")
fig.tight_layout(); fig.savefig(os.path.join(here, "rmse.png"), dpi=110); plt.close(fig)

_, sig = read("signals.csv")  # coordinate, kind, label
h, rows = read(sys.argv[1] if len(sys.argv) > 1 else "residual_plot.csv")
data = np.array([[float(c) for c in r] for r in rows])
col = {n: i for i, n in enumerate(h)}
t = data[:, col["t"]]
n = len(sig); nc = min(4, n); nr = int(math.ceil(n / nc))
fig, axes = plt.subplots(nr, nc, figsize=(4 * nc, 3.2 * nr), squeeze=False)
step = max(1, len(t) // 3000)
for k, (name, kind, label) in enumerate(sig):
    ax = axes[k // nc][k % nc]
    s = data[::step, col["sig_" + name]]
    ax.plot(s, data[::step, col["before_" + name]], ".", ms=1.5, alpha=0.4, label="before")
    ax.plot(s, data[::step, col["after_" + name]], ".", ms=1.5, alpha=0.4, label="after")
    ax.set_title(name, fontsize=9); ax.set_xlabel(label, fontsize=8); ax.set_ylabel("residual (N m)", fontsize=8)
    ax.grid(alpha=0.3)
    if k == 0: ax.legend(markerscale=6, fontsize=7)
for k in range(n, nr * nc): axes[k // nc][k % nc].axis("off")
fig.suptitle("Residual against the chosen candidate signal, before and after augmentation (held-out data)")
fig.tight_layout(); fig.savefig(os.path.join(here, "residual_vs_signal.png"), dpi=100); plt.close(fig)

# Spectra: resampled to the mean sample time (the timestamps may jitter), Welch with Hann windows.
dt = (t[-1] - t[0]) / max(len(t) - 1, 1)
tu = t[0] + dt * np.arange(len(t))
def welch(r):
    r = np.interp(tu, t, r); r = r - r.mean()
    nseg = min(1024, len(r)); hop = nseg // 2; w = np.hanning(nseg)
    acc = None; cnt = 0
    for s0 in range(0, len(r) - nseg + 1, hop):
        X = np.fft.rfft(w * r[s0:s0 + nseg]); p = (np.abs(X) ** 2) * dt / (w ** 2).sum()
        p[1:-1] *= 2; acc = p if acc is None else acc + p; cnt += 1
    return np.fft.rfftfreq(nseg, dt), acc / cnt
fig, axes = plt.subplots(nr, nc, figsize=(4 * nc, 3.2 * nr), squeeze=False)
for k, (name, kind, label) in enumerate(sig):
    ax = axes[k // nc][k % nc]
    f, pb = welch(data[:, col["before_" + name]]); _, pa = welch(data[:, col["after_" + name]])
    ax.loglog(f[1:], pb[1:], lw=0.8, label="before"); ax.loglog(f[1:], pa[1:], lw=0.8, label="after")
    ax.set_title(name, fontsize=9); ax.set_xlabel("frequency (Hz)", fontsize=8); ax.set_ylabel("PSD (N^2 m^2 / Hz)", fontsize=8)
    ax.grid(alpha=0.3, which="both")
    if k == 0: ax.legend(fontsize=7)
for k in range(n, nr * nc): axes[k // nc][k % nc].axis("off")
fig.suptitle("Residual spectra before and after augmentation (held-out data)")
fig.tight_layout(); fig.savefig(os.path.join(here, "spectra.png"), dpi=100); plt.close(fig)
)PY";

std::string safeName(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return s;
}

std::string signalLabel(const Model& model, const est::Effect& e, const est::EffectShape& shape) {
  char buf[512];
  switch (e.kind) {
    case est::EffectKind::Viscous: return "v (rad/s)";
    case est::EffectKind::Coulomb: std::snprintf(buf, sizeof buf, "tanh(v / %g)", shape.coulomb_width); return buf;
    case est::EffectKind::Stribeck:
      std::snprintf(buf, sizeof buf, "tanh(v/%g) exp(-(v/%g)^2)", shape.coulomb_width, shape.stribeck_velocity);
      return buf;
    case est::EffectKind::Offset: return "v (rad/s; offset: constant signal)";
    case est::EffectKind::Armature: return "dv/dt (rad/s^2)";
    case est::EffectKind::GainError: return "model torque (N m)";
    case est::EffectKind::Delay: return "-d/dt model torque (N m/s)";
    case est::EffectKind::Elastic: std::snprintf(buf, sizeof buf, "q - %.3g (rad)", shape.center); return buf;
    case est::EffectKind::ElasticCoupled:
      std::snprintf(buf, sizeof buf, "q_%s - %.3g (rad)", model.joint_names[e.coupled].c_str(), shape.center);
      return buf;
    case est::EffectKind::ElasticExp:
      std::snprintf(buf, sizeof buf, "%g (exp((q - %.3g)/%g) - 1) (rad)", shape.elastic_scale, shape.center,
                    shape.elastic_scale);
      return buf;
    case est::EffectKind::ElasticExpCoupled:
      std::snprintf(buf, sizeof buf, "%g (exp((q - %.3g %+.3g (q_%s - %.3g))/%g) - 1) (rad)", shape.elastic_scale,
                    shape.center, e.ratio, model.joint_names[e.coupled].c_str(), e.coupled_center, shape.elastic_scale);
      return buf;
  }
  return "";
}

// Which signal to plot per coordinate: its first finding, else the best-correlated candidate (velocity for an
// offset: a constant), with the plotted effect's own shape (width, scale, center, neighbour).
struct PlotSignals {
  std::vector<est::Effect> effect;
  std::vector<est::EffectShape> shape;
};
PlotSignals plotSignals(const Model& model, const est::DiagnoseOptions& opt, const est::DiagnosisResult& res) {
  const int nv = model.nv;
  PlotSignals ps{std::vector<est::Effect>(nv, est::Effect{est::EffectKind::Viscous}), std::vector<est::EffectShape>(nv, opt.shape)};
  std::vector<bool> from_finding(nv, false);
  for (int r = 0; r < nv; ++r) ps.effect[r] = res.coordinates[r].best_candidate;
  for (const est::Finding& f : res.findings) {
    const int r = model.jointRow(f.effect.joint);
    if (!from_finding[r]) ps.effect[r] = f.effect, from_finding[r] = true;
  }
  for (int r = 0; r < nv; ++r) {
    // A constant (offset): no signal to plot against; v instead. So for a row without a joint (a floating base's).
    if (ps.effect[r].kind == est::EffectKind::Offset || ps.effect[r].joint < 0 ||
        (est::isCoupled(ps.effect[r].kind) && ps.effect[r].coupled < 0))
      ps.effect[r] = est::Effect{est::EffectKind::Viscous};
    ps.shape[r] = est::effectShape(opt.shape, ps.effect[r]);
  }
  return ps;
}

// What the intake skipped, per file (rows of a CSV, ticks and damage of a log): on stdout, in summary.json and
// report.md, never only counted.
void describeInputs(const std::vector<std::string>& files, const std::vector<intake::InputStats>& stats,
                    nlohmann::json& js_inputs, std::string& md) {
  js_inputs = nlohmann::json::array();
  std::ostringstream md_inputs;
  for (size_t k = 0; k < files.size(); ++k) {
    const intake::InputStats& st = stats[k];
    nlohmann::json why = nlohmann::json::object();
    for (const auto& [reason, n] : st.why) why[reason] = n;
    js_inputs.push_back({{"file", files[k]}, {"samples", st.samples}, {"skipped", st.skipped}, {"skipped_by_reason", why}});
    if (!st.first_skip.empty()) js_inputs.back()["first_skipped"] = st.first_skip;
    if (!st.damage_report.empty()) js_inputs.back()["damage"] = st.damage_report;
    if (st.skipped == 0 && st.damage_report.empty()) continue;
    std::printf("input %s: %ld samples, %ld skipped%s%s%s%s\n", files[k].c_str(), st.samples, st.skipped,
                st.first_skip.empty() ? "" : " (first: ", st.first_skip.c_str(), st.first_skip.empty() ? "" : ")",
                st.damage_report.empty() ? "" : ("; damaged log, readable part used: " + st.damage_report).c_str());
    md_inputs << "- `" << files[k] << "`: " << st.samples << " samples, " << st.skipped << " skipped";
    for (const auto& [reason, n] : st.why) md_inputs << "; " << n << " " << reason;
    if (!st.first_skip.empty()) md_inputs << " (first: " << st.first_skip << ")";
    if (!st.damage_report.empty()) md_inputs << "; damaged log, its readable part used: " << st.damage_report;
    md_inputs << "\n";
  }
  md = md_inputs.str();
}

// rmse.csv: per coordinate the held-out and training RMSE before and after, the noise floor, the lag-1
// autocorrelations; the pooled figures last.
bool writeRmseCsv(const fs::path& out, const est::DiagnosisResult& res, std::string* error) {
  std::ofstream f;
  if (!openOut(out, "rmse.csv", f, error)) return false;
  f << "coordinate,rmse_before,rmse_after,train_rmse_before,train_rmse_after,noise_floor,lag1_before,lag1_after\n";
  char buf[256];
  for (const est::CoordinateSummary& c : res.coordinates) {
    std::snprintf(buf, sizeof buf, "%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.6f,%.6f\n", c.name.c_str(), c.rms_before, c.rms_after,
                  c.train_rms_before, c.train_rms_after, c.noise_floor, c.lag1_before, c.lag1_after);
    f << buf;
  }
  std::snprintf(buf, sizeof buf, "pooled,%.9g,%.9g,%.9g,%.9g,,,\n", res.pooled_before, res.pooled_after,
                res.train_pooled_before, res.train_pooled_after);
  f << buf;
  return true;
}

// candidates.csv: every candidate of the first step, then every payload candidate (the row names the link; value =
// mass, std_error = its jackknife error, com = CoM in the link frame). The last columns are the candidate's shape, empty
// where its kind has none: width (Coulomb, Stribeck: rad/s; the exponential springs' scale, rad), center (rad),
// angle_of (the coupled kinds' neighbour), ratio and angle_of_center (elastic_exp_coupled).
bool writeCandidatesCsv(const fs::path& out, const Model& model, const est::DiagnosisResult& res, std::string* error) {
  std::ofstream f;
  if (!openOut(out, "candidates.csv", f, error)) return false;
  f << "joint,kind,value,unit,correlation,explained,p_value,separable,status,std_error,com_x,com_y,com_z,width,center,"
       "angle_of,ratio,angle_of_center\n";
  for (const est::CandidateScore& c : res.first_step) {
    const est::Effect& e = c.effect;
    f << model.joint_names[e.joint] << ',' << est::effectKindName(e.kind) << ',' << e.value << ','
      << est::effectUnit(e.kind) << ',' << c.correlation << ',' << c.explained << ',' << c.p_value << ','
      << c.separable << ",\"" << c.status << "\"," << c.std_error << ",,,,";
    if (e.width != 0.0) f << e.width;
    f << ',';
    if (est::isElastic(e.kind)) f << e.center;
    f << ',';
    if (est::isCoupled(e.kind)) f << model.joint_names[e.coupled];
    f << ',';
    if (e.kind == est::EffectKind::ElasticExpCoupled) f << e.ratio << ',' << e.coupled_center;
    else f << ',';
    f << '\n';
  }
  for (const est::PayloadFinding& c : res.payload_first_step)
    f << model.body_names[c.link] << ",payload," << c.mass << ",kg,," << c.explained << ',' << c.p_value << ','
      << c.separable << ",\"" << c.status << "\"," << c.mass_se << ',' << c.com[0] << ',' << c.com[1] << ',' << c.com[2]
      << ",,,,,\n";
  return true;
}

// signals.csv (the plotted signal per joint) and residual_<segment>.csv of the held-out segments (validation, else
// training): t, and per joint the residual before and after, the plotted signal, v. *plot_csv: the first one.
bool writeResidualCsvs(const fs::path& out, const Model& model, const est::DiagnosisResult& res, const PlotSignals& ps,
                       std::string* plot_csv, std::string* error) {
  std::ofstream sf;
  if (!openOut(out, "signals.csv", sf, error)) return false;
  sf << "coordinate,kind,label\n";
  for (int j = 0; j < model.njoints; ++j) {
    const int r = model.jointRow(j);
    sf << model.joint_names[j] << ',' << est::effectKindName(ps.effect[r].kind) << ",\"" << signalLabel(model, ps.effect[r], ps.shape[r]) << "\"\n";
  }
  for (const est::ResidualSeries& rs : res.series) {
    if (rs.validation != res.has_validation) continue;
    const std::string name = "residual_" + safeName(rs.segment) + ".csv";
    if (plot_csv->empty()) *plot_csv = name;
    std::ofstream f;
    if (!openOut(out, name, f, error)) return false;
    f << "t";
    for (const std::string& n : model.joint_names) f << ",before_" << n << ",after_" << n << ",sig_" << n << ",v_" << n;
    f << '\n';
    char buf[64];
    for (long i = 0; i < rs.t.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%.9g", rs.t[i]);
      f << buf;
      for (int j = 0; j < model.njoints; ++j) {
        const int r = model.jointRow(j);
        const double dtau = (i > 0 && i + 1 < rs.t.size())
                                ? (rs.tau_model(i + 1, r) - rs.tau_model(i - 1, r)) / (rs.t[i + 1] - rs.t[i - 1])
                                : 0.0;
        const est::Effect& e = ps.effect[r];
        const double q = rs.q.rows() > i ? est::effectAngle(e, rs.q(i, j), rs.q(i, est::isCoupled(e.kind) ? e.coupled : j)) : 0.0;
        const double s = est::effectSignal(e.kind, ps.shape[r], q, rs.v(i, j), rs.a(i, j), rs.tau_model(i, r), dtau);
        std::snprintf(buf, sizeof buf, ",%.6g,%.6g,%.6g,%.6g", rs.before(i, r), rs.after(i, r), s, rs.v(i, j));
        f << buf;
      }
      f << '\n';
    }
  }
  return true;
}

// The augmented model: effects.yaml next to a copy of the URDF, and with payloads the declared model with them added to
// their links (point masses at their CoMs: their own rotational inertia is not fitted). *payload_urdf: its file name.
bool writeAugmentedModel(const fs::path& out, const Model& model, const Model& declared_model, const DiagnoseInputs& in,
                         const est::EffectSet& set, const est::DiagnosisResult& res, std::string* payload_urdf,
                         std::string* error) {
  std::error_code ec;
  fs::copy_file(in.model_path, out / set.model, fs::copy_options::overwrite_existing, ec);
  if (ec) return common::fail(error, "cannot copy the URDF: " + ec.message());
  if (!est::writeEffects((out / "effects.yaml").string(), model, set, error)) return false;
  if (res.payloads.empty()) return true;
  Eigen::VectorXd phi = declared_model.phi;
  for (const est::PayloadFinding& pf : res.payloads)
    phi.segment<kParamsPerBody>(model.bodyParamIndex(pf.link)) +=
        paramsFromInertial(pf.mass, pf.com, Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero());
  *payload_urdf = fs::path(in.declared_model_path).stem().string() + "_with_payload.urdf";
  return tools::writeUrdfWithInertials(in.declared_model_path, model, phi, (out / *payload_urdf).string(), error);
}

nlohmann::json payloadJson(const Model& model, const est::PayloadFinding& pf) {
  return nlohmann::json{{"link", model.body_names[pf.link]}, {"mass", pf.mass}, {"mass_se", pf.mass_se},
                        {"com", {pf.com[0], pf.com[1], pf.com[2]}}, {"com_se", {pf.com_se[0], pf.com_se[1], pf.com_se[2]}},
                        {"explained", pf.explained}, {"p_value", pf.p_value}, {"separable", pf.separable},
                        {"tested", pf.tested}, {"status", pf.status}, {"sentence", pf.sentence}};
}

// summary.json without the last stage's entry (writePredictability adds it).
nlohmann::json summaryJson(const Model& model, const est::DiagnoseOptions& opt, const DiagnoseInputs& in,
                           const est::DiagnosisResult& res, const est::OnlineComparison& online,
                           const nlohmann::json& js_inputs, const std::string& payload_urdf) {
  nlohmann::json js;
  js["model"] = in.model_path;
  js["declared"] = in.declared;
  js["declared_columns"] = res.declared_columns;
  js["dropped_columns"] = res.dropped_columns;
  js["candidates"] = res.candidates;
  js["train_samples"] = res.train_samples;
  js["validation_samples"] = res.validation_samples;
  js["inputs"] = js_inputs;
  js["alpha"] = opt.alpha;
  js["folds"] = opt.folds;
  js["pooled_rmse_before"] = res.pooled_before;
  js["pooled_rmse_after"] = res.pooled_after;
  js["train_pooled_rmse_before"] = res.train_pooled_before;
  js["train_pooled_rmse_after"] = res.train_pooled_after;
  if (online.ran) {
    js["online_joint_rmse_before"] = online.before;
    js["online_joint_rmse_after"] = online.after;
    for (int j = 0; j < online.joint_before.size(); ++j)
      js["online_joints"].push_back({{"name", model.joint_names[j]}, {"rmse_before", online.joint_before[j]},
                                     {"rmse_after", online.joint_after[j]}});
  }
  js["findings"] = nlohmann::json::array();
  for (const est::Finding& f : res.findings) {
    js["findings"].push_back({{"joint", model.joint_names[f.effect.joint]}, {"kind", est::effectKindName(f.effect.kind)},
                              {"value", f.effect.value}, {"unit", est::effectUnit(f.effect.kind)},
                              {"std_error", f.std_error}, {"explained", f.explained}, {"p_value", f.p_value},
                              {"tested", f.tested}, {"sentence", f.sentence}});
    if (f.ambiguous)  // another kind the data do not tell from this one (Finding::ambiguous)
    {
      nlohmann::json alt = {{"joint", model.joint_names[f.alternative.joint]},
                            {"kind", est::effectKindName(f.alternative.kind)}, {"value", f.alternative.value},
                            {"unit", est::effectUnit(f.alternative.kind)}, {"gain_ratio", f.alternative_gain},
                            {"separation_p", f.separation_p}};
      if (est::isCoupled(f.alternative.kind)) alt["angle_of"] = model.joint_names[f.alternative.coupled];
      js["findings"].back()["or"] = alt;
    }
    if (f.effect.width != 0.0) js["findings"].back()["width"] = f.effect.width;  // Coulomb, Stribeck: rad/s; elastic_exp: rad
    if (est::isElastic(f.effect.kind)) js["findings"].back()["center"] = f.effect.center;  // rad
    if (est::isCoupled(f.effect.kind)) js["findings"].back()["angle_of"] = model.joint_names[f.effect.coupled];
    if (f.effect.kind == est::EffectKind::ElasticExpCoupled) {
      js["findings"].back()["ratio"] = f.effect.ratio;                      // rad/rad
      js["findings"].back()["angle_of_center"] = f.effect.coupled_center;  // rad
    }
  }
  js["declared_model"] = in.declared_model_path.empty() ? nlohmann::json(nullptr) : nlohmann::json(in.declared_model_path);
  js["payloads"] = nlohmann::json::array();
  for (const est::PayloadFinding& pf : res.payloads) js["payloads"].push_back(payloadJson(model, pf));
  js["payload_candidates"] = nlohmann::json::array();
  for (const est::PayloadFinding& pf : res.payload_first_step) js["payload_candidates"].push_back(payloadJson(model, pf));
  if (!payload_urdf.empty()) js["payload_urdf"] = payload_urdf;
  for (const est::CoordinateSummary& c : res.coordinates)
    js["coordinates"].push_back({{"name", c.name}, {"rmse_before", c.rms_before}, {"rmse_after", c.rms_after},
                                 {"train_rmse_before", c.train_rms_before}, {"train_rmse_after", c.train_rms_after},
                                 {"noise_floor", c.noise_floor}, {"lag1_before", c.lag1_before}, {"lag1_after", c.lag1_after}});
  return js;
}

// report.md, its head: the model, the data, the selection rule, what the intake skipped.
void reportHead(std::ostringstream& md, const Model& model, const est::DiagnoseOptions& opt, const DiagnoseInputs& in,
                const est::DiagnosisResult& res, const std::string& md_inputs) {
  char buf[1024];
  md << "# exoid diagnose report\n\n";
  md << "Model `" << in.model_path << "` (" << (model.floating_base ? "floating" : "fixed") << " base, " << model.njoints
     << " joints); declared model: " << (opt.declared_friction ? "rigid body + viscous and Coulomb friction" : "rigid body")
     << ", " << res.declared_columns << " base-parameter columns excited";
  if (res.dropped_columns) md << " (" << res.dropped_columns << " structural ones not excited, left out)";
  md << ".\n\nTraining: ";
  for (const std::string& f : in.train_files) md << '`' << f << "` ";
  if (!in.calib_files.empty()) {
    md << "and the calibration run" << (in.calib_files.size() > 1 ? "s " : " ");
    for (const std::string& f : in.calib_files) md << '`' << f << "` ";
    md << "(pelvis held in a harness, legs swinging: joint rows only) ";
  }
  md << "(" << res.train_samples << " samples). Held-out validation: ";
  if (in.val_files.empty() && in.val_calib_files.empty()) md << "none (the before/after numbers below are training numbers)";
  for (const std::string& f : in.val_files) md << '`' << f << "` ";
  for (const std::string& f : in.val_calib_files) md << '`' << f << "` (calibration) ";
  if (!in.val_files.empty() || !in.val_calib_files.empty()) md << "(" << res.validation_samples << " samples)";
  std::snprintf(buf, sizeof buf,
                ".\n\nSelection: %d candidate columns, forward selection; an effect is accepted when the one-sided paired "
                "t-test of the held-out squared-error reduction over %d time-block folds has p < %g / (candidates of the "
                "step), it removes at least %.0f %% of its joint's held-out residual, and its value has the physical "
                "sign. False-alarm rate on data without an undeclared effect: <= %g per data set. Method: "
                "docs/diagnose.md.\n\n",
                res.candidates, opt.folds, opt.alpha, 100 * opt.min_explained, opt.alpha);
  md << buf;
  if (!md_inputs.empty()) md << "## Input skipped\n\n" << md_inputs << "\n";
  if (opt.hold_declared)
    md << "Declared rigid-body parameters held at `" << in.declared_model_path << "` (not identified: the residual is y - K "
          "phi_declared); every link tested for a payload.\n\n";
}

// report.md: the findings and the payload candidates.
void reportFindings(std::ostringstream& md, const Model& model, const est::DiagnoseOptions& opt,
                    const est::DiagnosisResult& res) {
  char buf[512];
  md << "## Findings\n\n";
  if (res.findings.empty() && res.payloads.empty())
    md << "None: no candidate effect passed the test; the residual is what the data allow.\n";
  for (const est::PayloadFinding& pf : res.payloads) md << "- " << pf.sentence << "\n";
  for (const est::Finding& f : res.findings) md << "- " << f.sentence << "\n";
  if (opt.payload && !opt.hold_declared)
    md << "\nPayloads: not tested. The declared model is identified from these data, so a rigid body fixed to a link "
          "moves that link's identified parameters instead of the residual (not separable); `--declared-model URDF` "
          "holds them and tests every link.\n";
  if (!opt.hold_declared || res.payload_first_step.empty()) return;
  md << "\n### Payload candidates (first step)\n\n| link | mass (kg) | CoM in the link frame (m) | explains | p | "
        "separable | verdict |\n|---|---|---|---|---|---|---|\n";
  for (const est::PayloadFinding& pf : res.payload_first_step) {
    std::snprintf(buf, sizeof buf, "| %s | %.3g | (%.3f, %.3f, %.3f) | %.0f %% | %.2g | %.2g | %s |\n",
                  model.body_names[pf.link].c_str(), pf.mass, pf.com[0], pf.com[1], pf.com[2], 100 * pf.explained,
                  pf.p_value, pf.separable, pf.status.c_str());
    md << buf;
  }
}

// report.md: the RMSE table before and after, and the residual's structure before augmentation.
void reportRmse(std::ostringstream& md, const est::DiagnoseOptions& opt, const est::DiagnosisResult& res) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "\n## Torque RMSE before and after (%s)\n\n", res.has_validation ? "held-out validation data" : "training data");
  md << buf;
  md << "| coordinate | before (N m) | after (N m) | change | noise floor (N m) | lag-1 autocorr. before / after | training before / after |\n"
        "|---|---|---|---|---|---|---|\n";
  for (const est::CoordinateSummary& c : res.coordinates) {
    std::snprintf(buf, sizeof buf, "| %s | %.3f | %.3f | %+.0f %% | %.3f | %.2f / %.2f | %.3f / %.3f |\n", c.name.c_str(),
                  c.rms_before, c.rms_after, 100 * (c.rms_after / c.rms_before - 1), c.noise_floor, c.lag1_before,
                  c.lag1_after, c.train_rms_before, c.train_rms_after);
    md << buf;
  }
  std::snprintf(buf, sizeof buf, "| **pooled** | **%.3f** | **%.3f** | %+.0f %% | | | %.3f / %.3f |\n\n", res.pooled_before,
                res.pooled_after, 100 * (res.pooled_after / res.pooled_before - 1), res.train_pooled_before,
                res.train_pooled_after);
  md << buf;
  md << "Noise floor: " << (opt.torque_noise > 0 ? "the given --torque-noise" : "sqrt(mean(diff(r)^2)/2) of the residual (white-noise estimate; "
                                                                                  "low for filtered data)")
     << ". A white residual has lag-1 autocorrelation near 0; near 1 means structure the model misses.\n\n";
  md << "## Residual structure before augmentation\n\n| joint | RMSE / noise floor | most correlated candidate signal | correlation |\n|---|---|---|---|\n";
  for (const est::CoordinateSummary& c : res.coordinates) {
    if (c.joint < 0) continue;
    std::snprintf(buf, sizeof buf, "| %s | %.1f | %s | %+.2f |\n", c.name.c_str(),
                  c.noise_floor > 0 ? c.rms_before / c.noise_floor : 0.0, est::effectKindWords(c.best_candidate.kind), c.best_correlation);
    md << buf;
  }
}

// report.md: the first step's 20 candidates with the largest held-out effect.
void reportCandidates(std::ostringstream& md, const Model& model, const est::DiagnosisResult& res) {
  char buf[512];
  md << "\n## Candidates of the first step (against the declared model alone), by held-out effect\n\n"
        "| joint | kind | value alone | correlation | explains | p | verdict |\n|---|---|---|---|---|---|---|\n";
  std::vector<est::CandidateScore> sorted = res.first_step;
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.explained > b.explained; });
  for (size_t i = 0; i < sorted.size() && i < 20; ++i) {
    const est::CandidateScore& c = sorted[i];
    std::snprintf(buf, sizeof buf, "| %s | %s | %.3g %s | %+.2f | %.0f %% | %.2g | %s |\n",
                  model.joint_names[c.effect.joint].c_str(), est::effectKindName(c.effect.kind), c.effect.value,
                  est::effectUnit(c.effect.kind), c.correlation, 100 * c.explained, c.p_value, c.status.c_str());
    md << buf;
  }
  md << "\n(all " << res.first_step.size() << " in candidates.csv)\n\n";
}

// report.md: what these data cannot show: candidates almost entirely inside the declared model's span.
void reportHidden(std::ostringstream& md, const Model& model, const est::DiagnosisResult& res) {
  std::map<std::string, std::vector<const est::CandidateScore*>> hidden;
  for (const est::CandidateScore& c : res.first_step)
    if (c.separable < kHiddenSeparable) hidden[est::effectKindWords(c.effect.kind)].push_back(&c);
  if (hidden.empty()) return;
  md << "## What these data cannot show\n\nCandidates with less than " << 100 * kHiddenSeparable
     << " % of their signal outside the span of the declared model's columns: the identified rigid-body parameters "
        "absorb nearly all of them (e.g. a constant torque on a joint of a robot that only balances is a "
        "first-moment shift of the links around it), and only an effect well above the smallest visible value "
        "given here (3 standard errors of its estimate, jackknifed over the time-block folds) could show. Motions that turn the "
        "joints through large angles separate them: a calibration run (`exoid calibrate`, `--calibration`) makes a "
        "torque offset of a few hundredths of a N m visible.\n\n"
        "| kind | joints (fraction of the signal outside the span; smallest visible value) |\n|---|---|\n";
  char buf[512];
  for (const auto& [kind, list] : hidden) {
    md << "| " << kind << " | ";
    for (size_t i = 0; i < list.size(); ++i) {
      const est::CandidateScore& c = *list[i];
      std::snprintf(buf, sizeof buf, "%s%s (%.2g %%; %.2g %s)", i ? ", " : "", model.joint_names[c.effect.joint].c_str(),
                    100 * c.separable, 3.0 * c.std_error, est::effectUnit(c.effect.kind));
      md << buf;
    }
    md << " |\n";
  }
  md << "\n";
}

// report.md: the plots and the augmented model's files.
void reportTail(std::ostringstream& md, bool plotted, const std::string& plot_csv, const est::EffectSet& set,
                const std::string& payload_urdf) {
  md << "## Plots\n\n";
  if (plotted)
    md << "![RMSE per coordinate](rmse.png)\n\n![Residual against the chosen signal](residual_vs_signal.png)\n\n"
          "Each panel: the joint's residual against the signal of its first finding (or, without a finding, the best-correlated "
          "candidate; velocity for an offset), before (blue) and after (orange).\n\n![Residual spectra](spectra.png)\n\n";
  else
    md << "Not drawn (run `python3 plot_diagnose.py " << plot_csv << "` here with matplotlib).\n\n";
  md << "## Augmented model\n\n`" << set.model << "` (the rigid-body model, unchanged) + `effects.yaml` (the accepted "
        "effects: dynamics columns and measurement corrections; format in docs/diagnose.md).\n";
  if (set.base_body_moves)
    md << "\n`base_body_moves: true`: an unmeasured body moves on the base (above); the online estimator given this "
          "sidecar (`exo_estimator --effects effects.yaml`) keeps the prior's uncertainty on the CoM height, which "
          "such a body's lag biases (docs/estimator.md \"A body that moves on the base\").\n";
  if (!payload_urdf.empty())
    md << "\n`" << payload_urdf << "`: the declared model with the payloads found added to their links (point masses).\n";
}

// report.md: each run used (training, validation; LCM logs: a CSV has no pose to draw) as its keyframe strip, the
// picture of `exoid render --keyframes` (start, largest CoM excursion, end). One that cannot be drawn says why.
void reportRuns(std::ostringstream& md, const Model& model, const DiagnoseInputs& in, const fs::path& out) {
  std::vector<render::ReportRun> runs;
  for (const auto* files : {&in.train_files, &in.val_files})
    for (const std::string& f : *files)
      if (!tools::isCsvPath(f))
        runs.push_back({files == &in.train_files ? "training" : "validation", f, "keyframes_" + std::to_string(runs.size() + 1) + ".png"});
  if (runs.empty() || in.no_plots) return;
  md << render::runKeyframesSection(runs, &model, "", in.scene_mjcf, out.string());
}

// The console summary.
void printSummary(const est::DiagnosisResult& res, const est::OnlineComparison& online, const std::string& predictability,
                  const std::string& unmeasured_body, const fs::path& out) {
  std::printf("declared model: %d base-parameter columns; %d candidates; %ld training / %ld validation samples\n",
              res.declared_columns, res.candidates, res.train_samples, res.validation_samples);
  for (const est::PayloadFinding& pf : res.payloads) std::printf("  %s\n", pf.sentence.c_str());
  for (const est::Finding& f : res.findings) std::printf("  %s\n", f.sentence.c_str());
  if (res.findings.empty() && res.payloads.empty()) std::printf("  no finding\n");
  std::printf("%s", predictability.c_str());
  std::printf("%s", unmeasured_body.c_str());
  std::printf("%-16s %10s %10s\n", "coordinate", "before", "after");
  for (const est::CoordinateSummary& c : res.coordinates) std::printf("%-16s %10.4f %10.4f\n", c.name.c_str(), c.rms_before, c.rms_after);
  std::printf("%-16s %10.4f %10.4f   (%s RMSE, N m)\n", "pooled", res.pooled_before, res.pooled_after,
              res.has_validation ? "held-out" : "training");
  if (online.ran)
    std::printf("online estimator (RecursiveLs on the training rows, prediction on the validation rows), joints: "
                "%.4f -> %.4f N m with the sidecar's columns\n", online.before, online.after);
  std::printf("report: %s\n", (out / "report.md").string().c_str());
}
}  // namespace diagnose_report

bool openOut(const fs::path& out, const std::string& name, std::ofstream& f, std::string* error) {
  using namespace diagnose_report;
  f.open(out / name);
  if (!f && error) *error = "cannot write '" + (out / name).string() + "'";
  return static_cast<bool>(f);
}

bool writePlotScript(const std::string& out_dir, const std::string& name, const char* script, bool run,
                     const std::string& python, const std::string& args, bool* plotted, std::string* error) {
  using namespace diagnose_report;
  const fs::path out(out_dir);
  {
    std::ofstream f;
    if (!openOut(out, name, f, error)) return false;
    f << script;
  }
  *plotted = false;
  if (!run) return true;
  const std::string cmd = python + " '" + (out / name).string() + "'" + args;
  *plotted = std::system(cmd.c_str()) == 0;
  if (!*plotted) std::fprintf(stderr, "exoid: warning: the plot script failed (%s); the CSVs are written\n", cmd.c_str());
  return true;
}

est::EffectSet effectSetOf(const std::string& model_path, const est::DiagnoseOptions& opt, const est::DiagnosisResult& res) {
  using namespace diagnose_report;
  est::EffectSet set;
  set.model = fs::path(model_path).filename().string();
  set.shape = opt.shape;
  for (const est::Finding& f : res.findings) set.effects.push_back(f.effect);
  for (const est::UnmeasuredBodyPlane& p : res.unmeasured_body.planes) set.base_body_moves = set.base_body_moves || p.found;
  return set;
}

bool writeDiagnosis(const Model& model, const Model& declared_model, const est::DiagnoseOptions& opt,
                    const DiagnoseInputs& in, const std::vector<intake::InputStats>& stats, const est::DiagnosisResult& res,
                    const est::OnlineComparison& online, std::string* error) {
  using namespace diagnose_report;
  std::vector<std::string> files = in.train_files;
  for (const auto* v : {&in.calib_files, &in.val_files, &in.val_calib_files}) files.insert(files.end(), v->begin(), v->end());
  nlohmann::json js_inputs;
  std::string md_inputs, plot_csv, payload_urdf, predictability_md, predictability_console, body_md, body_console;
  describeInputs(files, stats, js_inputs, md_inputs);
  std::error_code ec;
  fs::create_directories(in.out_dir, ec);
  if (ec) return common::fail(error, "cannot create '" + in.out_dir + "': " + ec.message());
  const fs::path out(in.out_dir);
  const est::EffectSet set = effectSetOf(in.model_path, opt, res);
  if (!writeRmseCsv(out, res, error) || !writeCandidatesCsv(out, model, res, error) ||
      !writeResidualCsvs(out, model, res, plotSignals(model, opt, res), &plot_csv, error) ||
      !writeAugmentedModel(out, model, declared_model, in, set, res, &payload_urdf, error))
    return false;
  nlohmann::json js = summaryJson(model, opt, in, res, online, js_inputs, payload_urdf);
  if (!writePredictability(in.out_dir, model, res.predictability, opt.predictability, !in.no_plots, in.python, js,
                           &predictability_md, &predictability_console, error) ||
      !writeUnmeasuredBody(in.out_dir, res.unmeasured_body, opt.unmeasured_body, !in.no_plots, in.python, js, &body_md,
                           &body_console, error))
    return false;
  std::ofstream f;
  if (!openOut(out, "summary.json", f, error)) return false;
  f << js.dump(2) << '\n';
  f.close();
  bool plotted = false;
  if (!writePlotScript(in.out_dir, "plot_diagnose.py", kPlotScript, !in.no_plots && !plot_csv.empty(), in.python,
                       " '" + plot_csv + "'", &plotted, error))
    return false;
  std::ostringstream md;
  reportHead(md, model, opt, in, res, md_inputs);
  reportFindings(md, model, opt, res);
  reportRmse(md, opt, res);
  reportCandidates(md, model, res);
  reportHidden(md, model, res);
  md << predictability_md;
  md << body_md;
  reportRuns(md, model, in, out);
  reportTail(md, plotted, plot_csv, set, payload_urdf);
  std::ofstream r;
  if (!openOut(out, "report.md", r, error)) return false;
  r << md.str();
  r.close();
  printSummary(res, online, predictability_console, body_console, out);
  return true;
}

}  // namespace exoid::cli
