# Sourced by the build scripts: where the PyPI-installed C++ packages (cmeel prefix) live.
EXOID_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
EXOID_CMEEL_PREFIX="$(ls -d "$EXOID_ROOT"/.deps/venv/lib/python3*/site-packages/cmeel.prefix 2>/dev/null | head -n1)"
export EXOID_ROOT EXOID_CMEEL_PREFIX
