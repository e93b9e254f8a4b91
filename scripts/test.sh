#!/usr/bin/env bash
# Runs every test (what CI runs, .ci/run): installs what is missing, then
#   1. builds build/ (GCC, Release) and runs its tests: all but those marked SANITIZED (cmake/ExoidTest.cmake),
#   2. builds build-sanitize/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer) and runs the tests marked
#      SANITIZED there (scripts/test-sanitize.sh): every test runs once,
#   3. runs every libFuzzer target for a bounded time (scripts/fuzz.sh),
# and prints the time each step took. docs/testing.md describes the steps, labels and variables.
# Steps 2 and 3 build in build-sanitize/, which does not depend on step 1: once the dependencies are installed that
# build starts beside step 1's build and ctest at the lowest priority (its output in build-sanitize.log, printed
# after the ctest) and takes the CPU they leave idle: the Release build's serial stretches (it kept 1.6 of 2 cores
# busy) and the serialized system tests (docs/testing.md, "CI time"). Lowest priority means nice 19 for its own
# session's autogroup as well: with the kernel's autogroup scheduling (on by default) a new session's nice value
# counts only inside that session, so `setsid nice -n 19` alone got half the CPU.
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
early=""  # pid of the early sanitizer build
finish() {
  if [ -n "$early" ]; then kill -- "-$early" 2>/dev/null || true; fi
  report
}
trap finish EXIT

# Every test runs once: the Release build leaves out the tests the sanitizer build runs (cmake/ExoidTest.cmake),
# unless step 2 is skipped.
if [ "${EXOID_SANITIZE_TESTS:-1}" != 0 ]; then export EXOID_TEST_SET=unsanitized; else export EXOID_TEST_SET=all; fi
step "dependencies" bash "$here/scripts/setup-deps.sh"
early_targets=()
if [ "${EXOID_SANITIZE_TESTS:-1}" != 0 ]; then early_targets+=(exoid_sanitized); fi
if [ "${EXOID_FUZZ_SECONDS:-10}" != 0 ]; then early_targets+=(exoid_fuzzers); fi
if ((${#early_targets[@]})); then
  # Its own session, so that a failed step 1 can stop the whole build (compilers included) on the way out; that
  # session's autogroup at nice 19 (where the kernel has autogroups and lets us: otherwise nice 19 alone).
  setsid bash -c '{ echo 19 >/proc/self/autogroup; } 2>/dev/null; exec nice -n 19 bash "$@"' _ \
    "$here/scripts/build-sanitize.sh" "${early_targets[@]}" >"$here/build-sanitize.log" 2>&1 &
  early=$!
fi
step "build (GCC, Release)" bash "$here/scripts/build.sh"
step "ctest (build/)" bash -c 'cd "$1/build" && shift && ctest --output-on-failure -j "$(nproc)" "$@"' _ "$here" "$@"
if [ -n "$early" ]; then
  early_wait() {  # the sanitizer build begun beside step 1: its result, its log
    local rc=0
    wait "$early" || rc=$?
    early=""
    cat "$here/build-sanitize.log"
    return "$rc"
  }
  step "sanitizer build (rest of it)" early_wait
fi
if [ "${EXOID_SANITIZE_TESTS:-1}" != 0 ]; then
  step "sanitizer tests" bash "$here/scripts/test-sanitize.sh"
fi
if [ "${EXOID_FUZZ_SECONDS:-10}" != 0 ]; then
  step "fuzzing" bash "$here/scripts/fuzz.sh"
fi
