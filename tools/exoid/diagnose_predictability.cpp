// Outputs of the residual-predictability stage of `exoid diagnose` (diagnose_predictability.hpp).
#include "diagnose_predictability.hpp"

#include "diagnose_report.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace exoid::cli {

namespace fs = std::filesystem;
namespace est = exoid::estimator;

namespace diagnose_predictability {  // this file's own names: the exoid binary is a unity build
// Per joint: the held-out residual against the stage's predictions over time (validation segments, else the
// cross-fitted training segments), and the predictable shares with their standard errors as bars.
constexpr char kPlotScript[] = R"PY(#!/usr/bin/env python3
# Plot of `exoid diagnose`'s last stage (residual predictability) from the CSVs next to this script (docs/diagnose.md).
import csv, math, os
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "predictability.csv")) as f:
    rows = list(csv.DictReader(f))
with open(os.path.join(here, "predictability_series.csv")) as f:
    rd = csv.reader(f); h = next(rd); data = list(rd)
col = {n: i for i, n in enumerate(h)}
has_val = any(r[col["validation"]] == "1" for r in data)
data = [r for r in data if (r[col["validation"]] == "1") == has_val]
seg = [r[col["segment"]] for r in data]
first = [r for r in data if r[col["segment"]] == seg[0]] if data else []
t = np.array([float(r[col["t"]]) for r in first])
n = len(rows); nc = min(3, n + 1); nr = int(math.ceil((n + 1) / nc))
fig, axes = plt.subplots(nr, nc, figsize=(5 * nc, 3.0 * nr), squeeze=False)
for k, r in enumerate(rows):
    ax = axes[k // nc][k % nc]; j = r["joint"]
    get = lambda c: np.array([float(x[col[c + "_" + j]]) for x in first])
    ax.plot(t, get("residual"), lw=0.9, color="k", label="residual after augmentation")
    ax.plot(t, get("sparse"), lw=0.9, label="sparse model (held-out share %.0f %%)" % (100 * float(r["share_sparse"])))
    if "trees_" + j in col and r["share_trees"] != "":
        ax.plot(t, get("trees"), lw=0.9, label="boosted trees (held-out share %.0f %%)" % (100 * float(r["share_trees"])))
    ax.set_title(j + (": predictable" if r["predictable"] == "1" else ""), fontsize=9)
    ax.set_xlabel("t (s), " + seg[0] + (" (held out)" if has_val else " (cross-fitted)"), fontsize=8)
    ax.set_ylabel("N m", fontsize=8); ax.grid(alpha=0.3)
    if k == 0: ax.legend(fontsize=6)
    else: ax.legend(fontsize=6, handles=ax.get_lines()[1:], labels=[l.get_label() for l in ax.get_lines()[1:]])
ax = axes[n // nc][n % nc]
x = np.arange(n)
for off, m, lab in ((-0.2, "sparse", "sparse model"), (0.2, "trees", "boosted trees")):
    s = np.array([float(r["share_" + m]) if r["share_" + m] != "" else 0.0 for r in rows])
    e = np.array([float(r["se_" + m]) if r["se_" + m] != "" else 0.0 for r in rows])
    ax.bar(x + off, 100 * s, 0.4, yerr=100 * e, label=lab, capsize=2)
for k, r in enumerate(rows):
    if r["predictable"] == "1": ax.annotate("*", (k, 100 * float(r["share"]) + 2), ha="center")
ax.axhline(0, color="k", lw=0.6)
ax.set_xticks(x); ax.set_xticklabels([r["joint"] for r in rows], rotation=30, ha="right", fontsize=7)
ax.set_ylabel("predictable share of the held-out residual (%)", fontsize=8); ax.legend(fontsize=7); ax.grid(axis="y", alpha=0.3)
ax.set_title("* significant (Bonferroni over joints and methods)", fontsize=8)
for k in range(n + 1, nr * nc): axes[k // nc][k % nc].axis("off")
fig.suptitle("Is the remaining residual predictable from the state? (held-out data)")
fig.tight_layout(); fig.savefig(os.path.join(here, "predictability.png"), dpi=100); plt.close(fig)
)PY";

std::string pct(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", 100.0 * x);
  return b;
}


// The reported method's variable weights ("name:percent ...") and the sparse terms ("+coef*term ...").
std::string variablesText(const est::JointPredictability& j) {
  std::string s;
  for (const auto& [name, w] : j.variables) s += (s.empty() ? "" : " ") + name + ":" + pct(w);
  return s;
}
std::string termsText(const est::JointPredictability& j) {
  std::string s;
  char b[64];
  for (const est::PredictabilityTerm& t : j.terms) {
    std::snprintf(b, sizeof b, "%+.4g*", t.coefficient);
    s += (s.empty() ? "" : " ") + std::string(b) + t.name;
  }
  return s;
}

// predictability.csv: one row per tested joint.
bool writeJointsCsv(const fs::path& out, const Model& model, const est::PredictabilityResult& res,
                    const est::PredictabilityOptions& opt, std::string* error) {
  std::ofstream f;
  if (!openOut(out, "predictability.csv", f, error)) return false;
  f << "joint,predictable,verdict,predictable_rms,method,share,std_error,p_value,level,share_sparse,se_sparse,p_sparse,share_trees,se_trees,"
       "p_trees,validation_share_sparse,validation_share_trees,rms,blocks,variables,terms\n";
  for (const est::JointPredictability& j : res.joints) {
    f << model.joint_names[j.joint] << ',' << (j.predictable ? 1 : 0) << ',' << j.verdict << ',' << j.predictable_rms
      << ',' << j.method << ',' << j.share << ','
      << j.se << ',' << j.p << ',' << res.level << ',' << j.share_sparse << ',' << j.se_sparse << ',' << j.p_sparse << ',';
    if (opt.trees) f << j.share_trees << ',' << j.se_trees << ',' << j.p_trees;
    else f << ",,";
    f << ',' << j.validation_share_sparse << ',' << (opt.trees ? std::to_string(j.validation_share_trees) : "") << ','
      << j.rms << ',' << j.blocks << ",\"" << variablesText(j) << "\",\"" << termsText(j) << "\"\n";
  }
  return true;
}

// predictability_series.csv: per segment's stage sample the residual and both methods' predictions per joint.
bool writeSeriesCsv(const fs::path& out, const Model& model, const est::PredictabilityResult& res, std::string* error) {
  std::ofstream f;
  if (!openOut(out, "predictability_series.csv", f, error)) return false;
  f << "segment,validation,t";
  for (const est::JointPredictability& j : res.joints) {
    const std::string& n = model.joint_names[j.joint];
    f << ",residual_" << n << ",sparse_" << n << ",trees_" << n;
  }
  f << '\n';
  char b[96];
  for (const est::PredictabilityResult::Series& s : res.series)
    for (long i = 0; i < s.t.size(); ++i) {
      std::snprintf(b, sizeof b, "%.6f", s.t[i]);
      f << s.segment << ',' << (s.validation ? 1 : 0) << ',' << b;
      for (const est::JointPredictability& j : res.joints) {
        std::snprintf(b, sizeof b, ",%.6g,%.6g,%.6g", s.residual(i, j.joint), s.sparse(i, j.joint), s.trees(i, j.joint));
        f << b;
      }
      f << '\n';
    }
  return true;
}

// summary.json's "predictability" entry.
nlohmann::json predictabilityJson(const Model& model, const est::PredictabilityResult& res,
                                  const est::PredictabilityOptions& opt) {
  nlohmann::json pj;
  pj["ran"] = true;
  pj["level"] = res.level;
  pj["pooled_rms"] = res.pooled_rms;
  pj["min_rms_fraction"] = opt.min_rms_fraction;
  pj["tests"] = res.tests;
  pj["has_q"] = res.has_q;
  pj["block_seconds"] = opt.block_seconds;
  pj["rate_hz"] = opt.rate_hz;
  pj["joints"] = nlohmann::json::array();
  for (const est::JointPredictability& j : res.joints) {
    nlohmann::json v = nlohmann::json::array(), t = nlohmann::json::array();
    for (const auto& [name, w] : j.variables) v.push_back({{"name", name}, {"weight", w}});
    for (const est::PredictabilityTerm& x : j.terms)
      t.push_back({{"term", x.name}, {"coefficient", x.coefficient}, {"weight", x.weight}});
    pj["joints"].push_back({{"joint", model.joint_names[j.joint]}, {"predictable", j.predictable}, {"verdict", j.verdict},
                            {"predictable_rms", j.predictable_rms}, {"method", j.method},
                            {"share", j.share}, {"std_error", j.se}, {"p_value", j.p}, {"share_sparse", j.share_sparse},
                            {"p_sparse", j.p_sparse}, {"share_trees", j.share_trees}, {"p_trees", j.p_trees},
                            {"validation_share_sparse", j.validation_share_sparse},
                            {"validation_share_trees", j.validation_share_trees}, {"rms", j.rms}, {"blocks", j.blocks},
                            {"variables", v}, {"terms", t}, {"sentence", j.sentence}});
  }
  return pj;
}

// The report.md section (method, named joints, the table) and the console lines.
void predictabilityReport(const Model& model, const est::PredictabilityResult& res, const est::PredictabilityOptions& opt,
                          bool plotted, std::string* report, std::string* console) {
  std::ostringstream md, con;
  char buf[2048];
  md << "## Is the remaining residual predictable from the state?\n\n";
  std::snprintf(buf, sizeof buf,
                "The residual after augmentation, decimated to %g Hz, per joint against a dictionary of the state of the "
                "joint and its kinematic neighbours (%sv, a, model torque, their products, tanh(v / w), lagged v(t - L) "
                "and q(t) - q(t - L)) by sparse regression, and against the raw state by gradient-boosted trees%s. Held "
                "out: %d contiguous training folds (each predicted by models fitted %g s away from it) and the validation "
                "runs; share = 1 - SSE(r - prediction) / SSE(r) over held-out blocks of %g s, +- its jackknife standard "
                "error; a joint is named when the one-sided t-test over the blocks has p < %.2g (alpha / %d tests), "
                "the share is at least the minimum and the predictable part, sqrt(share) x RMS, is at least %g of the "
                "pooled held-out RMS (%.3g N m). Never the lagged residual: an autocorrelated noise is not "
                "predictable from the state.\n\n",
                opt.rate_hz, res.has_q ? "q, sin q, cos q, " : "", opt.trees ? " (XGBoost)" : " (off)", opt.folds,
                opt.block_seconds, opt.block_seconds, res.level, res.tests, opt.min_rms_fraction, res.pooled_rms);
  md << buf;
  bool any = false;
  for (const est::JointPredictability& j : res.joints)
    if (j.predictable) md << "- " << j.sentence << "\n", con << "  " << j.sentence << "\n", any = true;
  if (!any) {
    md << "Nothing: no joint's remaining residual is predictable from the state on held-out data.\n";
    con << "  residual predictability: nothing predictable from the state on held-out data\n";
  }
  md << "\n| joint | verdict | held-out RMS (N m) | sparse: share +- SE (p) | trees: share +- SE (p) | validation only: sparse / trees | "
        "depends on | sparse terms |\n|---|---|---|---|---|---|---|---|\n";
  for (const est::JointPredictability& j : res.joints) {
    std::string trees = "-";
    if (opt.trees) {
      std::snprintf(buf, sizeof buf, "%.0f %% +- %.0f (%.2g)", 100 * j.share_trees, 100 * j.se_trees, j.p_trees);
      trees = buf;
    }
    std::snprintf(buf, sizeof buf, "| %s | %s | %.3f | %.0f %% +- %.0f (%.2g) | %s | %.0f %% / %.0f %% | ",
                  model.joint_names[j.joint].c_str(), j.verdict.c_str(), j.rms, 100 * j.share_sparse,
                  100 * j.se_sparse, j.p_sparse, trees.c_str(), 100 * j.validation_share_sparse,
                  100 * j.validation_share_trees);
    md << buf << variablesText(j) << " | " << termsText(j) << " |\n";
  }
  md << "\n(`predictability.csv`; variable weights in %: the reported method's, sparse terms' standardized squared "
        "coefficients or the trees' total split gain.)\n\n";
  if (plotted) md << "![Residual against the stage's predictions](predictability.png)\n\n";
  if (report) *report = md.str();
  if (console) *console = con.str();
}
}  // namespace diagnose_predictability

bool writePredictability(const std::string& out_dir, const Model& model, const estimator::PredictabilityResult& res,
                         const estimator::PredictabilityOptions& opt, bool plot, const std::string& python,
                         nlohmann::json& js, std::string* report, std::string* console, std::string* error) {
  using namespace diagnose_predictability;
  if (!res.ran) {
    js["predictability"] = {{"ran", false}};
    if (report) *report = "";
    if (console) *console = "";
    return true;
  }
  const fs::path out(out_dir);
  bool plotted = false;
  if (!writeJointsCsv(out, model, res, opt, error) || !writeSeriesCsv(out, model, res, error) ||
      !writePlotScript(out_dir, "plot_predictability.py", kPlotScript, plot && !res.joints.empty(), python, "", &plotted,
                       error))
    return false;
  js["predictability"] = predictabilityJson(model, res, opt);
  predictabilityReport(model, res, opt, plotted, report, console);
  return true;
}

}  // namespace exoid::cli
