#!/usr/bin/env bash
# Configures and builds the checking build in build-sanitize/ (clang, AddressSanitizer + UndefinedBehavior-
# Sanitizer, libFuzzer targets; docs/testing.md). Arguments: targets to build (default: exoid_sanitized, the tests
# marked SANITIZED, cmake/ExoidTest.cmake; the others are not even registered there).
# The main build (scripts/build.sh, build/) stays GCC Release.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/setup-deps.sh"
source "$here/scripts/env.sh"
dir="$here/build-sanitize"
# -O1: sanitizer reports stay readable and the tests fast enough; line tables give file:line in reports.
# No -DNDEBUG: assertions (Eigen's index checks among them) stay on.
CC=clang CXX=clang++ cmake -S "$here" -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DEXOID_SANITIZE=ON -DEXOID_FUZZ=ON -DEXOID_TEST_SET=sanitized -DCMAKE_PREFIX_PATH="$EXOID_CMEEL_PREFIX" >/dev/null
(($#)) || set -- exoid_sanitized
cmake --build "$dir" -j "$(nproc)" --target "$@"
