#!/usr/bin/env bash
# Runs every test (what CI runs, .ci/run): installs what is missing, then
#   1. builds build/ (GCC, Release) and runs its tests: all but those marked SANITIZED (cmake/ExoidTest.cmake),
#   2. builds build-sanitize/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer) and runs the tests marked
#      SANITIZED or ALSO_SANITIZED there (scripts/test-sanitize.sh): every test runs at least once,
#   3. runs every libFuzzer target for a bounded time (scripts/fuzz.sh),
# and prints the time each step took. docs/testing.md describes the steps, labels and variables.
#   EXOID_SANITIZE_TESTS=0   skip step 2 (step 1 then builds and runs every test)
#   EXOID_FUZZ_SECONDS=N     seconds per fuzz target in step 3 (default 10; 0 skips step 3)
#   arguments                passed to the ctest of step 1 (e.g. -L model, -R Regressor)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
times=()
step() {  # step NAME COMMAND...: runs it, records its wall time
  local name="$1" start=$SECONDS
  shift
  echo "[test] ---- $name ----"
  "$@"
  times+=("$(printf '%-34s %4d s' "$name" $((SECONDS - start)))")
}
report() {
  echo "[test] ---- time per step ----"
  local t
  for t in "${times[@]}"; do echo "[test] $t"; done
}
trap report EXIT

# Every test runs once: the Release build leaves out the tests the sanitizer build runs (cmake/ExoidTest.cmake),
# unless step 2 is skipped.
if [ "${EXOID_SANITIZE_TESTS:-1}" != 0 ]; then export EXOID_TEST_SET=unsanitized; else export EXOID_TEST_SET=all; fi
step "build (GCC, Release)" bash "$here/scripts/build.sh"
step "ctest (build/)" bash -c 'cd "$1/build" && shift && ctest --output-on-failure -j "$(nproc)" "$@"' _ "$here" "$@"
if [ "${EXOID_SANITIZE_TESTS:-1}" != 0 ]; then
  step "sanitizer build + tests" bash "$here/scripts/test-sanitize.sh"
fi
if [ "${EXOID_FUZZ_SECONDS:-10}" != 0 ]; then
  step "fuzzing" bash "$here/scripts/fuzz.sh"
fi
