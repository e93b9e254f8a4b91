#!/usr/bin/env bash
# Builds build-sanitize/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer on every target, every report
# fatal) and runs the tests marked SANITIZED there (cmake/ExoidTest.cmake; docs/testing.md "Which build runs which
# test"): the readers, messages, model, numerics and real-time code's unit tests. The Java jar check, registered in
# every build, is left to the Release build. Arguments go to ctest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/build-sanitize.sh" exoid_sanitized
# Leaks are errors (except urdfdom's own, fuzz/lsan.supp); UBSan prints the stack.
export LSAN_OPTIONS="suppressions=$here/fuzz/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
export ASAN_OPTIONS="detect_leaks=1:strict_init_order=1:check_initialization_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
cd "$here/build-sanitize"
ctest --output-on-failure -j "$(nproc)" -LE '^system$' -E '^lcmtypes_jar_contains_robot_state$' --timeout 900 "$@"
