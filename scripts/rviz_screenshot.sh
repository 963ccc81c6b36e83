#!/bin/bash
# Screenshot of rviz during a replay, without a display: Xvfb, software OpenGL, replay.launch with
# rviz:=true, a screenshot of the whole screen after SECONDS of wall time, then everything stops.
#   bash scripts/rviz_screenshot.sh SEQ_DIR OUT.png [SECONDS (default 60)]
# Needs xvfb and imagemagick (Debian packages; scripts/setup.sh does not install them).
set -eo pipefail
[ $# -ge 2 ] || { sed -n '2,5p' "$0" >&2; exit 2; }
SEQ="$(cd "$1" && pwd)"
OUT="$2"
SECONDS_TO_WAIT="${3:-60}"
cd "$(dirname "$0")/.."
source scripts/env.sh
source "$VIMS_BUILD/devel/setup.bash"
for tool in Xvfb import convert; do
  command -v "$tool" > /dev/null || { echo "rviz_screenshot.sh: $tool is missing (apt-get install xvfb imagemagick)" >&2; exit 2; }
done
LOG_DIR="$(mktemp -d /tmp/vims_rviz_screenshot.XXXXXX)"

# A free X display number and a free port for a private ROS master.
DISPLAY_NUMBER=90
while [ -e "/tmp/.X${DISPLAY_NUMBER}-lock" ]; do DISPLAY_NUMBER=$((DISPLAY_NUMBER + 1)); done
PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://127.0.0.1:$PORT"
export DISPLAY=":$DISPLAY_NUMBER"
export LIBGL_ALWAYS_SOFTWARE=1

Xvfb "$DISPLAY" -screen 0 1400x900x24 -nolisten tcp > "$LOG_DIR/xvfb.log" 2>&1 &
XVFB_PID=$!
roslaunch --port "$PORT" vims replay.launch seq:="$SEQ" rviz:=true > "$LOG_DIR/roslaunch.log" 2>&1 &
LAUNCH_PID=$!
cleanup() {
  kill -INT "$LAUNCH_PID" 2>/dev/null || true
  wait "$LAUNCH_PID" 2>/dev/null || true
  kill "$XVFB_PID" 2>/dev/null || true
}
trap cleanup EXIT
sleep "$SECONDS_TO_WAIT"
kill -0 "$LAUNCH_PID" 2>/dev/null || { echo "roslaunch ended early, see $LOG_DIR/roslaunch.log" >&2; exit 1; }
import -window root "$LOG_DIR/screen.png"
mkdir -p "$(dirname "$OUT")"
# A 256-colour palette keeps the PNG small (rviz shows flat colours and one grey image).
convert "$LOG_DIR/screen.png" -colors 256 "PNG8:$OUT"
echo "screenshot: $OUT ($(du -k "$OUT" | cut -f1) KB); logs in $LOG_DIR"
