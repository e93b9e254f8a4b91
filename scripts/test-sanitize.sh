#!/usr/bin/env bash
# Builds build-sanitize/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer on every target, every report
# fatal) and runs the unit tests in it. Excluded: label `system` (multi-process closed-loop runs of minutes,
# whose code the unit tests already cover; docs/testing.md). Arguments are passed to ctest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/build-sanitize.sh"
# Leaks are errors; UBSan prints the stack; third-party leaks we cannot fix are listed in the suppressions.
export ASAN_OPTIONS="detect_leaks=1:strict_init_order=1:check_initialization_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
cd "$here/build-sanitize"
ctest --output-on-failure -j "$(nproc)" -LE '^system$' --timeout 900 "$@"
