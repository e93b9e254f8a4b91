#!/usr/bin/env bash
# Issue 20's real-time check: runs the 20-move nominal experiment N times at wall-clock 1 kHz with the estimator
# beside the loop and its estimate fed back, and prints each run's loop timing from its summary.json (docs/sim.md,
# "Loop timing"): overruns (tick work > 1 ms), deadline misses (work ended after its 1 ms slot), the worst tick
# (wall and CPU time), the latest start after a slot began, the loop thread's preemptions and page faults, the
# plugin's call mean / max, fallback ticks (the sim's and the controller's), the load average before each run and the
# machine's floor measured just before it: exoid_loop_jitter, a bare SCHED_FIFO loop placed as the sim is, 10 s
# (slots a 0.25 ms tick would have missed, its latest wake-up): a shared or loaded machine delays even such a loop.
# Usage: bash scripts/bench-realtime.sh [N=3] [OUT_DIR=out/bench-realtime] [exoid experiment options ...]
#   e.g. bash scripts/bench-realtime.sh 3 out/rt-process --controller process
# Writes OUT_DIR/run_I/ (each run's outputs) and OUT_DIR/bench.md (the table printed). Needs a build and root.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
n="${1:-3}"
out="${2:-$here/out/bench-realtime}"
shift 2 || shift $# || true
bin="$here/build/bin"
mkdir -p "$out"
table="$out/bench.md"
{
  echo "| run | load (1 min) | floor: missed slots / latest wake-up ms in 10 s | outcome | overruns | deadline misses | worst tick wall (cpu) ms | mean tick ms | latest start ms | preemptions | page faults | plugin call mean / max us | fallback ticks sim / controller |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} >"$table"
for i in $(seq 1 "$n"); do
  d="$out/run_$i"
  load="$(cut -d' ' -f1 /proc/loadavg)"
  floor="$("$bin/exoid_loop_jitter" 10 250 2>/dev/null | sed -n 's/.*late max \([0-9.]*\) ms.*slots missed \([0-9]*\);.*/\2 \/ \1/p')"
  echo "[$i/$n] load $load, floor (missed slots / latest wake-up ms) ${floor:-?}: $bin/exoid experiment --realtime --estimate-feedback $* -> $d"
  # exit 1 (failed) and 3 (fell) are results to tabulate, not errors of this script
  "$bin/exoid" experiment --scenario "$here/config/scenarios/nominal.yaml" --realtime --estimate-feedback "$@" \
    --out "$d" >"$d.log" 2>&1 || true
  /usr/bin/env python3 - "$d/summary.json" "$i" "$load | ${floor:-?}" >>"$table" <<'PY'
import json, sys
path, run, load = sys.argv[1:4]
try:
    s = json.load(open(path))
except (OSError, ValueError) as e:
    print(f"| {run} | {load} | no summary ({e}) |" + " |" * 9)
    sys.exit(0)
t = s.get("loop_timing") or {}
def g(k, fmt="{}"):
    return fmt.format(t[k]) if k in t else "?"
plugin = (f"{t['plugin_call_us_mean']:.1f} / {t['plugin_call_us_max']:.1f}" if t.get("plugin_calls", 0) > 0
          else f"(process) controller tick max {s.get('tick_us_max', 0):.1f}")
sim_fb = s.get("sim_held_ticks", 0) + s.get("sim_zero_ticks", 0)
print(f"| {run} | {load} | {s['outcome']} | {g('overruns')} | {g('deadline_misses')} | "
      f"{g('tick_ms_max', '{:.3f}')} ({g('tick_cpu_ms_max', '{:.3f}')}) | {g('tick_ms_mean', '{:.3f}')} | "
      f"{g('start_delay_ms_max', '{:.3f}')} | {g('preemptions')} | {g('page_faults')} | {plugin} | "
      f"{sim_fb} / {s.get('controller_fallbacks', '?')} |")
PY
done
cat "$table"
