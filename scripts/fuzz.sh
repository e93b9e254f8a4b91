#!/usr/bin/env bash
# Builds the libFuzzer targets (build-sanitize/, scripts/build-sanitize.sh), assembles their seed corpora from
# the repository's real files, generated messages/logs and the checked-in regression inputs (fuzz/corpus/),
# runs every target for a bounded time and prints the executions per target. Fails if any target finds a
# crash (the input is kept in build-sanitize/fuzz/crashes/<target>/; docs/testing.md says how to reproduce).
#   EXOID_FUZZ_SECONDS  time per target (default 10; 0 skips fuzzing)
#   EXOID_FUZZ_JOBS     targets run at once (default: number of CPUs)
#   arguments           a subset of targets (names without fuzz_), e.g. `scripts/fuzz.sh urdf lcm_log`
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${EXOID_FUZZ_SECONDS:-10}"
jobs="${EXOID_FUZZ_JOBS:-$(nproc)}"
all=(urdf states_csv sim_config controller_config lcm_decode lcm_log lcm_wire log_samples measured_csv effects_sidecar)
targets=("$@")
((${#targets[@]})) || targets=("${all[@]}")
if [ "$seconds" = 0 ]; then echo "[fuzz] EXOID_FUZZ_SECONDS=0: skipped"; exit 0; fi

bash "$here/scripts/build-sanitize.sh" exoid_fuzzers
build="$here/build-sanitize"
work="$build/fuzz"
rm -rf "$work/seeds" "$work/logs" "$work/crashes"
mkdir -p "$work/seeds" "$work/logs"

# Seeds: generated ones first, then the real files, then the regression inputs of earlier crashes.
"$build/bin/fuzz_make_seeds" "$work/seeds" >/dev/null
seed() { mkdir -p "$work/seeds/$1"; cp "${@:2}" "$work/seeds/$1/"; }
seed urdf "$here/config/exo.urdf" "$here/data/kuka_lwr4/kuka_lwr4.urdf"
seed states_csv "$here/config/exo_true_parameters.csv"
for f in "$here"/data/kuka_lwr4/measurements_*.csv; do  # 1.8 MB each: the header and 30 samples suffice
  head -n 31 "$f" >"$work/seeds/states_csv/$(basename "$f")"
done
cp -r "$work/seeds/lcm_log" "$work/seeds/log_samples"  # the generated log: every channel, three ticks
mkdir -p "$work/seeds/measured_csv"
for f in "$here"/data/kuka_lwr4/measurements_*.csv; do head -n 31 "$f" >"$work/seeds/measured_csv/$(basename "$f")"; done
seed sim_config "$here"/config/scenarios/*.yaml "$here/config/sensors.yaml"
seed controller_config "$here/config/controller.yaml"
for t in "${all[@]}"; do
  mkdir -p "$work/seeds/$t"
  if [ -d "$here/fuzz/corpus/$t" ]; then cp "$here/fuzz/corpus/$t"/* "$work/seeds/$t/" 2>/dev/null || true; fi
done

# Leaks inside urdfdom that exoid cannot free (fuzz/lsan.supp says which and why).
export LSAN_OPTIONS="suppressions=$here/fuzz/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
run() {  # run TARGET: fuzz for $seconds, the growing corpus kept in build-sanitize/fuzz/corpus/TARGET
  local t="$1"
  mkdir -p "$work/corpus/$t" "$work/crashes/$t"
  "$build/bin/fuzz_$t" -max_total_time="$seconds" -print_final_stats=1 -timeout=20 -rss_limit_mb=2048 \
    -artifact_prefix="$work/crashes/$t/" "$work/corpus/$t" "$work/seeds/$t" >"$work/logs/$t.log" 2>&1
}
echo "[fuzz] ${#targets[@]} targets x ${seconds} s, ${jobs} at once (EXOID_FUZZ_SECONDS, EXOID_FUZZ_JOBS)"
declare -A pid
for t in "${targets[@]}"; do
  [ -x "$build/bin/fuzz_$t" ] || { echo "[fuzz] unknown target '$t' (known: ${all[*]})" >&2; exit 2; }
  while (($(jobs -rp | wc -l) >= jobs)); do wait -n || true; done
  run "$t" &
  pid[$t]=$!
done

failed=0
printf '[fuzz] %-24s %12s %9s %8s  %s\n' target executions exec/s corpus result
for t in "${targets[@]}"; do
  status=0
  wait "${pid[$t]}" || status=$?
  log="$work/logs/$t.log"
  execs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n1)"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n1)"
  corpus="$(ls "$work/corpus/$t" | wc -l)"
  if ((status == 0)); then result=ok; else result="CRASH (exit $status)"; failed=1; fi
  printf '[fuzz] %-24s %12s %9s %8s  %s\n' "fuzz_$t" "${execs:-?}" "${rate:-?}" "$corpus" "$result"
done
if ((failed)); then
  for t in "${targets[@]}"; do
    if ls "$work/crashes/$t"/* >/dev/null 2>&1; then
      echo "[fuzz] ---- fuzz_$t: $(ls "$work/crashes/$t"/*) ----"
      grep -v '^#\|^INFO\|^Log event' "$work/logs/$t.log" | tail -n 60
      echo "[fuzz] reproduce: build-sanitize/bin/fuzz_$t $(ls "$work/crashes/$t"/* | head -n1 | sed "s|$here/||")"
    fi
  done
  exit 1
fi
