#!/usr/bin/env bash
# Headless lcm-spy screenshot: in a private network namespace (so the multicast traffic cannot reach or
# come from any other process or host), starts Xvfb, scripts/lcm-spy and exoid_lcm_demo_publisher, opens the
# EXO_STATE channel's decoded view (double-click, via xdotool) and saves a PNG of the screen.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

usage() {
  cat <<EOF
usage: scripts/lcm-spy-screenshot.sh [--build-dir DIR] OUT.png

Runs, inside 'unshare -n' (loopback only, multicast routed to lo):
  Xvfb on a free display, scripts/lcm-spy, and DIR/bin/exoid_lcm_demo_publisher (robot_state_t on EXO_STATE
  at 100 Hz); double-clicks the EXO_STATE row so the spy shows the decoded fields; writes OUT.png.
  --build-dir DIR   build folder with bin/exoid_lcm_demo_publisher and share/java/exoid_lcmtypes.jar
                    (default: \$EXOID_BUILD_DIR, else $here/build)
Needs root or unprivileged user namespaces, and the Debian packages
  xvfb x11-apps imagemagick xdotool iproute2 util-linux (plus lcm-spy's own: liblcm-java libjchart2d-java).
EOF
}
die() { echo "lcm-spy-screenshot: $*" >&2; exit 2; }

build_dir="${EXOID_BUILD_DIR:-$here/build}"
out=""
while (($#)); do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --build-dir) (($# >= 2)) || die "--build-dir needs a folder"; build_dir="$2"; shift 2 ;;
    --build-dir=*) build_dir="${1#*=}"; shift ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *) [[ -z "$out" ]] || die "one output file only (got '$out' and '$1')"; out="$1"; shift ;;
  esac
done
[[ -n "$out" ]] || { usage >&2; exit 2; }
[[ "$out" == *.png ]] || die "output '$out' must end in .png"
build_dir="$(cd "$build_dir" 2>/dev/null && pwd)" || die "build folder not found (see --help)"
out_dir="$(cd "$(dirname "$out")" 2>/dev/null && pwd)" || die "folder of '$out' does not exist"
out="$out_dir/$(basename "$out")"

publisher="$build_dir/bin/exoid_lcm_demo_publisher"
[[ -x "$publisher" ]] || die "$publisher not found: build target exoid_lcm_demo_publisher first"
[[ -f "$build_dir/share/java/exoid_lcmtypes.jar" ]] || die "exoid_lcmtypes.jar not built in $build_dir"
missing=()
for tool in Xvfb:xvfb xwd:x11-apps convert:imagemagick xdotool:xdotool ip:iproute2 unshare:util-linux java:default-jdk-headless; do
  command -v "${tool%%:*}" >/dev/null || missing+=("${tool#*:}")
done
((${#missing[@]} == 0)) || die "missing tools; apt-get install ${missing[*]}"

# --- outside: re-run this script in a new network namespace -------------------------------------------
if [[ "${EXOID_SPY_IN_NETNS:-}" != 1 ]]; then
  ns=(unshare -n)
  [[ "$(id -u)" -eq 0 ]] || ns=(unshare -r -n)  # unprivileged: map ourselves to root in a user namespace
  EXOID_SPY_IN_NETNS=1 exec "${ns[@]}" -- bash "${BASH_SOURCE[0]}" --build-dir "$build_dir" "$out"
fi

# --- inside the namespace ------------------------------------------------------------------------------
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo

pids=()
workdir="$(mktemp -d)"
cleanup() {
  local p
  for p in "${pids[@]+"${pids[@]}"}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]+"${pids[@]}"}"; do wait "$p" 2>/dev/null || true; done
  rm -rf "$workdir"
}
trap cleanup EXIT

# Xvfb picks a free display itself and writes its number to the pipe (-displayfd).
mkfifo "$workdir/displayfd"
Xvfb -displayfd 3 -screen 0 1000x780x24 -nolisten tcp 3>"$workdir/displayfd" >"$workdir/xvfb.log" 2>&1 &
pids+=($!)
display=""
read -r -t 15 display <"$workdir/displayfd" || true
[[ -n "$display" ]] || die "Xvfb did not start: $(tail -n 3 "$workdir/xvfb.log")"
export DISPLAY=":$display"
url="udpm://239.255.76.67:7667?ttl=0"
export LCM_DEFAULT_URL="$url"

"$here/scripts/lcm-spy" --build-dir "$build_dir" --lcm-url "$url" >"$workdir/spy.log" 2>&1 &
pids+=($!)
main="$(timeout 30 xdotool search --sync --name '^LCM Spy$' | head -n 1)" ||
  die "lcm-spy window did not appear: $(tail -n 3 "$workdir/spy.log")"
xdotool windowmove "$main" 0 0 windowsize "$main" 1000 110

# Phase 1: the spy discovers EXO_STATE. The viewer is opened while no message arrives (lcm-spy 1.3.1 counts
# a message that lands while its viewer is being built as undecodable).
"$publisher" --count 100 --rate 100 >"$workdir/pub1.log" 2>&1 || die "publisher failed: $(cat "$workdir/pub1.log")"
sleep 0.5
xdotool mousemove --window "$main" 80 27 click --repeat 2 --delay 100 1
viewer="$(timeout 10 xdotool search --sync --name '^EXO_STATE$' | head -n 1)" ||
  die "double-click did not open the EXO_STATE viewer (is EXO_STATE listed? $(tail -n 3 "$workdir/spy.log"))"
xdotool windowmove "$viewer" 0 115 windowsize "$viewer" 1000 665
sleep 0.5

# Phase 2: live data; the screenshot is taken mid-stream so rates and sparklines are filled in.
"$publisher" --count 400 --rate 100 --start-tick 100 >"$workdir/pub2.log" 2>&1 &
pids+=($!)
sleep 3
xwd -root -display "$DISPLAY" | convert xwd:- -strip "$out"
grep -q "Found [1-9][0-9]* LCM types" "$workdir/spy.log" || echo "lcm-spy-screenshot: warning: spy found no LCM types" >&2
echo "lcm-spy-screenshot: wrote $out ($(stat -c %s "$out") bytes)"
