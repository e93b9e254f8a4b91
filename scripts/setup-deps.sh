#!/usr/bin/env bash
# Installs every dependency exoid needs, idempotently, on Debian 12 (run as root, or with sudo available).
#  - Debian packages (pinned major versions come from Debian 12 "bookworm": MuJoCo 2.2.2, LCM 1.3.1, KDL 1.5.1,
#    urdfdom 3.0.1, Eigen 3.4.0, GoogleTest 1.12.1, Google Benchmark 1.7.1, yaml-cpp 0.7.0, cereal 1.3.2,
#    CLI11 2.1.2, nlohmann/json 3.11.2, Boost 1.74 (headers: Boost.Math); clang 14 with its sanitizer and libFuzzer runtimes for the checking build).
#  - From PyPI, into the project-local virtual environment .deps/venv, only what Debian lacks:
#    proxsuite (ProxQP, the controller's QP solver; ships C++ headers and a CMake config via cmeel).
# Builds find the PyPI package's CMake config through scripts/env.sh (EXOID_CMEEL_PREFIX).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

DEB_PACKAGES=(
  build-essential cmake pkg-config python3 python3-venv libqhull-dev libtinyxml2-dev libconsole-bridge-dev
  libeigen3-dev libmujoco-dev
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev default-jdk-headless libjchart2d-java
  liborocos-kdl-dev libkdl-parser-dev liburdfdom-dev
  libgtest-dev libbenchmark-dev libyaml-cpp-dev libcereal-dev libcli11-dev nlohmann-json3-dev
  iproute2 util-linux xvfb xauth x11-apps imagemagick xdotool
  python3-matplotlib
  libxgboost-dev
  libboost-dev
  clang libclang-rt-14-dev llvm-14
  libegl-dev libegl-mesa0 libgl1-mesa-dri ffmpeg libglfw3-dev
)
PROXSUITE_VERSION=0.8.0

missing=()
for p in "${DEB_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "[setup] installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

venv="$here/.deps/venv"
if [ ! -x "$venv/bin/python" ]; then
  echo "[setup] creating $venv"
  python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import importlib.metadata as m, sys; sys.exit(m.version('proxsuite') != '$PROXSUITE_VERSION')" 2>/dev/null; then
  echo "[setup] installing proxsuite==$PROXSUITE_VERSION from PyPI"
  "$venv/bin/pip" install -q --disable-pip-version-check "proxsuite==$PROXSUITE_VERSION"
fi
echo "[setup] dependencies ready"
