#!/usr/bin/env bash
# Installs missing dependencies, then configures and builds exoid into build/ (binaries in build/bin/).
#   EXOID_TEST_SET=all|sanitized|unsanitized   which tests build/ builds and registers (cmake/ExoidTest.cmake;
#                                             unset: as configured before, `all` on a first configure)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/setup-deps.sh"
source "$here/scripts/env.sh"
jobs="$(nproc)"
cmake -S "$here" -B "$here/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$EXOID_CMEEL_PREFIX" \
  ${EXOID_TEST_SET:+-DEXOID_TEST_SET="$EXOID_TEST_SET"} >/dev/null
cmake --build "$here/build" -j "$jobs"
