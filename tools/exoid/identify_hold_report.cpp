// `exoid identify --hold`'s writers (identify_hold_report.hpp).
#include "identify_hold_report.hpp"

#include <cmath>
#include <cstdio>

#include "diagnose_report.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/tools/csv.hpp"

namespace exoid::cli {

namespace identify_hold_report {  // this file's own names: the exoid binary is a unity build

constexpr char kPlotScript[] = R"PY(#!/usr/bin/env python3
# wearer.png from wearer.csv next to this script (written by `exoid identify --hold`; docs/wearer.md).
import csv, os
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
here = os.path.dirname(os.path.abspath(__file__))
rows = list(csv.DictReader(open(os.path.join(here, "wearer.csv"))))
links = [r["link"] for r in rows]
val = lambda r, k: float(r[k]) if r[k] != "" else float("nan")
truth = all(r["truth_mass_kg"] != "" for r in rows)
fig, ax = plt.subplots(1, 2, figsize=(max(8, 1.6 * len(links) + 4), 4))
x = range(len(links))
kinds = [("prior", "table prior"), ("identified", "identified")] + ([("truth", "truth")] if truth else [])
w = 0.8 / len(kinds)
if truth:
    for i, (k, label) in enumerate([("prior", "table prior"), ("identified", "identified")]):
        ax[0].bar([p + (i - 0.5) * 0.4 for p in x], [val(r, k + "_mass_kg") - val(r, "truth_mass_kg") for r in rows],
                  0.4, label=label)
    ax[0].axhline(0.0, color="k", lw=0.8)
    ax[0].set_ylabel("mass error against the truth (kg)"); ax[0].set_title("added mass per carrying link")
else:
    for i, (k, label) in enumerate(kinds):
        ax[0].bar([p + (i - (len(kinds) - 1) / 2) * w for p in x], [val(r, k + "_mass_kg") for r in rows], w, label=label)
    ax[0].set_ylabel("added mass on the link (kg)"); ax[0].set_title("mass per carrying link")
ax[0].set_xticks(list(x)); ax[0].set_xticklabels(links, rotation=30, ha="right"); ax[0].legend()
if truth:
    for i, (k, label) in enumerate([("prior", "table prior"), ("identified", "identified")]):
        ax[1].bar([p + (i - 0.5) * 0.4 for p in x], [1e3 * val(r, k + "_com_error_m") for r in rows], 0.4, label=label)
    ax[1].set_ylabel("CoM error against the truth (mm)"); ax[1].set_title("CoM of the added bodies")
else:
    ax[1].bar(list(x), [1e3 * val(r, "com_shift_m") for r in rows], 0.6)
    ax[1].set_ylabel("identified CoM - table prior CoM (mm)"); ax[1].set_title("CoM moved by the data")
ax[1].set_xticks(list(x)); ax[1].set_xticklabels(links, rotation=30, ha="right"); ax[1].legend() if truth else None
fig.tight_layout(); fig.savefig(os.path.join(here, "wearer.png"), dpi=110)
)PY";

// Mass and CoM (link coordinates) of a parameter vector; CoM NaN when the mass is not positive.
InertialProperties massCom(const Vector10d& phi) {
  InertialProperties p;
  if (!inertialFromParams(phi, p)) p.mass = phi[0], p.com.setConstant(NAN);
  return p;
}

std::string joined(const std::vector<std::string>& v, const char* sep) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

nlohmann::json massComJson(const Vector10d& phi) {
  const InertialProperties p = massCom(phi);
  return {{"mass_kg", p.mass}, {"com_m", std::isfinite(p.com.x()) ? nlohmann::json({p.com.x(), p.com.y(), p.com.z()})
                                                                  : nlohmann::json(nullptr)}};
}

}  // namespace identify_hold_report

void printHoldReport(const tools::IdentifyRun& run) {
  using namespace identify_hold_report;
  const tools::SystemComCheck& c = run.system_com;
  if (c.samples > 0) {
    std::printf("system CoM against the truth channel over %ld validation samples, RMSE 3-D (horizontal): prior %.2f "
                "(%.2f) mm, identified %.2f (%.2f) mm, max %.2f mm", c.samples, 1e3 * c.prior_rmse_m,
                1e3 * c.prior_rmse_xy_m, 1e3 * c.identified_rmse_m, 1e3 * c.identified_rmse_xy_m, 1e3 * c.identified_max_m);
    if (c.truth_model_rmse_m >= 0.0)
      std::printf("; the true rigid model %.2f (%.2f) mm: what a rigid model cannot follow (a moving trunk)",
                  1e3 * c.truth_model_rmse_m, 1e3 * c.truth_model_rmse_xy_m);
    std::printf("\n");
  }
  if (run.added.empty()) return;
  double sum[3] = {0.0, 0.0, 0.0};
  std::printf("added bodies (--hold: each carrying link's estimate less the held URDF's):\n");
  for (const tools::AddedBody& a : run.added) {
    const InertialProperties p = massCom(a.prior), i = massCom(a.identified), t = massCom(a.truth);
    std::printf("  %-12s %5.2f kg -> %6.2f kg", run.model.body_names[static_cast<size_t>(a.body)].c_str(), p.mass, i.mass);
    if (a.has_truth)
      std::printf(" (truth %5.2f), CoM error %5.1f mm (prior %5.1f)", t.mass, 1e3 * (i.com - t.com).norm(),
                  1e3 * (p.com - t.com).norm());
    else
      std::printf(", CoM moved %5.1f mm", 1e3 * (i.com - p.com).norm());
    std::printf(", %d of 10 excited: %s\n", a.excited, joined(a.frames, ", ").c_str());
    sum[0] += p.mass, sum[1] += i.mass, sum[2] += t.mass;
  }
  std::printf("  total        %5.2f kg -> %6.2f kg", sum[0], sum[1]);
  if (!run.added.empty() && run.added.front().has_truth) std::printf(" (truth %5.2f)", sum[2]);
  std::printf("\n");
  if (run.model.floating_base && run.added.size() > 1)
    std::printf("  the split between links: standing balance data barely separate the pelvis's share from the legs' (a "
              "mass moved up or down a nearly vertical chain changes little but the height); trust the total and the "
              "horizontal CoM, not one link's share (docs/wearer.md \"Identify the wearer\")\n");
}

void holdJson(const tools::IdentifyRun& run, nlohmann::json& j) {
  using namespace identify_hold_report;
  const tools::SystemComCheck& c = run.system_com;
  auto mm = [](double v) { return v >= 0.0 ? nlohmann::json(v) : nlohmann::json(nullptr); };
  j["system_com"] = c.samples == 0 ? nlohmann::json(nullptr)
                                   : nlohmann::json({{"samples", c.samples}, {"prior_rmse_m", mm(c.prior_rmse_m)},
                                                     {"identified_rmse_m", mm(c.identified_rmse_m)},
                                                     {"identified_max_m", c.identified_max_m},
                                                     {"truth_model_rmse_m", mm(c.truth_model_rmse_m)},
                                                     {"prior_rmse_xy_m", mm(c.prior_rmse_xy_m)},
                                                     {"identified_rmse_xy_m", mm(c.identified_rmse_xy_m)},
                                                     {"truth_model_rmse_xy_m", mm(c.truth_model_rmse_xy_m)}});
  if (run.added.empty()) return;
  nlohmann::json added = nlohmann::json::array();
  for (const tools::AddedBody& a : run.added) {
    nlohmann::json e = {{"link", run.model.body_names[static_cast<size_t>(a.body)]}, {"segments", a.frames},
                        {"excited", a.excited}, {"prior", massComJson(a.prior)}, {"identified", massComJson(a.identified)},
                        {"identified_consistent", checkConsistency(a.identified).consistent}};
    e["truth"] = a.has_truth ? massComJson(a.truth) : nlohmann::json(nullptr);
    added.push_back(e);
  }
  j["added_bodies"] = added;
}

bool writeHoldOutputs(const tools::IdentifyRun& run, const std::string& out_dir, bool plot, const std::string& python,
                      std::string* error) {
  using namespace identify_hold_report;
  if (run.added.empty()) return true;
  tools::AtomicCsvWriter w;
  if (!w.open(out_dir + "/wearer.csv", error)) return false;
  std::fprintf(w.file(), "link,segments,excited,identified_consistent,prior_mass_kg,identified_mass_kg,truth_mass_kg,"
                         "prior_com_x_m,prior_com_y_m,prior_com_z_m,identified_com_x_m,identified_com_y_m,"
                         "identified_com_z_m,truth_com_x_m,truth_com_y_m,truth_com_z_m,com_shift_m,"
                         "prior_com_error_m,identified_com_error_m\n");
  auto num = [](bool have, double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", v);
    return have && std::isfinite(v) ? std::string(b) : std::string();
  };
  for (const tools::AddedBody& a : run.added) {
    const InertialProperties p = massCom(a.prior), i = massCom(a.identified), t = massCom(a.truth);
    std::string row = run.model.body_names[static_cast<size_t>(a.body)] + "," + joined(a.frames, ";") + "," +
                      std::to_string(a.excited) + "," + (checkConsistency(a.identified).consistent ? "1" : "0") + "," +
                      num(true, p.mass) + "," + num(true, i.mass) + "," + num(a.has_truth, t.mass);
    for (const auto* v : {&p.com, &i.com, &t.com})
      for (int k = 0; k < 3; ++k) row += "," + num(v != &t.com || a.has_truth, (*v)[k]);
    row += "," + num(true, (i.com - p.com).norm()) + "," + num(a.has_truth, (p.com - t.com).norm()) + "," +
           num(a.has_truth, (i.com - t.com).norm());
    std::fprintf(w.file(), "%s\n", row.c_str());
  }
  if (!w.commit(error)) return false;
  bool plotted = false;
  return writePlotScript(out_dir, "plot_wearer.py", kPlotScript, plot, python, "", &plotted, error);
}

}  // namespace exoid::cli
