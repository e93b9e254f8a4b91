#!/usr/bin/python3
"""Figures of `exoid study` from the CSVs it writes (matplotlib; Debian python3-matplotlib).

usage: scripts/plot_study.py STUDY_DIR

Writes into STUDY_DIR:
  metrics_vs_cutoff.png  the five metrics of Table C.1 against the filter cutoff, per method (mean over priors)
  link_error.png         thesis Fig. 6: average estimation error per link (prior +-25 %)
  singular_values.png    spectra of the scaled training problems (first prior), with the chosen z
  fig3_com.png, fig4_torque.png, fig5_momentum.png
                         thesis Figs. 3-5: CoM position, joint torque and CoM momentum predictions of Ref and
                         WLS-RC against the truth on the validation run (series.csv)
"""
import os
import csv
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    d = sys.argv[1]
    c1 = read(f"{d}/table_c1.csv")
    metrics = [("gen_force_rmse", "gen. force RMSE (N & N m)"), ("torque_rmse", "torque RMSE (N m)"),
               ("com_rmse_mm", "CoM RMSE (mm)"), ("momentum_rmse", "CoM momentum RMSE (N s & N m s)"),
               ("estimation_error_pct", "avg. estimation error (%)")]
    groups = sorted({(r["pipeline"], r["range"]) for r in c1})
    fig, axes = plt.subplots(len(groups), len(metrics), figsize=(4 * len(metrics), 3.2 * len(groups)), squeeze=False)
    for gi, (pipe, rng) in enumerate(groups):
        rows = [r for r in c1 if r["pipeline"] == pipe and r["range"] == rng]
        for mi, (key, label) in enumerate(metrics):
            ax = axes[gi][mi]
            for method in dict.fromkeys(r["method"] for r in rows):
                pts = sorted((float(r["cutoff_hz"]), float(r[key])) for r in rows if r["method"] == method)
                xs = [x if x > 0 else 150.0 for x, _ in pts]  # "none" drawn at 150 Hz
                ys = [y if math.isfinite(y) else float("nan") for _, y in pts]
                ax.plot(xs, ys, marker="o", label=method)
            ax.set_yscale("log")
            ax.set_xticks([30, 50, 70, 100, 150], ["30", "50", "70", "100", "none"])
            ax.set_title(f"{pipe}, prior {rng}: {label}", fontsize=8)
            ax.set_xlabel("cutoff (Hz)", fontsize=8)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(f"{d}/metrics_vs_cutoff.png", dpi=110)

    le = read(f"{d}/link_error.csv")
    links = [k for k in le[0].keys() if k not in ("pipeline", "cutoff_hz", "range", "method", "prior")] if le else []
    sel = [r for r in le if r["range"] == "25%"] or le
    if sel:
        # The cutoff where WLS-RC's mean estimation error is lowest, per pipeline (Fig. 6 shows one setting).
        fig, axes = plt.subplots(1, len({r["pipeline"] for r in sel}), figsize=(11, 3.5), squeeze=False)
        for pi, pipe in enumerate(sorted({r["pipeline"] for r in sel})):
            mean = defaultdict(lambda: [0.0] * len(links))
            count = defaultdict(int)
            for r in sel:
                if r["pipeline"] != pipe:
                    continue
                k = (r["method"], r["cutoff_hz"])
                count[k] += 1
                for i, l in enumerate(links):
                    mean[k][i] += float(r[l])
            cut = min((c for (m, c) in count if m == "WLS-RC"),
                      key=lambda c: sum(mean[("WLS-RC", c)]) / count[("WLS-RC", c)], default=None)
            ax = axes[0][pi]
            methods = [m for m in ("Ref", "OLS", "WLS-RC", "WLS-RC-PC") if (m, cut) in count]
            w = 0.8 / max(1, len(methods))
            for j, m in enumerate(methods):
                vals = [v / count[(m, cut)] for v in mean[(m, cut)]]
                ax.bar([i + j * w for i in range(len(links))], vals, width=w, label=m)
            ax.set_yscale("log")
            ax.set_xticks(range(len(links)), [str(i + 1) for i in range(len(links))])
            ax.set_xlabel("link (1 body, 2-6 right leg, 7-11 left leg)")
            ax.set_ylabel("avg. estimation error (%)")
            ax.set_title(f"{pipe} pipeline, prior 25 %, cutoff {cut} Hz (0 = none)", fontsize=9)
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(f"{d}/link_error.png", dpi=110)

    sv = read(f"{d}/singular_values.csv")
    if sv:
        keys = sorted({(r["pipeline"], r["cutoff_hz"]) for r in sv})
        fig, axes = plt.subplots(1, len({k[0] for k in keys}), figsize=(11, 3.8), squeeze=False)
        for pi, pipe in enumerate(sorted({k[0] for k in keys})):
            ax = axes[0][pi]
            for method in ("OLS", "WLS-RC"):
                for cut in sorted({k[1] for k in keys if k[0] == pipe}, key=float):
                    rows = [r for r in sv if r["pipeline"] == pipe and r["cutoff_hz"] == cut and r["method"] == method]
                    if not rows:
                        continue
                    s = [float(r["singular_value"]) for r in rows]
                    s = [x / s[0] for x in s]
                    z = int(rows[0]["z_validation"])
                    line, = ax.semilogy(range(1, len(s) + 1), s, label=f"{method}, cutoff {cut}",
                                        linestyle="-" if method == "WLS-RC" else ":")
                    if 0 < z <= len(s):
                        ax.plot([z], [s[z - 1]], marker="o", color=line.get_color())
            ax.set_xlabel("index")
            ax.set_ylabel("s_i / s_1 (dot: z chosen on validation)")
            ax.set_title(f"{pipe} pipeline: singular values of the scaled problem", fontsize=9)
            ax.legend(fontsize=6)
        fig.tight_layout()
        fig.savefig(f"{d}/singular_values.png", dpi=110)
    series_figures(d)


def series_figures(d):
    path = f"{d}/series.csv"
    if not os.path.exists(path):
        return
    with open(path, newline="") as f:
        title = f.readline().lstrip("# ").strip()
        rows = list(csv.DictReader(f))
    if not rows:
        return
    t = [float(r["t"]) for r in rows]
    style = {"true": ("k", "-", "true"), "ref": ("tab:blue", "--", "Ref."), "rc": ("tab:red", "-", "WLS-RC")}

    def panel(ax, prefix, ylabel):
        for w, (color, ls, label) in style.items():
            ax.plot(t, [float(r[f"{prefix}_{w}"]) for r in rows], color=color, linestyle=ls, linewidth=0.9, label=label)
        ax.set_ylabel(ylabel, fontsize=8)

    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    for ax, c in zip(axes, "xyz"):
        panel(ax, f"com_{c}", f"CoM {c} (m)")
    axes[0].legend(fontsize=7)
    axes[0].set_title(f"Fig. 3 analogue: CoM position prediction ({title})", fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(f"{d}/fig3_com.png", dpi=110)

    joints = [k[len("tau_"):-len("_true")] for k in rows[0] if k.startswith("tau_") and k.endswith("_true")]
    fig, axes = plt.subplots(len(joints), 1, figsize=(10, 1.6 * len(joints)), sharex=True, squeeze=False)
    for ax, j in zip(axes[:, 0], joints):
        panel(ax, f"tau_{j}", f"{j} (N m)")
    axes[0][0].legend(fontsize=7)
    axes[0][0].set_title(f"Fig. 4 analogue: joint torque prediction, external forces known ({title})", fontsize=8)
    axes[-1][0].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(f"{d}/fig4_torque.png", dpi=110)

    fig, axes = plt.subplots(6, 1, figsize=(10, 9), sharex=True)
    for ax, c, u in zip(axes, ["kx", "ky", "kz", "px", "py", "pz"], ["N m s"] * 3 + ["N s"] * 3):
        panel(ax, f"mom_{c}", f"{c} ({u})")
    axes[0].legend(fontsize=7)
    axes[0].set_title(f"Fig. 5 analogue: CoM momentum prediction ({title})", fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(f"{d}/fig5_momentum.png", dpi=110)


if __name__ == "__main__":
    main()
