#!/usr/bin/env python3
"""Balance margin over wearers nobody chose (docs/wearer.md "Balance: unseen wearers").

Runs `exoid experiment --no-estimator` on a base wearer scenario for every person seed (the wearer's variation and
own torque draws), noise seed (the scenario's sensor noise) and reflex amplitude given, with one controller
configuration, and prints per run: fell, fallback ticks, and the hip flexions' ringing (RMS of the tick-to-tick change
of their applied torque after 0.6 s, from `exoid export --truth`; a calm run is about 1 N m, a ringing one 5-35).
Writes OUT/margin.csv and OUT/margin.md (the falls per amplitude).

    python3 scripts/wearer_margin.py --out out/margin --config config/controller.yaml \\
        --persons 100-105 --noises 25 100 --amplitudes 20 40 --moves 3
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def seeds(text):
    """'100-105' or '7' -> list of ints."""
    m = re.fullmatch(r"(\d+)-(\d+)", text)
    if m:
        return list(range(int(m.group(1)), int(m.group(2)) + 1))
    if not text.isdigit():
        raise argparse.ArgumentTypeError(f"expected N or N-M, got '{text}'")
    return [int(text)]


def scenario_text(base, person, noise, amplitude):
    """The base scenario with the noise seed, the wearer's seed and the reflex amplitude replaced."""
    out, in_wearer, seen = [], False, set()
    for line in base.splitlines():
        if re.match(r"^seed:", line):
            line = f"seed: {noise}"
            seen.add("noise")
        elif re.match(r"^wearer:", line):
            in_wearer = True
        elif in_wearer and re.match(r"^  seed:", line):
            line = f"  seed: {person}"
            seen.add("person")
        elif in_wearer and re.match(r"^  reflex:", line):
            line = re.sub(r"amplitude: *[0-9.eE+-]+", f"amplitude: {amplitude}", line)
            seen.add("reflex")
        elif line and not line.startswith(" ") and not line.startswith("#"):
            in_wearer = False
        out.append(line)
    missing = {"noise", "person", "reflex"} - seen
    if missing:
        sys.exit(f"wearer_margin: the base scenario lacks a top-level seed:, wearer.seed: or a one-line wearer.reflex: "
                 f"({', '.join(sorted(missing))})")
    return "\n".join(out) + "\n"


def hip_ringing(truth_csv):
    data = np.genfromtxt(truth_csv, delimiter=",", names=True)
    keep = data["t"] > 0.6
    cols = [n for n in data.dtype.names if n.startswith("tau_") and n.endswith("hip_fe")]
    if not keep.any() or not cols:
        return float("nan")
    steps = np.concatenate([np.diff(data[c][keep]) for c in cols])
    return float(np.sqrt(np.mean(steps ** 2)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="output directory (created)")
    ap.add_argument("--config", default=os.path.join(ROOT, "config", "controller.yaml"), help="controller configuration")
    ap.add_argument("--scenario", default=os.path.join(ROOT, "config", "scenarios", "wearer_heavy_sway_reflex.yaml"),
                    help="base wearer scenario (with reflexes)")
    ap.add_argument("--persons", type=seeds, default=seeds("100-105"), help="wearer seeds, N or N-M")
    ap.add_argument("--noises", type=int, nargs="+", default=[25, 100], help="sensor noise seeds")
    ap.add_argument("--amplitudes", type=float, nargs="+", default=[20.0, 40.0], help="reflex amplitudes, N m")
    ap.add_argument("--moves", type=int, default=3, help="CoM moves per run")
    ap.add_argument("--exoid", default=os.path.join(ROOT, "build", "bin", "exoid"), help="the exoid binary")
    a = ap.parse_args()
    with open(a.scenario) as f:
        base = f.read()
    os.makedirs(a.out, exist_ok=True)
    rows = []
    total = len(a.amplitudes) * len(a.persons) * len(a.noises)
    for amplitude in a.amplitudes:
        for person in a.persons:
            for noise in a.noises:
                name = f"p{person}_n{noise}_a{amplitude:g}"
                run = os.path.join(a.out, name)
                os.makedirs(run, exist_ok=True)
                sc = os.path.join(run, "scenario.yaml")
                with open(sc, "w") as f:
                    f.write(scenario_text(base, person, noise, amplitude))
                subprocess.run([a.exoid, "experiment", "--scenario", sc, "--moves", str(a.moves), "--no-estimator",
                                "--controller-config", a.config, "--out", os.path.join(run, "r")],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                with open(os.path.join(run, "r", "summary.json")) as f:
                    s = json.load(f)
                truth = os.path.join(run, "truth.csv")
                subprocess.run([a.exoid, "export", "--truth", "--log", os.path.join(run, "r", "run.lcmlog"),
                                "--out", truth], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                ring = hip_ringing(truth)
                os.remove(truth)
                os.remove(os.path.join(run, "r", "run.lcmlog"))
                row = {"person": person, "noise": noise, "amplitude_nm": amplitude, "fell": bool(s["fell"]),
                       "fall_time_s": round(s["fall_time_s"], 3) if s["fell"] else "", "moves_done": s["moves_done"],
                       "fallback_ticks": s["controller_fallbacks"], "hip_fe_ringing_nm": round(ring, 3)}
                rows.append(row)
                print(f"[{len(rows)}/{total}] {name}: fell {'yes' if row['fell'] else 'no'}, fallback ticks "
                      f"{row['fallback_ticks']}, hip flexion ringing {ring:.2f} N m", flush=True)
    with open(os.path.join(a.out, "margin.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    lines = [f"controller configuration `{a.config}`, base scenario `{os.path.basename(a.scenario)}`, "
             f"{a.moves} moves, persons {a.persons[0]}-{a.persons[-1]}, noise seeds {' '.join(map(str, a.noises))}", "",
             "| reflex amplitude (N m) | falls | runs with fallback ticks | hip flexion ringing, median / max (N m) |",
             "|---|---|---|---|"]
    for amplitude in a.amplitudes:
        sel = [r for r in rows if r["amplitude_nm"] == amplitude]
        ring = [r["hip_fe_ringing_nm"] for r in sel]
        lines.append(f"| {amplitude:g} | {sum(r['fell'] for r in sel)} / {len(sel)} | "
                     f"{sum(r['fallback_ticks'] > 0 for r in sel)} | {np.median(ring):.2f} / {max(ring):.2f} |")
    with open(os.path.join(a.out, "margin.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
