#!/usr/bin/env bash
# Issue 10's equivalence check over every shipped scenario, with the online estimator running and its estimate
# fed back (issue 20: each estimate applied estimate.lag_ticks after its tick, lockstep waiting for it): runs the
# 20-move experiment of each config/scenarios/*.yaml in the plugin shape and in the process shape (same move
# seed), then tabulates both summaries side by side and whether the two runs are the same run: their
# ground-truth exports (`exoid export --truth`: state, accelerations, applied torques and contact wrenches of
# every tick, printed to 17 significant digits) compared byte for byte. --repeat runs the plugin shape a second
# time and compares that too (the determinism check: the same options give the same run).
# Usage: bash scripts/compare-modes.sh [--repeat] [OUT_DIR] [SCENARIO.yaml ...]   (default out/modes, every scenario)
# Writes OUT_DIR/modes.csv and OUT_DIR/modes.md. Needs a build (bash scripts/build.sh) and root (netns).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
repeat=0
if [ "${1:-}" = "--repeat" ]; then repeat=1; shift; fi
out="${1:-$here/out/modes}"
shift || true
scenarios=("$@")
[ ${#scenarios[@]} -gt 0 ] || scenarios=("$here"/config/scenarios/*.yaml)
bin="$here/build/bin"
mkdir -p "$out"
n=${#scenarios[@]}
i=0
for s in "${scenarios[@]}"; do
  i=$((i + 1))
  name="$(basename "$s" .yaml)"
  runs="plugin process"
  [ "$repeat" = 1 ] && runs="plugin process plugin_again"
  for run in $runs; do
    mode="${run%_again}"
    d="$out/$name/$run"
    mkdir -p "$out/$name"
    echo "[$i/$n] $name ($run)"
    # exit 3 (fell) and 1 (failed) are results to tabulate, not errors of this script
    "$bin/exoid" experiment --scenario "$s" --controller "$mode" --estimate-feedback --out "$d" >"$d.log" 2>&1 || true
    if [ -f "$d/run.lcmlog" ]; then
      "$bin/exoid" export --truth --allow-partial --log "$d/run.lcmlog" --out "$d/truth.csv" >/dev/null 2>&1 || true
    fi
  done
done
python3 - "$out" "$repeat" "${scenarios[@]}" <<'PY'
import csv, filecmp, json, os, sys
out = sys.argv[1]
repeat = sys.argv[2] == "1"
rows = []
for s in sys.argv[3:]:
    name = os.path.splitext(os.path.basename(s))[0]
    r = {"scenario": name}
    for mode in ("plugin", "process"):
        p = os.path.join(out, name, mode, "summary.json")
        j = json.load(open(p)) if os.path.exists(p) else {}
        r[mode] = j
    a, b = (os.path.join(out, name, m, "truth.csv") for m in ("plugin", "process"))
    r["same_run"] = os.path.exists(a) and os.path.exists(b) and filecmp.cmp(a, b, shallow=False)
    if repeat:
        c = os.path.join(out, name, "plugin_again", "truth.csv")
        r["same_again"] = os.path.exists(a) and os.path.exists(c) and filecmp.cmp(a, c, shallow=False)
        r["same_run"] = r["same_run"] and r["same_again"]
    rows.append(r)
cols = [("outcome", "{}"), ("moves_done", "{}"), ("com_rmse_m", "{:.6g}"), ("true_com_rmse_m", "{:.6g}"),
        ("max_foot_slip_m", "{:.3g}"), ("controller_fallbacks", "{}"), ("realtime_factor", "{:.2f}")]
with open(os.path.join(out, "modes.csv"), "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["scenario"] + [f"{m}_{c}" for c, _ in cols for m in ("plugin", "process")] + ["same_run"])
    for r in rows:
        w.writerow([r["scenario"]] + [r[m].get(c, "") for c, _ in cols for m in ("plugin", "process")] + [r["same_run"]])
def fmt(j, c, f):
    v = j.get(c)
    return "-" if v is None else f.format(v)
with open(os.path.join(out, "modes.md"), "w") as f:
    f.write("| scenario | outcome plugin / process | CoM RMSE at true state mm | true-CoM RMSE mm | slip mm | "
            "fallbacks | realtime factor plugin / process | same run (truth bit for bit" +
            (": plugin = process = plugin again" if repeat else "") + ") |\n")
    f.write("|---|---|---|---|---|---|---|---|\n")
    for r in rows:
        p, q = r["plugin"], r["process"]
        mm = lambda j, c: "-" if c not in j else f"{1e3 * j[c]:.3f}"
        f.write(f"| {r['scenario']} | {fmt(p,'outcome','{}')} / {fmt(q,'outcome','{}')} | "
                f"{mm(p,'com_rmse_m')} / {mm(q,'com_rmse_m')} | {mm(p,'true_com_rmse_m')} / {mm(q,'true_com_rmse_m')} | "
                f"{mm(p,'max_foot_slip_m')} / {mm(q,'max_foot_slip_m')} | "
                f"{fmt(p,'controller_fallbacks','{}')} / {fmt(q,'controller_fallbacks','{}')} | "
                f"{fmt(p,'realtime_factor','{:.2f}')} / {fmt(q,'realtime_factor','{:.2f}')} | "
                f"{'yes' if r['same_run'] else 'NO'} |\n")
print(open(os.path.join(out, "modes.md")).read())
same = sum(r["same_run"] for r in rows)
print(f"{same} of {len(rows)} scenarios: the plugin and process runs{' (and the plugin run repeated)' if repeat else ''} "
      "are the same run")
sys.exit(0 if same == len(rows) else 1)
PY
