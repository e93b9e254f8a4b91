// Outputs of the unmeasured-body stage of `exoid diagnose` (diagnose_unmeasured_body.hpp).
#include "diagnose_unmeasured_body.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "diagnose_report.hpp"

namespace exoid::cli {

namespace fs = std::filesystem;
namespace est = exoid::estimator;

namespace diagnose_unmeasured_body {  // this file's own names: the exoid binary is a unity build
// Per plane: the moment row's held-out residual against the body's and the null's predictions over time (the first
// validation segment, else the first cross-fitted training segment).
constexpr char kPlotScript[] = R"PY(#!/usr/bin/env python3
# Plot of `exoid diagnose`'s unmeasured-body stage from the CSVs next to this script (docs/diagnose.md).
import csv, os
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "unmeasured_body.csv")) as f:
    planes = list(csv.DictReader(f))
with open(os.path.join(here, "unmeasured_body_series.csv")) as f:
    data = list(csv.DictReader(f))
has_val = any(r["validation"] == "1" for r in data)
data = [r for r in data if (r["validation"] == "1") == has_val]
seg = data[0]["segment"] if data else ""
data = [r for r in data if r["segment"] == seg]
t = np.array([float(r["t"]) for r in data])
fig, axes = plt.subplots(len(planes), 1, figsize=(10, 3.0 * len(planes)), squeeze=False)
for k, p in enumerate(planes):
    ax = axes[k][0]; n = p["moment_row"]
    get = lambda c: np.array([float(r[c + "_" + n]) for r in data])
    ax.plot(t, get("residual"), lw=0.9, color="k", label=p["moment_row"] + " residual after augmentation")
    ax.plot(t, get("null"), lw=0.9, label="null: the base's motion through a fast filter")
    ax.plot(t, get("body"), lw=0.9, label="driven body on a spring, %s Hz, damping %s (held-out share %.0f %%, null %.0f %%)"
            % (p["frequency_hz"], p["damping_ratio"], 100 * float(p["driven_share"]), 100 * float(p["driven_null_share"])))
    ax.set_title("%s plane: %s (gravity signature b/g %.2f, gain %.0f %%)" % (p["plane"], p["verdict"],
                 float(p["gravity_ratio"]), 100 * float(p["gravity_gain"])), fontsize=9)
    ax.set_xlabel("t (s), " + seg + (" (held out)" if has_val else " (cross-fitted)"), fontsize=8)
    ax.set_ylabel("N m", fontsize=8); ax.grid(alpha=0.3); ax.legend(fontsize=7)
fig.suptitle("Does an unmeasured body move on the base? (held-out data)")
fig.tight_layout(); fig.savefig(os.path.join(here, "unmeasured_body.png"), dpi=100); plt.close(fig)
)PY";

// One row per plane: the two signatures' figures (gravity_*, driven_*).
bool writePlanesCsv(const fs::path& out, const est::UnmeasuredBodyResult& res, std::string* error) {
  std::ofstream f;
  if (!openOut(out, "unmeasured_body.csv", f, error)) return false;
  f << "plane,found,verdict,moment_row,force_row,moment_rms,force_rms,level";
  for (const char* t : {"gravity", "driven"})
    for (const char* c : {"passed", "share", "null_share", "gain", "gain_std_error", "p_value", "validation_share",
                          "validation_gain", "blocks"})
      f << ',' << t << '_' << c;
  f << ",gravity_ratio,lever_m,first_moment_rms_kgm,frequency_hz,damping_ratio,moment_share,force_share\n";
  for (const est::UnmeasuredBodyPlane& p : res.planes) {
    f << p.plane << ',' << (p.found ? 1 : 0) << ",\"" << p.verdict << "\"," << p.moment_row << ',' << p.force_row << ','
      << p.moment_rms << ',' << p.force_rms << ',' << res.level;
    for (const est::BodyTest* t : {&p.gravity, &p.driven})
      f << ',' << (t->passed ? 1 : 0) << ',' << t->share << ',' << t->null_share << ',' << t->gain << ',' << t->se << ','
        << t->p << ',' << t->validation_share << ',' << t->validation_gain << ',' << t->blocks;
    f << ',' << p.gravity_ratio << ',' << p.lever << ',' << p.first_moment_rms << ',' << p.frequency_hz << ','
      << p.damping_ratio << ',' << p.moment_share << ',' << p.force_share << '\n';
  }
  return true;
}

bool writeSeriesCsv(const fs::path& out, const est::UnmeasuredBodyResult& res, std::string* error) {
  std::ofstream f;
  if (!openOut(out, "unmeasured_body_series.csv", f, error)) return false;
  f << "segment,validation,t";
  for (const est::UnmeasuredBodyPlane& p : res.planes)
    for (const std::string& row : {p.moment_row, p.force_row}) f << ",residual_" << row << ",body_" << row << ",null_" << row;
  f << '\n';
  char b[96];
  for (const est::UnmeasuredBodyResult::Series& s : res.series)
    for (long i = 0; i < s.t.size(); ++i) {
      std::snprintf(b, sizeof b, "%.6f", s.t[i]);
      f << s.segment << ',' << (s.validation ? 1 : 0) << ',' << b;
      for (size_t c = 0; c < 2 * res.planes.size(); ++c) {
        std::snprintf(b, sizeof b, ",%.6g,%.6g,%.6g", s.residual(i, c), s.body(i, c), s.null(i, c));
        f << b;
      }
      f << '\n';
    }
  return true;
}

nlohmann::json testJson(const est::BodyTest& t) {
  return {{"passed", t.passed}, {"share", t.share}, {"null_share", t.null_share}, {"gain", t.gain},
          {"gain_std_error", t.se}, {"p_value", t.p}, {"validation_share", t.validation_share},
          {"validation_gain", t.validation_gain}, {"blocks", t.blocks}};
}

nlohmann::json unmeasuredBodyJson(const est::UnmeasuredBodyResult& res, const est::UnmeasuredBodyOptions& opt) {
  nlohmann::json j;
  j["ran"] = true;
  j["level"] = res.level;
  j["frequencies_hz"] = opt.frequencies_hz;
  j["damping_ratios"] = opt.damping_ratios;
  j["null_frequency_hz"] = opt.null_frequency_hz;
  j["leak_hz"] = opt.leak_hz;
  j["block_seconds"] = opt.block_seconds;
  j["planes"] = nlohmann::json::array();
  for (const est::UnmeasuredBodyPlane& p : res.planes)
    j["planes"].push_back({{"plane", p.plane}, {"found", p.found}, {"verdict", p.verdict}, {"moment_row", p.moment_row},
                           {"force_row", p.force_row}, {"moment_rms", p.moment_rms}, {"force_rms", p.force_rms},
                           {"gravity", testJson(p.gravity)}, {"gravity_ratio", p.gravity_ratio}, {"lever_m", p.lever},
                           {"first_moment_rms_kgm", p.first_moment_rms}, {"driven", testJson(p.driven)},
                           {"frequency_hz", p.frequency_hz}, {"damping_ratio", p.damping_ratio},
                           {"moment_share", p.moment_share}, {"force_share", p.force_share}, {"sentence", p.sentence}});
  return j;
}

void unmeasuredBodyReport(const est::UnmeasuredBodyResult& res, const est::UnmeasuredBodyOptions& opt, bool plotted,
                          std::string* report, std::string* console) {
  std::ostringstream md, con;
  char buf[2048];
  md << "## Does an unmeasured body move on the base?\n\n";
  std::snprintf(buf, sizeof buf,
                "The base rows' residual after augmentation, per plane (sagittal: base_ny, base_fx; frontal: base_nx, "
                "base_fy), tested for two signatures of a body no sensor measures. The gravity signature: the double "
                "integral of the force row (a leaky one, %g Hz; both rows high-passed alike) is a moving mass's first "
                "moment, which the moment row carries times -g (frontal +g) whatever moves the mass: it is predicted "
                "from the moment row beyond the force row alone. The driven response: a body on a spring at the base answering the base's own motion (its "
                "specific force and angular acceleration through a second-order low-pass, %g-%g Hz, damping %g-%g), "
                "against the same inputs through a %g Hz filter and their first two derivatives. Held out: %d "
                "contiguous training folds (each predicted from fits %g s away from it) and the validation runs; over "
                "held-out blocks of %g s, share = 1 - SSE / SSE(r), gain = (SSE_null - SSE_model) / SSE(r) +- its "
                "jackknife standard error; a signature passes when the one-sided t-test of the gain has p < %.2g "
                "(alpha / 4 tests), the gain is at least the minimum and, for the gravity signature, the moment row's "
                "coefficient has gravity's sign (b / g > 0; 1 for a moving mass, lower with the moment row's noise).\n\n",
                opt.leak_hz, opt.frequencies_hz.front(), opt.frequencies_hz.back(), opt.damping_ratios.front(),
                opt.damping_ratios.back(), opt.null_frequency_hz, opt.folds, opt.block_seconds, opt.block_seconds,
                res.level);
  md << buf;
  bool any = false;
  for (const est::UnmeasuredBodyPlane& p : res.planes)
    if (p.found) md << "- " << p.sentence << "\n", con << "  " << p.sentence << "\n", any = true;
  if (!any) {
    md << "Nothing: neither plane's base-row residual has the signature of an unmeasured body.\n";
    con << "  unmeasured body: none found on the base rows\n";
  }
  md << "\n| plane | base rows RMS | gravity: b / g, height, first moment | gravity: share model / null, gain +- SE (p) | "
        "driven: resonance | driven: share model / null, gain +- SE (p) | verdict |\n|---|---|---|---|---|---|---|\n";
  for (const est::UnmeasuredBodyPlane& p : res.planes) {
    std::snprintf(buf, sizeof buf,
                  "| %s | %.3g N m, %.3g N | %.2f, %.2f m, %.2g kg m | %.0f %% / %.0f %%, %.0f %% +- %.0f (%.2g) | %g Hz, "
                  "%g | %.0f %% / %.0f %%, %.0f %% +- %.0f (%.2g) | %s |\n",
                  p.plane.c_str(), p.moment_rms, p.force_rms, p.gravity_ratio, p.lever, p.first_moment_rms,
                  100 * p.gravity.share, 100 * p.gravity.null_share, 100 * p.gravity.gain, 100 * p.gravity.se,
                  p.gravity.p, p.frequency_hz, p.damping_ratio, 100 * p.driven.share, 100 * p.driven.null_share,
                  100 * p.driven.gain, 100 * p.driven.se, p.driven.p, p.verdict.c_str());
    md << buf;
  }
  md << "\n(`unmeasured_body.csv`.)\n\n";
  if (plotted) md << "![Base-row residual against the body's response](unmeasured_body.png)\n\n";
  if (report) *report = md.str();
  if (console) *console = con.str();
}
}  // namespace diagnose_unmeasured_body

bool writeUnmeasuredBody(const std::string& out_dir, const est::UnmeasuredBodyResult& res,
                         const est::UnmeasuredBodyOptions& opt, bool plot, const std::string& python, nlohmann::json& js,
                         std::string* report, std::string* console, std::string* error) {
  using namespace diagnose_unmeasured_body;
  if (!res.ran) {
    js["unmeasured_body"] = {{"ran", false}};
    if (report) *report = "";
    if (console) *console = "";
    return true;
  }
  const fs::path out(out_dir);
  bool plotted = false;
  if (!writePlanesCsv(out, res, error) || !writeSeriesCsv(out, res, error) ||
      !writePlotScript(out_dir, "plot_unmeasured_body.py", kPlotScript, plot && !res.planes.empty(), python, "", &plotted,
                       error))
    return false;
  js["unmeasured_body"] = unmeasuredBodyJson(res, opt);
  unmeasuredBodyReport(res, opt, plotted, report, console);
  return true;
}

}  // namespace exoid::cli
