#!/usr/bin/env bash
# VIO accuracy and speed over several simulated sequences (issue 4): tank 750 s for seeds 1..5 and
# one field sequence. For each: simulate (unless the sequence exists), run vims_offline
# --vio-only (the same odometry as --mode full, without the pose graph, so the real-time factor
# is the VIO's own), evaluate vio.tum (vims_eval traj, SE(3) and Sim(3) alignment), then print one
# table row: seed, distance, ATE [m] and [% of distance], rotation RMSE [deg], Sim(3) scale,
# real-time factors and the front/back-end latency percentiles of summary.yaml.
#
#   bench/vio_seeds.sh [--work DIR] [--build DIR] [--seeds "1 2 3 4 5"] [--field-duration 600]
#                      [--field-seed 1] [--no-field] [--generate-only] [--jobs N]
#                      [--reuse SEED=DIR]...
#
# Targets (issue 4): tank <= 0.5 % ATE and <= 1 deg rotation RMSE on every seed, no divergence
# (one VIO session); field <= 1 % ATE. Sequences go to WORK/tank750_sN and WORK/field<D>_sN,
# outputs to WORK/out/<name>. --jobs N simulates (and then runs) N sequences at once (default 1;
# the wall-clock figures then include the competition between the runs). The table is
# also written to WORK/vio_seeds.md. Exit status 1 if a run or an evaluation failed.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
work=/work/data/vio/bench
build="$here/_build"
seeds="1 2 3 4 5"
field_duration=600
field_seed=1
with_field=1
generate_only=0
jobs=1
declare -A reuse=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --work) work="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --seeds) seeds="$2"; shift 2 ;;
    --field-duration) field_duration="$2"; shift 2 ;;
    --field-seed) field_seed="$2"; shift 2 ;;
    --no-field) with_field=0; shift ;;
    --generate-only) generate_only=1; shift ;;
    --jobs) jobs="$2"; shift 2 ;;
    --reuse) reuse["${2%%=*}"]="${2#*=}"; shift 2 ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "vio_seeds.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

bin="$build/devel/lib/vims"
for tool in vims_sim vims_offline vims_eval; do
  [[ -x "$bin/$tool" ]] || { echo "vio_seeds.sh: $bin/$tool not built" >&2; exit 2; }
done
mkdir -p "$work/out"

# name|scenario|duration|seed|sequence dir
runs=()
for s in $seeds; do
  dir="${reuse[$s]:-$work/tank750_s$s}"
  runs+=("tank750_s$s|tank|750|$s|$dir")
done
if [[ $with_field == 1 ]]; then
  runs+=("field${field_duration}_s$field_seed|field|$field_duration|$field_seed|$work/field${field_duration}_s$field_seed")
fi

simulate() {  # name scenario duration seed dir
  local name="$1" scenario="$2" duration="$3" seed="$4" dir="$5"
  local base
  base="$(basename "$dir")"
  if [[ -f "$dir/${base}_gt.tum" ]]; then return 0; fi
  echo "[vio_seeds] simulating $name into $dir" >&2
  "$bin/vims_sim" --scenario "$scenario" --duration "$duration" --seed "$seed" --out "$dir" --threads 1 \
    > "$work/out/$name.sim.log" 2>&1
}

pids=()
for r in "${runs[@]}"; do
  IFS='|' read -r name scenario duration seed dir <<< "$r"
  simulate "$name" "$scenario" "$duration" "$seed" "$dir" &
  pids+=($!)
  if (( ${#pids[@]} >= jobs )); then wait "${pids[0]}"; pids=("${pids[@]:1}"); fi
done
for p in "${pids[@]}"; do wait "$p"; done
[[ $generate_only == 1 ]] && exit 0

yaml_get() {  # file key: value of a top-level 'key: value' line
  awk -v k="$1:" '$1 == k {print $2; exit}' "$2"
}
flow_get() {  # file section key: value inside 'section: {key: value, ...}'
  grep "^$2:" "$1" | tr '{},' '\n\n\n' | awk -v k="$3:" '$1 == k {print $2; exit}'
}

run_one() {  # name seed dir: runs, evaluates and writes the table row to WORK/out/NAME.row
  local name="$1" seed="$2" dir="$3"
  local out="$work/out/$name" base s se3 scale
  local row="$out.row"
  echo "[vio_seeds] vims_offline on $name" >&2
  if ! "$bin/vims_offline" --sequence "$dir" --out "$out" --vio-only --quiet > "$out.offline.log" 2>&1; then
    echo "| $name | $seed | vims_offline failed (see $out.offline.log) |" > "$row"; return 1
  fi
  base="$(basename "$dir")"
  if ! "$bin/vims_eval" traj --gt "$dir/${base}_gt.tum" --est "$out/vio.tum" --align all > "$out.eval.log" 2>&1; then
    echo "| $name | $seed | vims_eval failed (see $out.eval.log) |" > "$row"; return 1
  fi
  se3="$(grep '^VIMS_EVAL ' "$out.eval.log" | tail -1)"  # SE(3) figures and the Sim(3) scale
  kv() { tr ' ' '\n' <<< "$1" | awk -F= -v k="$2" '$1 == k {print $2; exit}'; }
  scale="$(kv "$se3" scale)"
  s="$out/summary.yaml"
  printf '| %s | %s | %s | %s | %s | %s | %s | %s | %.1f | %.1f | %.1f | %.1f / %.1f | %.1f / %.1f |\n' \
    "$name" "$seed" "$(kv "$se3" dist_m)" "$(kv "$se3" ate_se3_m)" "$(kv "$se3" ate_se3_pct)" \
    "$(kv "$se3" rot_rmse_deg)" "$scale" "$(flow_get "$s" vio sessions)" \
    "$(yaml_get real_time_factor "$s")" "$(yaml_get vio_real_time_factor "$s")" \
    "$(flow_get "$s" vio_cpu_s real_time_factor)" \
    "$(flow_get "$s" latency_ms frontend_p50)" "$(flow_get "$s" latency_ms frontend_p99)" \
    "$(flow_get "$s" latency_ms backend_p50)" "$(flow_get "$s" latency_ms backend_p99)" > "$row"
}

pids=()
for r in "${runs[@]}"; do
  IFS='|' read -r name scenario duration seed dir <<< "$r"
  rm -f "$work/out/$name.row"
  run_one "$name" "$seed" "$dir" &
  pids+=($!)
  if (( ${#pids[@]} >= jobs )); then wait "${pids[0]}" || true; pids=("${pids[@]:1}"); fi
done
for p in "${pids[@]}"; do wait "$p" || true; done

table="$work/vio_seeds.md"
{
  echo "| sequence | seed | distance m | ATE m | ATE % | rot RMSE deg | Sim3 scale | sessions | VIO RTF (wall) | stages one after another | VIO RTF (CPU) | front p50/p99 ms | back p50/p99 ms |"
  echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
} > "$table"
status=0
for r in "${runs[@]}"; do
  IFS='|' read -r name scenario duration seed dir <<< "$r"
  if [[ -f "$work/out/$name.row" ]]; then cat "$work/out/$name.row" >> "$table"; else status=1; fi
  grep -q failed "$work/out/$name.row" 2>/dev/null && status=1
done
cat "$table"
exit $status
