// exoid diagnose: what the rigid-body model leaves out, found from the residual (docs/diagnose.md).
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "commands.hpp"
#include "diagnose_predictability.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/identify_input.hpp"
#include "exoid/tools/urdf_inertials.hpp"

namespace exoid::cli {

namespace {
// A candidate with less of its signal than this outside the declared model's span is reported as not visible.
constexpr double kHiddenSeparable = 0.01;
namespace est = exoid::estimator;
namespace fs = std::filesystem;

constexpr char kDescription[] =
    "Finds what the declared rigid-body model leaves out (docs/diagnose.md). Identifies the declared model on\n"
    "the training data, analyses the residual per joint (size against the noise, autocorrelation, correlation\n"
    "with candidate signals), tests a library of candidate effects per joint (viscous, Coulomb with a smooth\n"
    "sign, Stribeck, constant offset, armature, torque-sensor gain error, time delay) by forward selection with\n"
    "a one-sided paired t-test over held-out time-block folds (Bonferroni over the candidates of each step:\n"
    "false-alarm rate <= --alpha per data set), re-identifies with the accepted effects and reports the torque\n"
    "RMSE before and after on the validation data, per joint and pooled. A last stage asks whether what remains of\n"
    "each joint's residual is predictable from the state at all (sparse regression over a dictionary of the state,\n"
    "gradient-boosted trees; held-out time blocks, Bonferroni over the joints) and names the state variables.\n\n"
    "Writes to --out: report.md (findings in words, tables, plots), summary.json, rmse.csv, candidates.csv,\n"
    "residual_<segment>.csv, effects.yaml (the sidecar of the augmented model) next to a copy of the URDF,\n"
    "plot_diagnose.py and its PNGs (rmse.png, residual_vs_signal.png, spectra.png; python3 with matplotlib);\n"
    "the last stage's predictability.csv, predictability_series.csv, plot_predictability.py, predictability.png.\n\n"
    "exit codes: 0 success, 2 bad input or data that cannot identify the declared model (one line on stderr),\n"
    "            3 the log is damaged (damaged stretches, a cut-off tail, rejected events; nothing written; see\n"
    "            --allow-partial).";

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid diagnose: error: %s\n", msg.c_str());
  return 2;
}

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

std::string signalLabel(est::EffectKind k, const est::EffectShape& shape) {
  char buf[128];
  switch (k) {
    case est::EffectKind::Viscous: return "v (rad/s)";
    case est::EffectKind::Coulomb: std::snprintf(buf, sizeof buf, "tanh(v / %g)", shape.coulomb_width); return buf;
    case est::EffectKind::Stribeck:
      std::snprintf(buf, sizeof buf, "tanh(v/%g) exp(-(v/%g)^2)", shape.coulomb_width, shape.stribeck_velocity);
      return buf;
    case est::EffectKind::Offset: return "v (rad/s; offset: constant signal)";
    case est::EffectKind::Armature: return "dv/dt (rad/s^2)";
    case est::EffectKind::GainError: return "model torque (N m)";
    case est::EffectKind::Delay: return "-d/dt model torque (N m/s)";
  }
  return "";
}
}  // namespace

int cmdDiagnose(int argc, char** argv) {
  CLI::App app(kDescription, "exoid diagnose");
  common::configureCli(app);
  std::vector<std::string> train_files, val_files, kinds, calib_files, val_calib_files;
  std::string model_path, out_dir, declared = "rigid", pipeline = "sensors", python = "python3", filter_mode = "parallel";
  bool floating = false, skip_bad = false, no_plots = false;
  double gravity = 9.81, cutoff = -1.0;
  est::DiagnoseOptions opt;
  int folds = opt.folds, max_effects = opt.max_effects;
  app.add_option("--model", model_path, "robot URDF")->required();
  app.add_flag("--floating-base", floating, "the root link is on a 6-dof free joint (default: fixed to the world)");
  app.add_option("--train", train_files, "training data: measured CSVs (docs/identification.md) and/or LCM logs of "
                 "`exoid experiment`")->required();
  app.add_option("--validate", val_files, "held-out data for the before/after report (same kinds); without it the "
                 "training data are reported and only the fold test guards the choice");
  app.add_option("--calibration", calib_files, "more training data: LCM logs of `exoid calibrate` (the pelvis held in a "
                 "harness, the legs swinging; needs --floating-base). Their base rows are left out (the harness's wrench "
                 "is not measured) and the base is taken at rest. Swinging legs separate a constant torque offset from "
                 "the links' first moments, which balancing data cannot (docs/diagnose.md)")->type_name("LOG");
  app.add_option("--validate-calibration", val_calib_files, "more held-out data: logs of `exoid calibrate` (another "
                 "--seed), read like --calibration; the before/after figures pool them with --validate")->type_name("LOG");
  app.add_option("--out", out_dir, "output directory (created)")->required();
  app.add_option("--gravity", gravity, "gravity magnitude, m/s^2, along -z of the world / root link")->transform(common::strictNumber(0.0, 100.0));
  app.add_option("--declared", declared, "declared model: 'rigid' (URDF rigid-body parameters; default) or "
                 "'rigid+friction' (plus fv, fc of every joint)")->check(CLI::IsMember({"rigid", "rigid+friction"}));
  std::string declared_model_path;
  app.add_option("--declared-model", declared_model_path, "hold the declared rigid-body parameters at this URDF's values "
                 "(e.g. identified.urdf of `exoid identify` on earlier data; the links and joints of --model) instead of "
                 "identifying them: the residual is y - K phi_declared, so a change of the robot since then is a finding; "
                 "with it each link is also tested for a payload (a rigid body fixed to it: mass and CoM; admissible with a mass "
                 "above 3 standard errors and the CoM within --payload-com-bound of the link frame), which an identified "
                 "declared model absorbs. Training and validation rows both become y - K phi_declared (docs/diagnose.md)")
      ->type_name("URDF");
  app.add_option("--payload-com-bound", opt.payload_com_bound, "m: an admissible payload's CoM lies within this distance "
                 "of its link frame's origin (default 0.5)")->transform(common::strictNumber(1e-6, 1e3));
  app.add_option("--effects", kinds, "candidate kinds to test (default all): viscous coulomb stribeck offset armature gain delay");
  app.add_option("--alpha", opt.alpha, "false-alarm rate per data set (family-wise per selection step; default 0.01)")
      ->transform(common::strictNumber(1e-9, 0.5));
  app.add_option("--folds", folds, "time-block folds for the held-out test (default 20)")
      ->transform(common::strictInteger(3, 100));
  app.add_option("--chunk-seconds", opt.chunk_seconds, "length of one time chunk; chunks are dealt to the folds in turn "
                 "(default 0.25 s)")->transform(common::strictNumber(1e-3, 1e6));
  app.add_option("--min-explained", opt.min_explained, "an effect must remove at least this fraction of its joint's "
                 "held-out residual (default 0.02)")->transform(common::strictNumber(0.0, 1.0));
  app.add_option("--max-effects", max_effects, "at most this many effects (default 30)")->transform(common::strictInteger(0, 1000));
  auto* width_opt = app.add_option("--coulomb-width", opt.shape.coulomb_width,
                                   "rad/s: one Coulomb width tanh(v / width) for every joint (default: each joint's width is\n"
                                   "profiled on the training data over 0.001 ... 0.1 rad/s, the one whose signal, beside v,\n"
                                   "would remove the most of that joint's residual; docs/diagnose.md)")
      ->transform(common::strictNumber(1e-9, 1e3));
  app.add_option("--stribeck-velocity", opt.shape.stribeck_velocity, "rad/s: Stribeck decay exp(-(v / vs)^2) (default 0.1)")
      ->transform(common::strictNumber(1e-9, 1e3));
  app.add_option("--torque-noise", opt.torque_noise, "known torque noise sigma (N m) for the size check (default: "
                 "estimated from the residual's sample-to-sample differences)")->transform(common::strictNumber(0.0, 1e6));
  app.add_option("--pipeline", pipeline, "LCM logs: 'sensors' (default) or 'truth'")->check(CLI::IsMember({"sensors", "truth"}));
  app.add_option("--cutoff", cutoff, "zero-phase Butterworth cutoff in Hz for the dataset pipeline (0: none). Default: 5 Hz "
                 "with --floating-base (exoskeleton logs: differenced encoders and gyro; docs/diagnose.md), none otherwise")
      ->transform(common::strictNumber(0.0, 1e6));
  app.add_option("--filter-mode", filter_mode, "'parallel' (default: inputs only differenced, the same filter on every "
                 "column of W and on y, so filter lag and attenuation cancel) or 'inputs' (filter q, differentiate, filter "
                 "again, y unfiltered: leaves the filtered-away motion in the residual); docs/identification.md")
      ->check(CLI::IsMember({"inputs", "parallel"}));
  app.add_flag("--skip-bad-rows", skip_bad, "CSV: drop and count bad rows instead of failing at the first (the count and "
               "the first are reported on stdout, in summary.json and report.md)");
  bool allow_partial = false;
  app.add_flag("--allow-partial", allow_partial, "LCM logs (--train, --validate, --calibration, --validate-calibration): a "
               "damaged log (damaged stretches, a cut-off tail, events the adapters reject) is refused (exit 3, the damage "
               "on stderr); with this flag its readable part is used and the damage reported on stdout, in summary.json "
               "and report.md");
  app.add_flag("--no-plots", no_plots, "do not run the plot script (it is still written)");
  bool no_predictability = false;
  app.add_flag("--no-predictability", no_predictability, "skip the last stage, which asks whether the residual left after "
               "augmentation is predictable from the state (sparse regression over a dictionary of q, v, a of each joint "
               "and its neighbours, their products and history; gradient-boosted trees; docs/diagnose.md)");
  app.add_option("--predictability-block", opt.predictability.block_seconds, "s: held-out blocks of the last stage's test "
                 "and the guard between its training and held-out data; longer than the time over which noise in the "
                 "residual is correlated (default 5)")->transform(common::strictNumber(0.01, 1e6));
  app.add_option("--python", python, "python interpreter for the plots (default python3; needs matplotlib and numpy)");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  if (width_opt->count() > 0) opt.coulomb_widths = {opt.shape.coulomb_width};  // one width, as asked
  opt.folds = folds;
  opt.predictability.enabled = !no_predictability;
  opt.max_effects = max_effects;
  opt.declared_friction = declared == "rigid+friction";
  if (!kinds.empty()) {
    opt.kinds.clear();
    for (const std::string& k : kinds) {
      est::EffectKind kind;
      if (!est::parseEffectKind(k, kind)) return fail("--effects: unknown kind '" + k + "'");
      opt.kinds.push_back(kind);
    }
  }

  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(model_path, floating, model, &err, gravity)) return fail(err);
  tools::SourceOptions so;
  so.pipeline = pipeline == "truth" ? intake::LogPipeline::Truth : intake::LogPipeline::Sensors;
  so.dataset.cutoff_hz = cutoff >= 0.0 ? cutoff : floating ? 5.0 : 0.0;
  so.dataset.filter = filter_mode == "parallel" ? est::FilterMode::Parallel : est::FilterMode::Inputs;
  so.dataset.trim_edges = true;  // the filter's start-up transient is no residual of the model
  so.skip_bad_rows = skip_bad;
  so.allow_partial = allow_partial;
  Model declared_model;
  Eigen::VectorXd held_phi;  // --declared-model: its parameters, taken off y (friction too, unless it is fitted)
  if (!declared_model_path.empty()) {
    if (!buildModelFromUrdfFile(declared_model_path, floating, declared_model, &err, gravity)) return fail(err);
    const std::string why = differentTree(model, declared_model);
    if (!why.empty()) return fail("--declared-model " + declared_model_path + ": not the tree of " + model_path + ": " + why);
    held_phi = declared_model.phi;
    if (opt.declared_friction) held_phi.tail(model.nparams() - model.nInertialParams()).setZero();  // fitted instead
    so.held_phi = &held_phi;
    opt.hold_declared = true;
  }
  if ((!calib_files.empty() || !val_calib_files.empty()) && !floating)
    return fail("--calibration and --validate-calibration need --floating-base (an exoskeleton held in a harness)");
  tools::SourceOptions so_held = so;
  so_held.held_base = true;
  std::vector<intake::InputStats> stats(train_files.size() + calib_files.size() + val_files.size() + val_calib_files.size());
  std::set<std::string> names;  // segment names name the residual_<name>.csv files: unique
  auto makeSegment = [&](const std::string& path, size_t k, bool held) {
    est::Segment s;
    const fs::path p(path);
    s.name = p.stem().string();
    if (names.count(s.name)) s.name = p.parent_path().filename().string() + "_" + s.name;  // e.g. two run.lcmlog
    for (int i = 2; names.count(s.name); ++i) s.name = p.stem().string() + "_" + std::to_string(i);
    names.insert(s.name);
    s.held_base = held;
    s.stream = [&, path, k, held](const est::DiagnosisRowSink& sink, std::string* e) {
      stats[k] = intake::InputStats{};
      return tools::streamFileRows(path, model, held ? so_held : so, sink, stats[k], e);
    };
    s.stream_state = [&, path, k, held](const est::DiagnosisStateSink& sink, std::string* e) {
      stats[k] = intake::InputStats{};
      return tools::streamFileStateRows(path, model, held ? so_held : so, sink, stats[k], e);
    };
    return s;
  };
  std::vector<est::Segment> train, validate;
  for (size_t i = 0; i < train_files.size(); ++i) train.push_back(makeSegment(train_files[i], i, false));
  for (size_t i = 0; i < calib_files.size(); ++i)
    train.push_back(makeSegment(calib_files[i], train_files.size() + i, true));
  for (size_t i = 0; i < val_files.size(); ++i)
    validate.push_back(makeSegment(val_files[i], train_files.size() + calib_files.size() + i, false));
  for (size_t i = 0; i < val_calib_files.size(); ++i)
    validate.push_back(
        makeSegment(val_calib_files[i], train_files.size() + calib_files.size() + val_files.size() + i, true));

  est::DiagnosisResult res;
  if (!est::diagnose(model, train, validate, opt, res, &err)) {
    for (const intake::InputStats& st : stats)
      if (st.refused_damaged) return fail(err), 3;
    return fail(err);
  }
  // What the intake skipped, per file (rows of a CSV, ticks and damage of a log): on stdout, in summary.json
  // and report.md, never only counted.
  std::vector<std::string> all_files = train_files;
  for (const auto* v : {&calib_files, &val_files, &val_calib_files}) all_files.insert(all_files.end(), v->begin(), v->end());
  nlohmann::json js_inputs = nlohmann::json::array();
  std::ostringstream md_inputs;
  for (size_t k = 0; k < all_files.size(); ++k) {
    const intake::InputStats& st = stats[k];
    nlohmann::json why = nlohmann::json::object();
    for (const auto& [reason, n] : st.why) why[reason] = n;
    js_inputs.push_back({{"file", all_files[k]}, {"samples", st.samples}, {"skipped", st.skipped}, {"skipped_by_reason", why}});
    if (!st.first_skip.empty()) js_inputs.back()["first_skipped"] = st.first_skip;
    if (!st.damage_report.empty()) js_inputs.back()["damage"] = st.damage_report;
    if (st.skipped == 0 && st.damage_report.empty()) continue;
    std::printf("input %s: %ld samples, %ld skipped%s%s%s%s\n", all_files[k].c_str(), st.samples, st.skipped,
                st.first_skip.empty() ? "" : " (first: ", st.first_skip.c_str(), st.first_skip.empty() ? "" : ")",
                st.damage_report.empty() ? "" : ("; damaged log, readable part used: " + st.damage_report).c_str());
    md_inputs << "- `" << all_files[k] << "`: " << st.samples << " samples, " << st.skipped << " skipped";
    for (const auto& [reason, n] : st.why) md_inputs << "; " << n << " " << reason;
    if (!st.first_skip.empty()) md_inputs << " (first: " << st.first_skip << ")";
    if (!st.damage_report.empty()) md_inputs << "; damaged log, its readable part used: " << st.damage_report;
    md_inputs << "\n";
  }

  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return fail("cannot create '" + out_dir + "': " + ec.message());
  const fs::path out(out_dir);
  const int nv = model.nv;
  auto open = [&](const std::string& name, std::ofstream& f) {
    f.open(out / name);
    if (!f) return fail("cannot write '" + (out / name).string() + "'"), false;
    return true;
  };

  // Which signal to plot per joint: its first finding, else the best-correlated candidate.
  std::vector<est::EffectKind> plot_kind(nv, est::EffectKind::Viscous);
  std::vector<est::EffectShape> plot_shape(nv, opt.shape);  // with the plotted effect's own Coulomb width
  std::vector<bool> from_finding(nv, false);
  for (int r = 0; r < nv; ++r) {
    plot_kind[r] = res.coordinates[r].best_kind;
    plot_shape[r] = est::effectShape(opt.shape, est::Effect{plot_kind[r], -1, 0.0, res.coordinates[r].best_width});
  }
  for (const est::Finding& f : res.findings) {
    const int r = model.jointRow(f.effect.joint);
    if (!from_finding[r]) plot_kind[r] = f.effect.kind, plot_shape[r] = est::effectShape(opt.shape, f.effect), from_finding[r] = true;
  }
  for (int r = 0; r < nv; ++r)
    if (plot_kind[r] == est::EffectKind::Offset) plot_kind[r] = est::EffectKind::Viscous;  // constant: plot vs v

  // CSVs.
  {
    std::ofstream f;
    if (!open("rmse.csv", f)) return 2;
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
  }
  {
    std::ofstream f;
    if (!open("candidates.csv", f)) return 2;
    f << "joint,kind,value,unit,correlation,explained,p_value,separable,status,std_error,com_x,com_y,com_z\n";
    for (const est::CandidateScore& c : res.first_step)
      f << model.joint_names[c.effect.joint] << ',' << est::effectKindName(c.effect.kind) << ',' << c.effect.value << ','
        << est::effectUnit(c.effect.kind) << ',' << c.correlation << ',' << c.explained << ',' << c.p_value << ','
        << c.separable << ",\"" << c.status << "\"," << c.std_error << ",,,\n";
    // Payload candidates: the row names the link; value = mass, std_error = its jackknife error, com = CoM (link frame).
    for (const est::PayloadFinding& c : res.payload_first_step)
      f << model.body_names[c.link] << ",payload," << c.mass << ",kg,," << c.explained << ',' << c.p_value << ','
        << c.separable << ",\"" << c.status << "\"," << c.mass_se << ',' << c.com[0] << ',' << c.com[1] << ',' << c.com[2] << "\n";
  }
  {
    std::ofstream f;
    if (!open("signals.csv", f)) return 2;
    f << "coordinate,kind,label\n";
    for (int j = 0; j < model.njoints; ++j) {
      const int r = model.jointRow(j);
      f << model.joint_names[j] << ',' << est::effectKindName(plot_kind[r]) << ",\"" << signalLabel(plot_kind[r], plot_shape[r])
        << "\"\n";
    }
  }
  std::string plot_csv;
  for (const est::ResidualSeries& rs : res.series) {
    if (rs.validation != res.has_validation) continue;
    const std::string name = "residual_" + safeName(rs.segment) + ".csv";
    if (plot_csv.empty()) plot_csv = name;
    std::ofstream f;
    if (!open(name, f)) return 2;
    f << "t";
    for (int j = 0; j < model.njoints; ++j) {
      const std::string& n = model.joint_names[j];
      f << ",before_" << n << ",after_" << n << ",sig_" << n << ",v_" << n;
    }
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
        const double s = est::effectSignal(plot_kind[r], plot_shape[r], rs.v(i, j), rs.a(i, j), rs.tau_model(i, r), dtau);
        std::snprintf(buf, sizeof buf, ",%.6g,%.6g,%.6g,%.6g", rs.before(i, r), rs.after(i, r), s, rs.v(i, j));
        f << buf;
      }
      f << '\n';
    }
  }

  // Sidecar + URDF copy: the augmented model.
  est::EffectSet set;
  set.model = fs::path(model_path).filename().string();
  set.shape = opt.shape;
  for (const est::Finding& f : res.findings) set.effects.push_back(f.effect);
  fs::copy_file(model_path, out / set.model, fs::copy_options::overwrite_existing, ec);
  if (ec) return fail("cannot copy the URDF: " + ec.message());
  if (!est::writeEffects((out / "effects.yaml").string(), model, set, &err)) return fail(err);
  // The declared model with the payloads found added to their links (point masses at their CoMs: their own
  // rotational inertia is not fitted).
  std::string payload_urdf;
  if (!res.payloads.empty()) {
    Eigen::VectorXd phi = declared_model.phi;
    for (const est::PayloadFinding& pf : res.payloads)
      phi.segment<kParamsPerBody>(model.bodyParamIndex(pf.link)) +=
          paramsFromInertial(pf.mass, pf.com, Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero());
    payload_urdf = fs::path(declared_model_path).stem().string() + "_with_payload.urdf";
    if (!tools::writeUrdfWithInertials(declared_model_path, model, phi, (out / payload_urdf).string(), &err)) return fail(err);
  }

  // The online estimator with and without the sidecar's columns (issue 9 item 4), offline: the training rows fed
  // sample by sample through RecursiveLs (no forgetting, prior = the URDF +-25 %, effects prior 0 with sigma 10 x
  // their value; gains corrected on the sensor part of y), then its torque prediction on the validation rows,
  // back in measured units. Both see the same rows, so the difference is the sidecar alone. Only with validation
  // data and a finding, and not with --declared-model (the rows then hold y - K phi_declared, not what the online
  // estimator sees).
  double online_before = -1.0, online_after = -1.0;
  Eigen::VectorXd online_joint_before, online_joint_after;
  if (!validate.empty() && !set.effects.empty() && !opt.hold_declared) {
    const BaseParameters base = computeBaseParameters(model);
    const Eigen::MatrixXd info = est::diagonalPriorInformation(model, base, model.phi, 0.25);
    est::RecursiveLsModel rigid, augmented;
    if (!est::makeRecursiveLs(model, base, model.phi, info, {}, rigid, &err)) return fail(err);
    augmented = rigid;
    std::vector<int> rows;
    std::vector<double> sig;
    for (const est::Effect& e : set.effects)
      if (!est::isMeasurementEffect(e.kind)) rows.push_back(model.jointRow(e.joint)), sig.push_back(10.0 * std::fabs(e.value) + 1e-6);
    if (!est::addExtraColumns(augmented, rows, Eigen::Map<Eigen::VectorXd>(sig.data(), sig.size()), &err)) return fail(err);
    est::RecursiveLsData dr(rigid), da(augmented);
    const int ne = static_cast<int>(rows.size()), p = model.nparams();
    Eigen::MatrixXd Ka(nv, p + ne);
    Eigen::VectorXd ya(nv), pr(nv), pa(nv);
    Eigen::VectorXd sse_b = Eigen::VectorXd::Zero(nv), sse_a = Eigen::VectorXd::Zero(nv), n_row = Eigen::VectorXd::Zero(nv);
    // One tick count over all training segments: RecursiveLs refuses a tick not after the last one, so a count
    // restarted per file made it drop every later file's rows as duplicates.
    long tick = 0, refused = 0;
    for (size_t sgi = 0; sgi < res.series.size(); ++sgi) {
      const est::ResidualSeries& rs = res.series[sgi];
      const est::Segment& sg = sgi < train.size() ? train[sgi] : validate[sgi - train.size()];
      long i = 0;
      const bool ok = sg.stream(
          [&](double, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd& tau_sensor) {
            if (i >= rs.t.size()) return;
            Ka.leftCols(p) = K;
            est::effectColumns(model, set, rs.v.row(i).transpose(), rs.a.row(i).transpose(), Ka.rightCols(ne));
            ya = y;
            est::correctMeasurement(model, set, ya, tau_sensor);
            if (!rs.validation) {
              ++tick;
              refused += est::updateRecursiveLs(rigid, dr, tick, K, y) != est::SampleStatus::Accepted;
              refused += est::updateRecursiveLs(augmented, da, tick, Ka, ya) != est::SampleStatus::Accepted;
            } else {
              est::predictRecursiveLs(rigid, dr, K, pr);
              est::predictRecursiveLs(augmented, da, Ka, pa);
              // Back to measured units: the predicted sensor part tau = pa - (y - tau_sensor) scaled by (1 + g).
              for (const est::Effect& e : set.effects)
                if (e.kind == est::EffectKind::GainError) {
                  const int r = model.jointRow(e.joint);
                  pa[r] += e.value * (pa[r] - (y[r] - tau_sensor[r]));
                }
              for (int r = 0; r < nv; ++r) {
                if (!est::segmentRowMeasured(model, sg, r)) continue;  // a zero row, not data
                sse_b[r] += (y[r] - pr[r]) * (y[r] - pr[r]);
                sse_a[r] += (y[r] - pa[r]) * (y[r] - pa[r]);
                n_row[r] += 1.0;
              }
            }
            ++i;
          },
          &err);
      if (!ok) return fail(err);
      if (refused > 0) return fail("the online comparison refused " + std::to_string(refused) + " training rows (non-finite)");
      if (sgi + 1 == train.size()) {
        est::solveRecursiveLs(rigid, dr, false);
        est::solveRecursiveLs(augmented, da, false);
      }
    }
    const int j0 = model.floating_base ? 6 : 0;
    const Eigen::ArrayXd n_joint = n_row.tail(nv - j0).array().max(1.0);
    online_joint_before = (sse_b.tail(nv - j0).array() / n_joint).sqrt().matrix();
    online_joint_after = (sse_a.tail(nv - j0).array() / n_joint).sqrt().matrix();
    online_before = std::sqrt(sse_b.tail(nv - j0).sum() / std::max(n_row.tail(nv - j0).sum(), 1.0));
    online_after = std::sqrt(sse_a.tail(nv - j0).sum() / std::max(n_row.tail(nv - j0).sum(), 1.0));
  }

  // summary.json
  nlohmann::json js;
  js["model"] = model_path;
  js["declared"] = declared;
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
  if (online_before >= 0.0) {
    js["online_joint_rmse_before"] = online_before;
    js["online_joint_rmse_after"] = online_after;
    for (int j = 0; j < online_joint_before.size(); ++j)
      js["online_joints"].push_back({{"name", model.joint_names[j]}, {"rmse_before", online_joint_before[j]},
                                     {"rmse_after", online_joint_after[j]}});
  }
  for (const est::Finding& f : res.findings) {
    js["findings"].push_back({{"joint", model.joint_names[f.effect.joint]}, {"kind", est::effectKindName(f.effect.kind)},
                              {"value", f.effect.value}, {"unit", est::effectUnit(f.effect.kind)},
                              {"std_error", f.std_error}, {"explained", f.explained}, {"p_value", f.p_value},
                              {"tested", f.tested}, {"sentence", f.sentence}});
    if (f.effect.width > 0.0) js["findings"].back()["width"] = f.effect.width;  // rad/s, Coulomb and Stribeck
  }
  if (res.findings.empty()) js["findings"] = nlohmann::json::array();
  js["declared_model"] = declared_model_path.empty() ? nlohmann::json(nullptr) : nlohmann::json(declared_model_path);
  auto payloadJson = [&](const est::PayloadFinding& pf) {
    return nlohmann::json{{"link", model.body_names[pf.link]}, {"mass", pf.mass}, {"mass_se", pf.mass_se},
                          {"com", {pf.com[0], pf.com[1], pf.com[2]}}, {"com_se", {pf.com_se[0], pf.com_se[1], pf.com_se[2]}},
                          {"explained", pf.explained}, {"p_value", pf.p_value}, {"separable", pf.separable},
                          {"tested", pf.tested}, {"status", pf.status}, {"sentence", pf.sentence}};
  };
  js["payloads"] = nlohmann::json::array();
  for (const est::PayloadFinding& pf : res.payloads) js["payloads"].push_back(payloadJson(pf));
  js["payload_candidates"] = nlohmann::json::array();
  for (const est::PayloadFinding& pf : res.payload_first_step) js["payload_candidates"].push_back(payloadJson(pf));
  if (!payload_urdf.empty()) js["payload_urdf"] = payload_urdf;
  for (const est::CoordinateSummary& c : res.coordinates)
    js["coordinates"].push_back({{"name", c.name}, {"rmse_before", c.rms_before}, {"rmse_after", c.rms_after},
                                 {"train_rmse_before", c.train_rms_before}, {"train_rmse_after", c.train_rms_after},
                                 {"noise_floor", c.noise_floor}, {"lag1_before", c.lag1_before}, {"lag1_after", c.lag1_after}});
  std::string predictability_md, predictability_console;
  if (!writePredictability(out_dir, model, res.predictability, opt.predictability, !no_plots, python, js,
                           &predictability_md, &predictability_console, &err))
    return fail(err);
  {
    std::ofstream f;
    if (!open("summary.json", f)) return 2;
    f << js.dump(2) << '\n';
  }

  // Plots.
  {
    std::ofstream f;
    if (!open("plot_diagnose.py", f)) return 2;
    f << kPlotScript;
  }
  bool plotted = false;
  if (!no_plots && !plot_csv.empty()) {
    const std::string cmd = python + " '" + (out / "plot_diagnose.py").string() + "' '" + plot_csv + "'";
    plotted = std::system(cmd.c_str()) == 0;
    if (!plotted) std::fprintf(stderr, "exoid diagnose: warning: the plot script failed (%s); the CSVs are written\n", cmd.c_str());
  }

  // report.md
  std::ostringstream md;
  char buf[512];
  md << "# exoid diagnose report\n\n";
  md << "Model `" << model_path << "` (" << (model.floating_base ? "floating" : "fixed") << " base, " << model.njoints
     << " joints); declared model: " << (opt.declared_friction ? "rigid body + viscous and Coulomb friction" : "rigid body")
     << ", " << res.declared_columns << " base-parameter columns excited";
  if (res.dropped_columns) md << " (" << res.dropped_columns << " structural ones not excited, left out)";
  md << ".\n\nTraining: ";
  for (const std::string& f : train_files) md << '`' << f << "` ";
  if (!calib_files.empty()) {
    md << "and the calibration run" << (calib_files.size() > 1 ? "s " : " ");
    for (const std::string& f : calib_files) md << '`' << f << "` ";
    md << "(pelvis held in a harness, legs swinging: joint rows only) ";
  }
  md << "(" << res.train_samples << " samples). Held-out validation: ";
  if (val_files.empty() && val_calib_files.empty()) md << "none (the before/after numbers below are training numbers)";
  for (const std::string& f : val_files) md << '`' << f << "` ";
  for (const std::string& f : val_calib_files) md << '`' << f << "` (calibration) ";
  if (!val_files.empty() || !val_calib_files.empty()) md << "(" << res.validation_samples << " samples)";
  std::snprintf(buf, sizeof buf,
                ".\n\nSelection: %d candidate columns, forward selection; an effect is accepted when the one-sided paired "
                "t-test of the held-out squared-error reduction over %d time-block folds has p < %g / (candidates of the "
                "step), it removes at least %.0f %% of its joint's held-out residual, and its value has the physical "
                "sign. False-alarm rate on data without an undeclared effect: <= %g per data set. Method: "
                "docs/diagnose.md.\n\n",
                res.candidates, opt.folds, opt.alpha, 100 * opt.min_explained, opt.alpha);
  md << buf;
  if (!md_inputs.str().empty()) md << "## Input skipped\n\n" << md_inputs.str() << "\n";
  if (opt.hold_declared)
    md << "Declared rigid-body parameters held at `" << declared_model_path << "` (not identified: the residual is y - K "
          "phi_declared); every link tested for a payload.\n\n";
  md << "## Findings\n\n";
  if (res.findings.empty() && res.payloads.empty())
    md << "None: no candidate effect passed the test; the residual is what the data allow.\n";
  for (const est::PayloadFinding& pf : res.payloads) md << "- " << pf.sentence << "\n";
  for (const est::Finding& f : res.findings) md << "- " << f.sentence << "\n";
  if (opt.payload && !opt.hold_declared)
    md << "\nPayloads: not tested. The declared model is identified from these data, so a rigid body fixed to a link "
          "moves that link's identified parameters instead of the residual (not separable); `--declared-model URDF` "
          "holds them and tests every link.\n";
  if (opt.hold_declared && !res.payload_first_step.empty()) {
    md << "\n### Payload candidates (first step)\n\n| link | mass (kg) | CoM in the link frame (m) | explains | p | "
          "separable | verdict |\n|---|---|---|---|---|---|---|\n";
    for (const est::PayloadFinding& pf : res.payload_first_step) {
      std::snprintf(buf, sizeof buf, "| %s | %.3g | (%.3f, %.3f, %.3f) | %.0f %% | %.2g | %.2g | %s |\n",
                    model.body_names[pf.link].c_str(), pf.mass, pf.com[0], pf.com[1], pf.com[2], 100 * pf.explained,
                    pf.p_value, pf.separable, pf.status.c_str());
      md << buf;
    }
  }
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
                  c.noise_floor > 0 ? c.rms_before / c.noise_floor : 0.0, est::effectKindWords(c.best_kind), c.best_correlation);
    md << buf;
  }
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
  // What these data cannot show: candidates almost entirely inside the declared model's span.
  {
    std::map<std::string, std::vector<const est::CandidateScore*>> hidden;
    for (const est::CandidateScore& c : res.first_step)
      if (c.separable < kHiddenSeparable) hidden[est::effectKindWords(c.effect.kind)].push_back(&c);
    if (!hidden.empty()) {
      md << "## What these data cannot show\n\nCandidates with less than " << 100 * kHiddenSeparable
         << " % of their signal outside the span of the declared model's columns: the identified rigid-body parameters "
            "absorb nearly all of them (e.g. a constant torque on a joint of a robot that only balances is a "
            "first-moment shift of the links around it), and only an effect well above the smallest visible value "
            "given here (3 standard errors of its estimate, jackknifed over the time-block folds) could show. Motions that turn the "
            "joints through large angles separate them: a calibration run (`exoid calibrate`, `--calibration`) makes a "
            "torque offset of a few hundredths of a N m visible.\n\n"
            "| kind | joints (fraction of the signal outside the span; smallest visible value) |\n|---|---|\n";
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
  }
  md << predictability_md;
  md << "## Plots\n\n";
  if (plotted)
    md << "![RMSE per coordinate](rmse.png)\n\n![Residual against the chosen signal](residual_vs_signal.png)\n\n"
          "Each panel: the joint's residual against the signal of its first finding (or, without a finding, the best-correlated "
          "candidate; velocity for an offset), before (blue) and after (orange).\n\n![Residual spectra](spectra.png)\n\n";
  else
    md << "Not drawn (run `python3 plot_diagnose.py " << plot_csv << "` here with matplotlib).\n\n";
  md << "## Augmented model\n\n`" << set.model << "` (the rigid-body model, unchanged) + `effects.yaml` (the accepted "
        "effects: dynamics columns and measurement corrections; format in docs/diagnose.md).\n";
  if (!payload_urdf.empty())
    md << "\n`" << payload_urdf << "`: the declared model with the payloads found added to their links (point masses).\n";
  {
    std::ofstream f;
    if (!open("report.md", f)) return 2;
    f << md.str();
  }

  // Console summary.
  std::printf("declared model: %d base-parameter columns; %d candidates; %ld training / %ld validation samples\n",
              res.declared_columns, res.candidates, res.train_samples, res.validation_samples);
  for (const est::PayloadFinding& pf : res.payloads) std::printf("  %s\n", pf.sentence.c_str());
  for (const est::Finding& f : res.findings) std::printf("  %s\n", f.sentence.c_str());
  if (res.findings.empty() && res.payloads.empty()) std::printf("  no finding\n");
  std::printf("%s", predictability_console.c_str());
  std::printf("%-16s %10s %10s\n", "coordinate", "before", "after");
  for (const est::CoordinateSummary& c : res.coordinates) std::printf("%-16s %10.4f %10.4f\n", c.name.c_str(), c.rms_before, c.rms_after);
  std::printf("%-16s %10.4f %10.4f   (%s RMSE, N m)\n", "pooled", res.pooled_before, res.pooled_after,
              res.has_validation ? "held-out" : "training");
  if (online_before >= 0.0)
    std::printf("online estimator (RecursiveLs on the training rows, prediction on the validation rows), joints: "
                "%.4f -> %.4f N m with the sidecar's columns\n", online_before, online_after);
  std::printf("report: %s\n", (out / "report.md").string().c_str());
  return 0;
}

}  // namespace exoid::cli
