#!/bin/bash
# The README's main command: installs what is needed, builds, simulates a sequence, runs the
# full system on it offline and prints what it measured.
#   bash scripts/run_main.sh [--scenario tank|field] [--duration S] [--seed N] [--out DIR]
set -eo pipefail
cd "$(dirname "$0")/.."
SCENARIO=tank
DURATION=300
SEED=1
OUT=out/main
while [ $# -gt 0 ]; do
  case "$1" in
    --scenario) SCENARIO="$2"; shift 2 ;;
    --duration) DURATION="$2"; shift 2 ;;
    --seed) SEED="$2"; shift 2 ;;
    --out) OUT="$2"; shift 2 ;;
    -h|--help) sed -n '2,4p' "$0"; exit 0 ;;
    *) echo "run_main.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

bash scripts/setup.sh
bash scripts/build.sh
source scripts/env.sh
BIN="$VIMS_BUILD/devel/lib/vims"
NAME="${SCENARIO}${DURATION}_s${SEED}"
SEQ="$OUT/$NAME"
RESULT="$OUT/${NAME}_result"

echo "== simulating $SCENARIO, ${DURATION} s, seed $SEED -> $SEQ"
"$BIN/vims_sim" --scenario "$SCENARIO" --duration "$DURATION" --seed "$SEED" --out "$SEQ"
echo "== running VIMS offline -> $RESULT"
"$BIN/vims_offline" --sequence "$SEQ" --out "$RESULT"
echo "== sensor front-ends against the simulator's truth"
"$BIN/vims_frontend_eval" sonar --sequence "$SEQ"
"$BIN/vims_frontend_eval" mag --sequence "$SEQ"
echo "== trajectory and loop accuracy"
"$BIN/vims_eval" run --sequence "$SEQ" --out "$RESULT"
