#!/usr/bin/env python3
"""Confusion table of `exoid diagnose` over the diagnosis scenarios (docs/diagnose.md).

For every scenario in config/scenarios/diagnose/ (or the ones given): two closed-loop runs of `exoid experiment`
(move seeds 1 and 2, the scenario's own noise seed), `exoid diagnose` trained on the first and validated on the
second (sensors only), and the findings compared with the seeded effects read from the scenario file:

  joint_damping -> viscous, joint_frictionloss -> coulomb, armature -> armature,
  torque_sensor offset != 0 -> offset, gain != 1 -> gain, payload -> payload (a change of the link's inertial
  parameters, which the identified rigid-body model absorbs: no column, so the right answer is no finding).

A seeded effect is "found as K" when K is the kind of the first finding on its joint (none: no finding there);
a finding on a joint without a seeded effect counts in the row "(none)". Writes OUT/confusion.csv,
OUT/confusion.md (the table plus one line per scenario) and OUT/scenarios.csv.

usage: scripts/diagnose_confusion.py [--moves N] [--out DIR] [--bin build/bin] [SCENARIO.yaml ...]
"""
import argparse
import csv
import glob
import json
import os
import subprocess
import sys
import time

import yaml

KINDS = ["viscous", "coulomb", "stribeck", "offset", "armature", "gain", "delay", "payload"]


def seeded(path):
    """[(joint or link, kind, value)] from a scenario file."""
    with open(path) as f:
        sc = yaml.safe_load(f)
    eff = sc.get("effects") or {}
    out = []
    for key, kind in (("joint_damping", "viscous"), ("joint_frictionloss", "coulomb"), ("armature", "armature")):
        for joint, value in (eff.get(key) or {}).items():
            if joint == "all":
                raise SystemExit(f"{path}: 'all' is not a single-joint effect")
            out.append((joint, kind, float(value)))
    for joint, ts in (eff.get("torque_sensor") or {}).items():
        if float(ts.get("offset", 0.0)) != 0.0:
            out.append((joint, "offset", float(ts["offset"])))
        if float(ts.get("gain", 1.0)) != 1.0:
            out.append((joint, "gain", float(ts["gain"]) - 1.0))
    payloads = eff.get("payload") or []
    for p in payloads if isinstance(payloads, list) else [payloads]:
        out.append((p["link"], "payload", float(p["mass"])))
    return out


def run(cmd, log):
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        raise SystemExit(f"failed ({r.returncode}): {' '.join(cmd)} (see {log})")


def main():
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenarios", nargs="*", help="scenario files (default: config/scenarios/diagnose/*.yaml)")
    ap.add_argument("--moves", type=int, default=6, help="CoM moves per run (default 6: 19 s simulated)")
    ap.add_argument("--out", default=os.path.join(here, "out", "diagnose_confusion"), help="output directory")
    ap.add_argument("--bin", default=os.path.join(here, "build", "bin"), help="directory of the exoid binary")
    a = ap.parse_args()
    scenarios = a.scenarios or sorted(glob.glob(os.path.join(here, "config", "scenarios", "diagnose", "*.yaml")))
    if not scenarios:
        raise SystemExit("no scenario files")
    os.makedirs(a.out, exist_ok=True)
    exoid = os.path.join(a.bin, "exoid")
    urdf = os.path.join(here, "config", "exo.urdf")
    confusion = {}  # (seeded kind, found kind) -> count
    rows = []
    for path in scenarios:
        name = os.path.splitext(os.path.basename(path))[0]
        d = os.path.join(a.out, name)
        os.makedirs(d, exist_ok=True)
        effects = seeded(path)
        t0 = time.time()
        for seed in (1, 2):
            run([exoid, "experiment", "--no-estimator", "--scenario", path, "--moves", str(a.moves), "--seed", str(seed),
                 "--out", os.path.join(d, f"run{seed}")], os.path.join(d, f"experiment{seed}.txt"))
        run([exoid, "diagnose", "--model", urdf, "--floating-base", "--train", os.path.join(d, "run1", "run.lcmlog"),
             "--validate", os.path.join(d, "run2", "run.lcmlog"), "--no-plots", "--out", os.path.join(d, "diagnose")],
            os.path.join(d, "diagnose.txt"))
        with open(os.path.join(d, "diagnose", "summary.json")) as f:
            summary = json.load(f)
        findings = summary["findings"]
        first = {}
        for fd in findings:
            first.setdefault(fd["joint"], fd)
        seeded_joints = {j for j, k, v in effects if k != "payload"}
        verdicts = []
        for joint, kind, value in effects:
            found = "none" if kind == "payload" or joint not in first else first[joint]["kind"]
            if kind == "payload":  # no column: any finding on the link's joints would be the payload's shadow
                found = "none"
            confusion[(kind, found)] = confusion.get((kind, found), 0) + 1
            expected = "none" if kind == "payload" else kind
            verdicts.append(f"{joint} {kind} {value:g}: {'ok' if found == expected else 'found ' + found}")
        for fd in findings:
            if fd["joint"] not in seeded_joints:
                confusion[("(none)", fd["kind"])] = confusion.get(("(none)", fd["kind"]), 0) + 1
                verdicts.append(f"false finding: {fd['joint']} {fd['kind']}")
        if not effects and not findings:
            confusion[("(none)", "none")] = confusion.get(("(none)", "none"), 0) + 1
            verdicts.append("clean: no finding")
        rows.append({
            "scenario": name,
            "seeded": "; ".join(f"{j} {k} {v:g}" for j, k, v in effects) or "none",
            "findings": "; ".join(f"{fd['joint']} {fd['kind']} {fd['value']:.3g} ({100 * fd['explained']:.0f} %)"
                                  for fd in findings) or "none",
            "verdict": "; ".join(verdicts),
            "heldout_before": f"{summary['pooled_rmse_before']:.4f}",
            "heldout_after": f"{summary['pooled_rmse_after']:.4f}",
            "seconds": f"{time.time() - t0:.1f}",
        })
        print(f"{name}: {rows[-1]['verdict']} | held-out {rows[-1]['heldout_before']} -> {rows[-1]['heldout_after']} N m",
              flush=True)
    found_kinds = ["none"] + KINDS[:-1]
    seeded_kinds = [k for k in KINDS if any(s == k for s, _ in confusion)] + ["(none)"]
    with open(os.path.join(a.out, "confusion.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["seeded \\ found"] + found_kinds)
        for s in seeded_kinds:
            w.writerow([s] + [confusion.get((s, k), 0) for k in found_kinds])
    with open(os.path.join(a.out, "scenarios.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(a.out, "confusion.md"), "w") as f:
        f.write(f"Seeded effect kind (rows) x kind of the first finding on its joint (columns); {len(rows)} scenarios, "
                f"{a.moves} moves per run, train on move seed 1, validate on move seed 2. Row (none): findings on joints "
                "without a seeded effect (a clean run without any finding counts once in its 'none' column).\n\n")
        f.write("| seeded \\ found | " + " | ".join(found_kinds) + " |\n")
        f.write("|---" * (len(found_kinds) + 1) + "|\n")
        for s in seeded_kinds:
            f.write(f"| {s} | " + " | ".join(str(confusion.get((s, k), 0) or "") for k in found_kinds) + " |\n")
        f.write("\n| scenario | seeded | findings (value, share of its joint's residual) | held-out RMSE before -> after, N m |\n")
        f.write("|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r['scenario']} | {r['seeded']} | {r['findings']} | {r['heldout_before']} -> {r['heldout_after']} |\n")
    print(f"written: {a.out}/confusion.csv, confusion.md, scenarios.csv")


if __name__ == "__main__":
    sys.exit(main())
