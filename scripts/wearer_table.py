#!/usr/bin/env python3
"""Issue 21's table, end to end: per wearer scenario, balance, identification and diagnosis against the truth.

For every scenario given (default: config/scenarios/wearer_*.yaml), with the binaries in --bin:

  balance         `exoid experiment --scenario S --moves 20 --seed K` for each --balance-seeds K (default 3 and 5),
                  once with the estimate fed back (the default) and once with the prior alone (`--no-estimator`).
                  The controller's model is the clinic's: the exoskeleton plus the table wearer at the scenario's
                  mass, height and sex (`exoid experiment` writes it as OUT/wearer_prior.urdf). From summary.json:
                  fell, max_foot_slip_m, true_com_rmse_xy_settled_m (horizontal true-CoM RMSE from 10 s on, in the
                  controller's world). Ratio = prior alone / with the estimate (issue 21 part 2: >= 3).
  total mass      the estimate-fed run of the first balance seed replayed by `exoid_com_trust LOG 1 3 PRIOR moving`
                  (the estimator's library defaults, told that a body moves on the base, as `exoid experiment` runs
                  it): the largest error of the estimate's total mass, once a second from 5 s on, against the
                  truth's (TRUTH's total, below; part 2: within 1 % in 5 s). The table prior is typed at the
                  scenario's mass, which the simulated person weighs, so this is how far the estimate wanders from a
                  right total.
  identification  two --id-moves runs (move seeds 1 and 2) with the estimate fed back; `exoid identify --data run1
                  --validate run2 --validate-pipeline sensors --cutoff 20 --model PRIOR --hold config/exo.urdf
                  --truth-model TRUTH` (TRUTH: `exoid model wearer` at the scenario's mass, height, sex, seed and
                  variation: the simulated person with the trunk rigid). From summary.json: the whole system's CoM
                  RMSE over the held-out run, 3-D and horizontal, of the table prior, the identified model and the
                  true rigid model (the floor a rigid model cannot go below: the trunk's sway); per carrying link the
                  identified and the prior's mass minus the truth's (part 3: 3-D <= 5 mm).
  diagnosis       `exoid diagnose --model config/exo.urdf --floating-base --train BAL1 --validate BAL2` on the two
                  estimate-fed balance runs (20 moves): the first finding per joint, and whether the base rows' stage
                  names an unmeasured body (part 4: the person's passive moments as elastic kinds on the sagittal
                  hips, knees and ankles; the trunk as a body moving on the base).

Writes OUT/wearer_table.csv (one row per scenario, every figure), OUT/wearer_table.md (the table and the targets met)
and OUT/wearer_table.png (the balance ratio and the identified system CoM per scenario); each run's own output under
OUT/<scenario>/. Runs one process at a time (the runs pin their processes to the first CPU); ~2 min per scenario on a
2-core machine. Exit 1 when a command fails (its log named); a fall is a result, not a failure (a balance run's is in
the table; an identification run's leaves that wearer's identification columns n/a).

usage: scripts/wearer_table.py [--out DIR] [--bin build/bin] [--moves 20] [--id-moves 10] [--balance-seeds 3 5]
                               [--reuse] [SCENARIO.yaml ...]
"""
import argparse
import csv
import glob
import json
import os
import re
import subprocess
import sys

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAGITTAL = [f"{side}_{j}" for side in ("right", "left") for j in ("hip_fe", "knee", "ankle_pd")]
ELASTIC = ("elastic", "elastic_exp", "elastic_coupled", "elastic_exp_coupled")
# The carrying links of `exoid identify --hold`'s report, in the table's order.
LINKS = ["body", "right_thigh", "left_thigh", "right_shank", "left_shank", "right_foot", "left_foot"]


def run(cmd, log, ok=(0,)):
    """Runs cmd with its output in log; its exit code (one of ok, else the script stops naming the log)."""
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode not in ok:
        sys.exit(f"wearer_table: failed ({r.returncode}): {' '.join(cmd)} (see {log})")
    return r.returncode


def load_json(path):
    with open(path) as f:
        return json.load(f)


def person(path):
    """The scenario's wearer: mass, height, sex, seed, variation (a scenario without one is refused)."""
    with open(path) as f:
        sc = yaml.safe_load(f)
    w = (sc or {}).get("wearer")
    if not isinstance(w, dict):
        sys.exit(f"wearer_table: {path}: no 'wearer:' section (only wearer scenarios have this table)")
    try:
        return {"mass": float(w["mass_kg"]), "height": float(w["height_m"]), "sex": str(w["sex"]),
                "seed": int(w.get("seed", 1)), "variation": float(w.get("variation", 0.0))}  # the sim's defaults
    except (KeyError, TypeError, ValueError) as e:
        sys.exit(f"wearer_table: {path}: wearer: {e}")


def experiment(a, scenario, out, seed, moves, estimator):
    """One closed-loop run (skipped with --reuse where its summary exists); its summary.json."""
    summary = os.path.join(out, "summary.json")
    if not (a.reuse and os.path.exists(summary)):
        cmd = [a.exoid, "experiment", "--scenario", scenario, "--moves", str(moves), "--seed", str(seed), "--out", out]
        if not estimator:
            cmd.append("--no-estimator")
        os.makedirs(out, exist_ok=True)
        run(cmd, out + ".txt", ok=(0, 3))  # 3: the robot fell, which the table reports
    return load_json(summary)


def urdf_mass(path):
    """The total mass of a URDF's links (kg)."""
    with open(path) as f:
        masses = re.findall(r'<mass\s+value="([^"]+)"', f.read())
    if not masses:
        sys.exit(f"wearer_table: {path}: no <mass value=...>")
    return sum(float(m) for m in masses)


def mass_error_after_5s(a, log, prior, truth_mass, out):
    """The largest |total mass of the online estimate - the truth's| (kg) from 5 s on, from `exoid_com_trust`'s
    per-second lines ("t  12.00 s  model ..." then "mass change +0.003 kg (sigma ...)": the change from the prior)."""
    txt = out + ".txt"
    run([os.path.join(a.bin, "exoid_com_trust"), log, "1", "3", prior, "moving"], txt)
    prior_mass = urdf_mass(prior)
    worst, n, t = 0.0, 0, None
    with open(txt) as f:
        for line in f:
            mt = re.match(r"\s*t\s+([-+0-9.eE]+)\s*s\b", line)
            if mt:
                t = float(mt.group(1))
                continue
            mm = re.search(r"mass change\s+([-+0-9.eE]+)\s*kg", line)
            if mm and t is not None and t >= 5.0:
                worst = max(worst, abs(prior_mass + float(mm.group(1)) - truth_mass))
                n += 1
    if n == 0:
        sys.exit(f"wearer_table: no mass lines from 5 s on in {txt} (exoid_com_trust's output changed?)")
    return worst


def diagnosis(a, d, logs):
    """`exoid diagnose` on the two balance runs: (elastic first findings on the sagittal joints, trunk planes named,
    other first findings in words)."""
    out = os.path.join(d, "diagnose")
    if not (a.reuse and os.path.exists(os.path.join(out, "summary.json"))):
        run([a.exoid, "diagnose", "--model", os.path.join(ROOT, "config", "exo.urdf"), "--floating-base", "--train",
             logs[0], "--validate", logs[1], "--no-plots", "--out", out], out + ".txt")
    s = load_json(os.path.join(out, "summary.json"))
    first = {}
    for fd in s["findings"]:
        first.setdefault(fd["joint"], fd)
    elastic = [j for j in SAGITTAL if j in first and first[j]["kind"] in ELASTIC]
    planes = [p["plane"] for p in s.get("unmeasured_body", {}).get("planes", []) if p.get("found")]
    other = [f"{j} {fd['kind']}" + (f" (or {fd['or']['kind']})" if "or" in fd else "")
             for j, fd in first.items() if not (j in SAGITTAL and fd["kind"] in ELASTIC)]
    return elastic, planes, other


def one_scenario(a, scenario):
    name = os.path.splitext(os.path.basename(scenario))[0]
    p = person(scenario)
    d = os.path.join(a.out, name)
    os.makedirs(d, exist_ok=True)
    print(f"wearer_table: {name}: {p['mass']:g} kg, {p['height']:g} m, {p['sex']}", flush=True)
    row = {"scenario": name, "mass_kg": p["mass"], "height_m": p["height"], "sex": p["sex"]}

    # Part 2: balance, per move seed, with the estimate and with the prior alone.
    fell, slip, ratios, bal_logs = False, 0.0, [], []
    for k in a.balance_seeds:
        res = {}
        for mode, est in (("with", True), ("prior", False)):
            s = experiment(a, scenario, os.path.join(d, f"balance_{k}_{mode}"), k, a.moves, est)
            fell |= bool(s["fell"])
            slip = max(slip, float(s["max_foot_slip_m"]))
            res[mode] = float(s["true_com_rmse_xy_settled_m"])
            row[f"seed{k}_moves_done_{mode}"] = s["moves_done"]
        row[f"seed{k}_prior_alone_mm"] = 1e3 * res["prior"]
        row[f"seed{k}_with_estimate_mm"] = 1e3 * res["with"]
        row[f"seed{k}_ratio"] = res["prior"] / res["with"] if res["with"] > 0 else float("nan")
        ratios.append(row[f"seed{k}_ratio"])
        bal_logs.append(os.path.join(d, f"balance_{k}_with", "run.lcmlog"))
    row["fell"] = fell
    row["max_slip_mm"] = 1e3 * slip
    row["min_ratio"] = min(ratios)

    # The person's truth (trunk rigid) and the clinic's table prior (written by the first run).
    truth = os.path.join(d, "truth.urdf")
    run([a.exoid, "model", "wearer", "--mass", str(p["mass"]), "--height", str(p["height"]), "--sex", p["sex"],
         "--seed", str(p["seed"]), "--variation", str(p["variation"]), "--out", truth], truth + ".txt")
    prior = os.path.join(d, f"balance_{a.balance_seeds[0]}_with", "wearer_prior.urdf")
    if not os.path.exists(prior):
        sys.exit(f"wearer_table: {prior}: `exoid experiment` wrote no table prior")
    row["system_mass_kg"] = urdf_mass(truth)
    row["mass_error_after_5s_kg"] = mass_error_after_5s(a, bal_logs[0], prior, row["system_mass_kg"],
                                                        os.path.join(d, "mass_trust"))

    # Part 3: identification on two shorter runs, the exoskeleton held at its URDF (a run that fell: no figures).
    id_logs, fallen = [], []
    for k in (1, 2):
        s = experiment(a, scenario, os.path.join(d, f"identify_run{k}"), k, a.id_moves, True)
        fallen += [k] if s["fell"] else []
        id_logs.append(os.path.join(d, f"identify_run{k}", "run.lcmlog"))
    row["identify_runs_fell"] = " ".join(map(str, fallen)) or "none"
    for key in ("prior", "identified", "truth_model"):
        row[f"com_{key}_mm"] = row[f"com_{key}_xy_mm"] = float("nan")
    for link in LINKS:
        row[f"{link}_mass_err_kg"] = row[f"{link}_prior_mass_err_kg"] = float("nan")
    if not fallen:
        idout = os.path.join(d, "identify")
        if not (a.reuse and os.path.exists(os.path.join(idout, "summary.json"))):
            run([a.exoid, "identify", "--data", id_logs[0], "--validate", id_logs[1], "--validate-pipeline", "sensors",
                 "--cutoff", "20", "--model", prior, "--hold", os.path.join(ROOT, "config", "exo.urdf"),
                 "--truth-model", truth, "--no-plots", "--out", idout], idout + ".txt")
        s = load_json(os.path.join(idout, "summary.json"))
        c = s.get("system_com")
        if not c:
            sys.exit(f"wearer_table: {idout}/summary.json: no system_com (the validation log has no truth channel?)")
        for key in ("prior", "identified", "truth_model"):
            row[f"com_{key}_mm"] = 1e3 * c[f"{key}_rmse_m"]
            row[f"com_{key}_xy_mm"] = 1e3 * c[f"{key}_rmse_xy_m"]
        for b in s.get("added_bodies", []):
            if b["link"] in LINKS and b.get("truth") is not None:
                row[f"{b['link']}_mass_err_kg"] = b["identified"]["mass_kg"] - b["truth"]["mass_kg"]
                row[f"{b['link']}_prior_mass_err_kg"] = b["prior"]["mass_kg"] - b["truth"]["mass_kg"]

    # Part 4: the diagnosis on the two estimate-fed balance runs.
    elastic, planes, other = diagnosis(a, d, bal_logs)
    row["elastic_joints"] = len(elastic)
    row["trunk_planes"] = " ".join(planes) or "none"
    row["other_findings"] = "; ".join(other) or "none"
    return row


def fmt(v, f="%.2f"):
    return "n/a" if isinstance(v, float) and v != v else f % v


def write_outputs(a, rows):
    keys = list(rows[0].keys())
    for r in rows[1:]:
        keys += [k for k in r if k not in keys]
    with open(os.path.join(a.out, "wearer_table.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    seeds = a.balance_seeds
    with open(os.path.join(a.out, "wearer_table.md"), "w") as f:
        f.write(f"# Issue 21's table ({a.moves}-move balance runs, move seeds {', '.join(map(str, seeds))}; "
                f"identification on {a.id_moves}-move runs, move seeds 1 / 2)\n\n")
        f.write("| wearer | fell / max slip | horizontal true-CoM from 10 s, prior alone / with the estimate, mm "
                f"(seed {' ; seed '.join(map(str, seeds))}) | ratio (>= 3) | total mass, largest error from 5 s on (<= 1 %) | "
                "system CoM over the held-out run, 3-D (horizontal), mm: prior / identified / true rigid model "
                "(<= 5) | mass error identified (prior), kg: " + ", ".join(LINKS) +
                " | diagnosis: elastic first findings of 6 sagittal joints; trunk named; other first findings |\n")
        f.write("|" + "---|" * 8 + "\n")
        for r in rows:
            bal = "; ".join(f"{r[f'seed{k}_prior_alone_mm']:.3f} / **{r[f'seed{k}_with_estimate_mm']:.3f}**"
                            for k in seeds)
            rat = " ; ".join(f"{r[f'seed{k}_ratio']:.2f}x" for k in seeds)
            com = (f"{fmt(r['com_prior_mm'])} ({fmt(r['com_prior_xy_mm'])}) / **{fmt(r['com_identified_mm'])} "
                   f"({fmt(r['com_identified_xy_mm'])})** / {fmt(r['com_truth_model_mm'])} "
                   f"({fmt(r['com_truth_model_xy_mm'])})")
            if r["identify_runs_fell"] != "none":
                com = f"n/a: identification run {r['identify_runs_fell']} fell"
            mass = "; ".join(f"{fmt(r[f'{l}_mass_err_kg'], '%+.2f')} ({fmt(r[f'{l}_prior_mass_err_kg'], '%+.2f')})"
                             for l in LINKS)
            settle = f"{r['mass_error_after_5s_kg']:.3f} kg ({100 * r['mass_error_after_5s_kg'] / r['system_mass_kg']:.2f} %)"
            f.write(f"| {r['scenario']} | {'yes' if r['fell'] else 'no'} / {r['max_slip_mm']:.3f} mm | {bal} | {rat} | "
                    f"{settle} | {com} | {mass} | {r['elastic_joints']}; {r['trunk_planes']}; {r['other_findings']} |\n")
        n = len(rows)
        runs = n * len(seeds)
        met3 = sum(r[f"seed{k}_ratio"] >= 3.0 for r in rows for k in seeds)
        met5 = sum(r["com_identified_mm"] <= 5.0 for r in rows)
        floor5 = sum(r["com_truth_model_mm"] <= 5.0 for r in rows)
        f.write(f"\nTargets: no fall on {sum(not r['fell'] for r in rows)} of {n}; slip <= 1 mm on "
                f"{sum(r['max_slip_mm'] <= 1.0 for r in rows)} of {n}; balance ratio >= 3 on {met3} of {runs} runs; "
                f"total mass within 1 % from 5 s on on {sum(r['mass_error_after_5s_kg'] <= 0.01 * r['system_mass_kg'] for r in rows)} of {n}; "
                f"identified system CoM <= 5 mm (3-D) on {met5} of {n} (the true rigid model: {floor5} of {n}); the "
                f"trunk named on {sum(r['trunk_planes'] != 'none' for r in rows)} of {n}.\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("wearer_table: no matplotlib: no wearer_table.png", file=sys.stderr)
        return
    fig, ax = plt.subplots(1, 2, figsize=(13, 4.5))
    x = range(len(rows))
    names = [r["scenario"].replace("wearer_", "") for r in rows]
    width = 0.8 / len(seeds)
    for i, k in enumerate(seeds):
        ax[0].bar([p + (i - (len(seeds) - 1) / 2) * width for p in x], [r[f"seed{k}_ratio"] for r in rows], width,
                  label=f"move seed {k}")
    ax[0].axhline(3.0, color="k", ls="--", lw=1, label="target 3x")
    ax[0].set_ylabel("prior alone / with the estimate")
    ax[0].set_title("horizontal true-CoM RMSE from 10 s (balance)")
    for i, (key, label) in enumerate([("prior", "table prior"), ("identified", "identified"),
                                      ("truth_model", "true rigid model")]):
        ax[1].bar([p + (i - 1) * 0.27 for p in x], [r[f"com_{key}_mm"] for r in rows], 0.27, label=label)
    ax[1].axhline(5.0, color="k", ls="--", lw=1, label="target 5 mm")
    ax[1].set_ylabel("system CoM RMSE, held-out run, 3-D (mm)")
    ax[1].set_title("identification (--hold the exoskeleton)")
    for axis in ax:
        axis.set_xticks(list(x))
        axis.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
        axis.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "wearer_table.png"), dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenarios", nargs="*", help="wearer scenario files (default: config/scenarios/wearer_*.yaml)")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "wearer_table"), help="output directory")
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"), help="directory of the exoid binaries")
    ap.add_argument("--moves", type=int, default=20, help="CoM moves per balance run (default 20, issue 21 part 2)")
    ap.add_argument("--id-moves", type=int, default=10, help="CoM moves per identification run (default 10)")
    ap.add_argument("--balance-seeds", type=int, nargs="+", default=[3, 5], help="move seeds of the balance runs")
    ap.add_argument("--reuse", action="store_true", help="keep runs already in --out (their summary.json) instead of "
                                                         "recording them again")
    a = ap.parse_args()
    if a.moves < 1 or a.id_moves < 1:
        ap.error("--moves and --id-moves must be at least 1")
    if len(a.balance_seeds) < 2:
        ap.error("--balance-seeds needs two seeds: the diagnosis trains on the first and validates on the second")
    a.exoid = os.path.join(a.bin, "exoid")
    if not os.access(a.exoid, os.X_OK):
        sys.exit(f"wearer_table: {a.exoid}: not found (build first: bash scripts/build.sh)")
    scenarios = a.scenarios or sorted(glob.glob(os.path.join(ROOT, "config", "scenarios", "wearer_*.yaml")))
    if not scenarios:
        sys.exit("wearer_table: no scenario files")
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for i, sc in enumerate(scenarios):
        print(f"wearer_table: [{i + 1}/{len(scenarios)}] {sc}", flush=True)
        rows.append(one_scenario(a, sc))
        write_outputs(a, rows)  # a partial table survives an interrupted run
    print(open(os.path.join(a.out, "wearer_table.md")).read())


if __name__ == "__main__":
    main()
