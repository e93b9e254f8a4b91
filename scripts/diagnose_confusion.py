#!/usr/bin/env python3
"""Confusion table of `exoid diagnose` over the diagnosis scenarios (docs/diagnose.md).

For every scenario in config/scenarios/diagnose/ (or the ones given): two closed-loop runs of `exoid experiment`
(move seeds 1 and 2, the scenario's own noise seed) and a calibration run (`exoid calibrate`: the pelvis held in a
harness, the legs swinging; --calibration-seconds 0 leaves it out), `exoid diagnose` trained on the first and the
calibration and validated on the second (balancing data: sensors only), and the findings compared with the seeded
effects read from the scenario file:

  joint_damping -> viscous, joint_frictionloss -> coulomb, armature -> armature,
  torque_sensor offset != 0 -> offset, gain != 1 -> gain, payload -> payload (a change of the link's inertial
  parameters, which the identified rigid-body model absorbs: no column, so the right answer is no finding).

A seeded effect is "found as K" when K is the kind of the first finding on its joint (none: no finding there);
a finding on a joint without a seeded effect counts in the row "(none)". A wearer's trunk is seeded as "moving_body" on
"base" and found when the base rows' stage names an unmeasured body in either plane (summary.json "unmeasured_body").

A finding that the data do not tell from another kind on its joint (summary.json "or", docs/diagnose.md "Selection" step
4) shows as "found K (or K2)"; the summary counts the right findings named with an alternative and the wrong kinds whose
alternative was the seeded kind.

Effect size (issue 9's criterion: "every seeded effect that changes its joint's torque by >= 3x the torque noise is
named"), from the validation run's ground truth:
  - dynamics effects (viscous, dry friction, armature): the RMS over the run of y - K phi_URDF on the effect's
    joint row with every signal from the ground truth and no filter (`exoid_noise_budget LOG 0 RWAQTPF`): the robot
    is the URDF plus the seeded effects, so this is exactly the torque MuJoCo's damping, frictionloss (the sticking
    constraint force included) and armature applied on that joint;
  - offset: |offset| (a constant on the sensor); gain g: |g - 1| x RMS of the applied torque of the joint
    (`exoid export --truth`);
  - payload: the largest joint-row RMS of the same truth residual (reported only: no column, right answer none).
The torque noise is the joint torque sensor's sigma of the scenario's noise (config/sensors.yaml
joint_torque.sigma for `noise: realistic`, 0 for `off`, or the named file's).

Writes OUT/confusion.csv, OUT/confusion.md (the table, the detection rates over all seeded effects and over those
meeting the criterion, one line per effect and per scenario), OUT/effects.csv (one row per seeded effect) and
OUT/scenarios.csv.

usage: scripts/diagnose_confusion.py [--moves N] [--calibration-seconds S] [--out DIR] [--bin build/bin] [SCENARIO.yaml ...]
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

KINDS = ["viscous", "coulomb", "stribeck", "offset", "armature", "gain", "delay", "elastic", "elastic_exp",
         "elastic_coupled", "elastic_exp_coupled", "passive", "moving_body", "payload"]
# Seeded kinds no finding has: a wearer's passive moments (named as PASSIVE_KINDS), a payload (absorbed by the identified
# link). The trunk, a body moving on the base, is found as "moving_body" on "base" by the unmeasured-body stage (summary.json
# "unmeasured_body": one pseudo-finding per plane named, value its resonance in Hz, share the passed signature's gain).
SEEDED_ONLY = ("passive", "payload")
# A wearer's passive joint moments (Riener & Edrich's elastic law, its biarticular coupling, damping) are found as any of
# these kinds.
PASSIVE_KINDS = ("elastic", "elastic_exp", "elastic_coupled", "elastic_exp_coupled", "viscous")


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
    wearer = sc.get("wearer")
    if wearer:
        # The person's passive moments on the sagittal hip, knee and ankle (value: the joint damping, N m s/rad), and the
        # trunk on its unmeasured lumbar joint, a body moving on the base (value: its pitch stiffness, N m/rad).
        if wearer.get("passive_moments", True):
            damping = wearer.get("joint_damping", [1.0, 0.5, 0.3])
            for side in ("left", "right"):
                for joint, d in zip(("hip_fe", "knee", "ankle_pd"), damping):
                    out.append((f"{side}_{joint}", "passive", float(d)))
        out.append(("base", "moving_body", float(wearer["trunk"]["stiffness"][1])))
    return out


def torque_noise(path, here):
    """The joint torque sensor's sigma (N m) of a scenario's noise setting."""
    with open(path) as f:
        noise = yaml.safe_load(f).get("noise", "realistic")
    if noise == "off":
        return 0.0
    sensors = os.path.join(here, "config", "sensors.yaml") if noise == "realistic" else \
        (noise if os.path.isabs(noise) else os.path.join(os.path.dirname(path), noise))
    with open(sensors) as f:
        return float(yaml.safe_load(f)["joint_torque"]["sigma"])


def truth_sizes(bindir, log, d):
    """(joint names, {joint: RMS of y - K phi_URDF from the ground truth}, {joint: RMS applied torque})."""
    csv_path = os.path.join(d, "truth.csv")
    run([os.path.join(bindir, "exoid"), "export", "--log", log, "--truth", "--out", csv_path],
        os.path.join(d, "export_truth.txt"))
    with open(csv_path) as f:
        reader = csv.reader(f)
        header = next(reader)
        joints = [h[2:] for h in header if h.startswith("q_")]  # every joint, in the model's order
        tau_cols = [(i, h[4:]) for i, h in enumerate(header) if h.startswith("tau_")]  # the actuated ones
        ss = {j: 0.0 for _, j in tau_cols}
        n = 0
        for row in reader:
            for i, j in tau_cols:
                ss[j] += float(row[i]) ** 2
            n += 1
    os.remove(csv_path)  # 19 s of 1 kHz rows: not worth keeping
    tau_rms = {j: (ss[j] / max(n, 1)) ** 0.5 for _, j in tau_cols}
    out = subprocess.run([os.path.join(bindir, "exoid_noise_budget"), log, "0", "RWAQTPF"], capture_output=True,
                         text=True)
    if out.returncode != 0:
        raise SystemExit(f"exoid_noise_budget failed on {log}: {out.stderr}")
    values = out.stdout.strip().splitlines()[-1].split()[1:]
    if len(values) != 6 + len(joints):
        raise SystemExit(f"exoid_noise_budget: {len(values)} columns for {len(joints)} joints + 6 base rows")
    residual = {j: float(v) for j, v in zip(joints, values[6:])}
    return joints, residual, tau_rms


def effect_rms(joint, kind, value, residual, tau_rms):
    if kind in ("passive", "moving_body"):
        return float("nan")  # a wearer: the URDF lacks the person, so the truth residual is not the effect's alone
    if kind in ("viscous", "coulomb", "armature"):
        return residual[joint]
    if kind == "offset":
        return abs(value)
    if kind == "gain":
        return abs(value) * tau_rms.get(joint, 0.0)  # no applied torque on an unactuated joint
    return max(residual.values())  # payload: its largest joint-row torque


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
    ap.add_argument("--calibration-seconds", type=float, default=40.0,
                    help="length of the calibration run (`exoid calibrate`: pelvis held, legs swinging) added to the "
                         "training data (default 40; 0: balancing data only, as before stop 10)")
    ap.add_argument("--diagnose-args", default="", metavar="ARGS",
                    help="more options for every `exoid diagnose` call, one string (e.g. \"--base-orientation imu\")")
    ap.add_argument("--reuse", action="store_true",
                    help="keep the runs already in --out (run1, run2, calibration with their run.lcmlog) instead of "
                         "recording them again: the same runs diagnosed another way")
    a = ap.parse_args()
    scenarios = a.scenarios or sorted(glob.glob(os.path.join(here, "config", "scenarios", "diagnose", "*.yaml")))
    if not scenarios:
        raise SystemExit("no scenario files")
    os.makedirs(a.out, exist_ok=True)
    exoid = os.path.join(a.bin, "exoid")
    urdf = os.path.join(here, "config", "exo.urdf")
    confusion = {}  # (seeded kind, found kind) -> count
    rows = []
    effect_rows = []
    false_other = 0  # findings on joints without a seeded effect, in runs that have one
    false_flagged = 0  # of those, named with an alternative on a seeded joint (a coupling's rival, summary.json "or")
    for path in scenarios:
        name = os.path.splitext(os.path.basename(path))[0]
        d = os.path.join(a.out, name)
        os.makedirs(d, exist_ok=True)
        effects = seeded(path)
        t0 = time.time()
        def recorded(sub):
            return a.reuse and os.path.exists(os.path.join(d, sub, "run.lcmlog"))
        for seed in (1, 2):
            if recorded(f"run{seed}"):
                continue
            run([exoid, "experiment", "--no-estimator", "--scenario", path, "--moves", str(a.moves), "--seed", str(seed),
                 "--out", os.path.join(d, f"run{seed}")], os.path.join(d, f"experiment{seed}.txt"))
        calibration = []
        if a.calibration_seconds > 0:
            if not recorded("calibration"):
                run([exoid, "calibrate", "--scenario", path, "--duration", f"{a.calibration_seconds:g}",
                     "--out", os.path.join(d, "calibration")], os.path.join(d, "calibration.txt"))
            calibration = ["--calibration", os.path.join(d, "calibration", "run.lcmlog")]
        run([exoid, "diagnose", "--model", urdf, "--floating-base", "--train", os.path.join(d, "run1", "run.lcmlog")] +
            calibration + ["--validate", os.path.join(d, "run2", "run.lcmlog"), "--no-plots",
                           "--out", os.path.join(d, "diagnose")] + a.diagnose_args.split(),
            os.path.join(d, "diagnose.txt"))
        with open(os.path.join(d, "diagnose", "summary.json")) as f:
            summary = json.load(f)
        sigma = torque_noise(path, here)
        _, residual, tau_rms = truth_sizes(a.bin, os.path.join(d, "run2", "run.lcmlog"), d)
        findings = summary["findings"] + [
            {"joint": "base", "kind": "moving_body", "value": p["frequency_hz"],
             "explained": max(t["gain"] for t in (p["gravity"], p["driven"]) if t["passed"])}
            for p in summary.get("unmeasured_body", {}).get("planes", []) if p["found"]]
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
            expected = "none" if kind == "payload" else found if kind == "passive" and found in PASSIVE_KINDS else kind
            # The finding's alternative: another kind the data do not tell from it (summary.json "or"), named beside it.
            alt_d = first[joint].get("or", {}) if found != "none" else {}
            alt = alt_d.get("kind", "")
            alt_elsewhere = alt != "" and alt_d.get("joint", joint) != joint  # a coupling's rival on its angle's joint
            alt_right = alt != "" and not alt_elsewhere and (alt == kind or (kind == "passive" and alt in PASSIVE_KINDS))
            if alt_elsewhere:
                alt = f"{alt} on {alt_d['joint']}"
            verdicts.append(f"{joint} {kind} {value:g}: {'ok' if found == expected else 'found ' + found}"
                            + (f" (or {alt})" if alt else ""))
            size = effect_rms(joint, kind, value, residual, tau_rms)
            effect_rows.append({"scenario": name, "joint": joint, "kind": kind, "value": f"{value:g}",
                                "effect_rms_nm": f"{size:.4f}", "torque_noise_nm": f"{sigma:g}",
                                "meets_3x_noise": "n/a" if size != size else "yes" if size >= 3.0 * sigma else "no",
                                "found": found, "or": alt,
                                "right": "yes" if found == expected else "no",
                                "alternative_right": "yes" if found != expected and alt_right else "no"})
        for fd in findings:
            if fd["joint"] not in seeded_joints:
                confusion[("(none)", fd["kind"])] = confusion.get(("(none)", fd["kind"]), 0) + 1
                alt_d = fd.get("or", {})
                alt = f" (or {alt_d['kind']} on {alt_d.get('joint', fd['joint'])})" if alt_d else ""
                verdicts.append(f"false finding: {fd['joint']} {fd['kind']}{alt}")
                false_other += 1 if effects else 0
                false_flagged += 1 if effects and alt_d.get("joint", fd["joint"]) in seeded_joints else 0
        if not effects and not findings:
            confusion[("(none)", "none")] = confusion.get(("(none)", "none"), 0) + 1
            verdicts.append("clean: no finding")
        scenario_effects = [e for e in effect_rows if e["scenario"] == name]
        rows.append({
            "scenario": name,
            "seeded": "; ".join(f"{j} {k} {v:g}" for j, k, v in effects) or "none",
            "effect_rms_nm": "; ".join(e["effect_rms_nm"] for e in scenario_effects) or "",
            "meets_3x_noise": "; ".join(e["meets_3x_noise"] for e in scenario_effects) or "",
            "findings": "; ".join(f"{fd['joint']} {fd['kind']} {fd['value']:.3g} ({100 * fd['explained']:.0f} %)"
                                  + (f" or {fd['or']['kind']}" if "or" in fd else "") for fd in findings) or "none",
            "verdict": "; ".join(verdicts),
            "heldout_before": f"{summary['pooled_rmse_before']:.4f}",
            "heldout_after": f"{summary['pooled_rmse_after']:.4f}",
            "seconds": f"{time.time() - t0:.1f}",
        })
        print(f"{name}: {rows[-1]['verdict']} | held-out {rows[-1]['heldout_before']} -> {rows[-1]['heldout_after']} N m",
              flush=True)
    found_kinds = ["none"] + [k for k in KINDS if k not in SEEDED_ONLY]
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
    with open(os.path.join(a.out, "effects.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(effect_rows[0].keys()) if effect_rows else ["scenario"])
        w.writeheader()
        w.writerows(effect_rows)
    # Detection: effects with a column (a payload has none: its right answer is no finding, reported apart).
    cols = [e for e in effect_rows if e["kind"] != "payload"]
    big = [e for e in cols if e["meets_3x_noise"] == "yes"]
    clean = [r for r in rows if r["seeded"] == "none"]
    clean_false = [r for r in clean if r["findings"] != "none"]

    def rate(es):
        ok = sum(e["right"] == "yes" for e in es)
        return f"{ok} of {len(es)}" + (f" ({100.0 * ok / len(es):.0f} %)" if es else "")
    # Findings named with an alternative: right ones (a correct name that the data barely separate from another) and
    # wrong ones whose alternative is the seeded kind (a wrong name the report flags).
    flagged_right = sum(e["right"] == "yes" and e["or"] != "" for e in cols)
    flagged_wrong = sum(e["alternative_right"] == "yes" for e in cols)
    wrong = sum(e["right"] == "no" and e["found"] != "none" for e in cols)
    ambiguity = (f"Named with an alternative kind the data do not separate ('or'): {flagged_right} right findings; "
                 f"{flagged_wrong} of the {wrong} wrong kinds had the seeded kind as their alternative; "
                 f"{false_flagged} of the {false_other} findings on joints without a seeded effect named an "
                 f"alternative on a seeded joint.")
    with open(os.path.join(a.out, "confusion.md"), "w") as f:
        f.write(f"Seeded effect kind (rows) x kind of the first finding on its joint (columns); {len(rows)} scenarios, "
                f"{a.moves} moves per run, train on move seed 1"
                + (f" and a {a.calibration_seconds:g} s calibration run" if a.calibration_seconds > 0 else "")
                + ", validate on move seed 2. Row (none): findings on joints "
                "without a seeded effect (a clean run without any finding counts once in its 'none' column).\n\n")
        f.write("| seeded \\ found | " + " | ".join(found_kinds) + " |\n")
        f.write("|---" * (len(found_kinds) + 1) + "|\n")
        for s in seeded_kinds:
            f.write(f"| {s} | " + " | ".join(str(confusion.get((s, k), 0) or "") for k in found_kinds) + " |\n")
        f.write(f"\nDetection (right joint and kind; payloads excluded): {rate(cols)} of all seeded effects, "
                f"{rate(big)} of those that change their joint's torque by >= 3x the torque noise. "
                f"Findings on clean runs: {len(clean_false)} of {len(clean)}; findings on joints without a seeded "
                f"effect in the other runs: {false_other}. {ambiguity}\n")
        f.write("\n| scenario | seeded effect | effect RMS, N m | >= 3x noise? | found (first finding on its joint) |\n")
        f.write("|---|---|---|---|---|\n")
        for e in effect_rows:
            f.write(f"| {e['scenario']} | {e['joint']} {e['kind']} {e['value']} | {e['effect_rms_nm']} | "
                    + (f"{e['meets_3x_noise']} ({float(e['effect_rms_nm']) / max(float(e['torque_noise_nm']), 1e-12):.1f}x) | "
                       if e['meets_3x_noise'] != "n/a" else "n/a | ") +
                    f"{e['found']}{' or ' + e['or'] if e['or'] else ''}{'' if e['right'] == 'yes' else ' (wrong)'} |\n")
        f.write("\n| scenario | seeded | effect RMS, N m | >= 3x noise? | findings (value, share of its joint's residual) | "
                "held-out RMSE before -> after, N m |\n")
        f.write("|---|---|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r['scenario']} | {r['seeded']} | {r['effect_rms_nm']} | {r['meets_3x_noise']} | {r['findings']} | "
                    f"{r['heldout_before']} -> {r['heldout_after']} |\n")
    print(f"detection: {rate(cols)} of all seeded effects, {rate(big)} of those >= 3x the torque noise; "
          f"clean runs with a finding: {len(clean_false)} of {len(clean)}")
    print(ambiguity)
    print(f"written: {a.out}/confusion.csv, confusion.md, effects.csv, scenarios.csv")


if __name__ == "__main__":
    sys.exit(main())
