#!/bin/bash
# Online equals offline: runs vims_offline and launch/replay.launch (real time, rate 1) on the same
# sequence with the same configuration (config/*.yaml), evaluates both with `vims_eval traj`
# against the ground truth and prints both global (pose graph) ATEs and whether the online one is
# within 10 % of the offline one. See docs/running.md.
#   bash scripts/check_online_offline.sh SEQ_DIR [OUT_DIR] [--mode MODE]
# OUT_DIR (default /tmp/vims_online_offline/<name>) receives offline/, online/ and the logs.
# Exit status: 0 within 10 %, 1 not within 10 % or a run failed, 2 bad usage.
set -eo pipefail
usage() { sed -n '2,8p' "$0"; }
SEQ=""
OUT=""
MODE=full
while [ $# -gt 0 ]; do
  case "$1" in
    --mode) MODE="$2"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "check_online_offline.sh: unknown option '$1'" >&2; usage >&2; exit 2 ;;
    *) if [ -z "$SEQ" ]; then SEQ="$1"; elif [ -z "$OUT" ]; then OUT="$1"; else usage >&2; exit 2; fi; shift ;;
  esac
done
[ -n "$SEQ" ] || { usage >&2; exit 2; }
SEQ="$(cd "$SEQ" && pwd)"
NAME="$(basename "$SEQ")"
for f in "$SEQ/$NAME.bag" "$SEQ/$NAME.yaml" "$SEQ/${NAME}_gt.tum"; do
  [ -f "$f" ] || { echo "check_online_offline.sh: $f is missing" >&2; exit 2; }
done
OUT="${OUT:-/tmp/vims_online_offline/$NAME}"

cd "$(dirname "$0")/.."
source scripts/env.sh
# setup.bash is not `set -u` safe and sets ROS_PACKAGE_PATH (roslaunch finds vims in this tree).
source "$VIMS_BUILD/devel/setup.bash"
BIN="$VIMS_BUILD/devel/lib/vims"
for tool in vims_offline vims_eval vims_estimator_node vims_pose_graph_node vims_sonar_filter_node vims_magnetometer_node; do
  [ -x "$BIN/$tool" ] || { echo "check_online_offline.sh: $BIN/$tool is not built" >&2; exit 2; }
done
rm -rf "$OUT/offline" "$OUT/online"
mkdir -p "$OUT/offline" "$OUT/online"

# The same configuration for both: the files the launch files give the nodes (defaults of
# launch/vims.launch), each holding its module's section of the system configuration.
CONFIG_ARGS=()
for section in sonar magnetometer estimator pose_graph; do CONFIG_ARGS+=(--config "config/$section.yaml"); done

echo "== offline: vims_offline --mode $MODE -> $OUT/offline"
"$BIN/vims_offline" --sequence "$SEQ" --out "$OUT/offline" "${CONFIG_ARGS[@]}" --mode "$MODE" --quiet \
  > "$OUT/offline.log" 2>&1 || { echo "vims_offline failed, see $OUT/offline.log" >&2; exit 1; }

# A private master on a free port, so that nothing else running on this machine interferes.
PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://127.0.0.1:$PORT"
export ROS_HOSTNAME=127.0.0.1
echo "== online: roslaunch vims replay.launch seq:=$SEQ rate:=1 mode:=$MODE (master $ROS_MASTER_URI) -> $OUT/online"
roslaunch --port "$PORT" vims replay.launch seq:="$SEQ" rate:=1 mode:="$MODE" output_dir:="$OUT/online" \
  ground_truth:=false > "$OUT/online.log" 2>&1 &
LAUNCH_PID=$!
cleanup() { kill -INT "$LAUNCH_PID" 2>/dev/null || true; }
trap cleanup EXIT
# The bag plays for its duration (rosbag play exits at its end); then the estimator and the pose
# graph get time to process what is queued before roslaunch stops them (SIGINT), which makes them
# write vio.tum, global.tum and loops.csv.
while kill -0 "$LAUNCH_PID" 2>/dev/null; do
  grep -q '\[player-[0-9]*\] process has finished' "$OUT/online.log" && break
  sleep 2
done
kill -0 "$LAUNCH_PID" 2>/dev/null || { echo "roslaunch ended early, see $OUT/online.log" >&2; exit 1; }
sleep 10
kill -INT "$LAUNCH_PID"
wait "$LAUNCH_PID" || true
trap - EXIT
for f in vio.tum global.tum; do
  [ -s "$OUT/online/$f" ] || { echo "the online run wrote no $f, see $OUT/online.log" >&2; exit 1; }
done

GT="$SEQ/${NAME}_gt.tum"
evaluate() {  # evaluate RUN FILE -> prints the 'VIMS_EVAL ...' line (SE3-aligned ATE first)
  "$BIN/vims_eval" traj --gt "$GT" --est "$OUT/$1/$2" --align se3 --label "$1 $2" > "$OUT/eval_$1_${2%.tum}.txt" 2>&1
  grep '^VIMS_EVAL' "$OUT/eval_$1_${2%.tum}.txt" | tail -1
}
field() { echo "$1" | tr ' ' '\n' | sed -n "s/^$2=//p" | head -1; }
echo "== evaluation (vims_eval traj --align se3; full reports in $OUT/eval_*.txt)"
declare -A ATE
for run in offline online; do
  for f in vio.tum global.tum; do
    line="$(evaluate "$run" "$f")"
    ate="$(field "$line" ate_se3_m)"
    [ -n "$ate" ] || { echo "no ATE for $run/$f: $(cat "$OUT/eval_${run}_${f%.tum}.txt" | tail -3)" >&2; exit 1; }
    ATE["$run/$f"]="$ate"
    printf '  %-8s %-11s ATE %s m  (%s poses)\n' "$run" "$f" "$ate" "$(wc -l < "$OUT/$run/$f")"
  done
done
/usr/bin/python3 - "${ATE[offline/global.tum]}" "${ATE[online/global.tum]}" "${ATE[offline/vio.tum]}" "${ATE[online/vio.tum]}" <<'EOF'
import sys
off_g, on_g, off_v, on_v = map(float, sys.argv[1:5])
rel = abs(on_g - off_g) / off_g if off_g > 0 else float("inf")
ok = rel <= 0.10
print(f"ONLINE_OFFLINE global_ate_offline_m={off_g:.4f} global_ate_online_m={on_g:.4f} "
      f"relative_difference={100 * rel:.1f}% within_10_percent={'yes' if ok else 'no'} "
      f"vio_ate_offline_m={off_v:.4f} vio_ate_online_m={on_v:.4f}")
sys.exit(0 if ok else 1)
EOF
