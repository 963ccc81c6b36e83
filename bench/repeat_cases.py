#!/usr/bin/python3
"""Teach and repeat (issue 21): relocalisation in a saved map on the harder repeat missions.

One teach run of the tank (vims_sim --seed TEACH_SEED, its map saved by vims_offline
--map-save), then for every case and trajectory seed a repeat mission over the same world with
the same vehicle (--world-seed and --rig-seed of the teach run) that differs as the case says,
run against the saved map (vims_offline --map-load --map-mode MODE) and measured with
`vims_eval relocalisation`. The cases:

    same         another trajectory seed only (both start on the lap's first waypoint)
    reversed     starts 90 m along the reversed lap: over the map at once, every leg flown the
                 other way (another start and heading)
    beside       starts 55 m along the reversed lap, 1.5-2.4 m beside the teach track (its
                 images share a sliver of the map's), and flies over the map 90 s later
    late         the teach run is 120 s only: the repeat, starting 55 m along the lap, flies
                 outside the mapped area first and enters it later
    higher       1.5 m higher (the images' scale 0.7x)
    murky        turbid water (3x the attenuation) and a lamp at half power
    changed      20 % of the seabed re-laid since the survey
    other_world  another world (seabed and coil): it must never relocalise

    bench/repeat_cases.py --work /work/data/repeat [--cases same reversed ...] [--seeds 4 5 ...]
                          [--duration 300] [--teach-seed 3] [--map-mode localisation] [--build _build]

Sequences, maps and finished runs already in WORK are reused; delete WORK after a code change.
Prints one row per run and writes WORK/repeat_cases.md. docs/benchmarks.md, "Teach and repeat",
holds the measured table and this command.
"""
import argparse
import os
import subprocess
import sys

import yaml

from bench_common import ROOT, prepare_work_dir, tool_dir

# Each case: the repeat's extra vims_sim flags, the teach run's length (None: --duration) and
# whether the repeat flies in the teach run's world.
CASES = {
    "same": ([], None, True),
    "reversed": (["--start-along-lap-m", "90", "--reverse-lap"], None, True),
    "beside": (["--start-along-lap-m", "55", "--reverse-lap"], None, True),
    "late": (["--start-along-lap-m", "55"], 120.0, True),
    "higher": (["--altitude-offset-m", "1.5"], None, True),
    "murky": (["--turbidity", "3", "--lamp-power", "0.5"], None, True),
    "changed": (["--seabed-change", "0.2"], None, True),
    "other_world": ([], None, False),
}
OTHER_WORLD_OFFSET = 1000  # the other world's seed: the teach seed + this


def run(cmd, log):
    with open(log, "w") as f:
        if subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode != 0:
            sys.exit(f"repeat_cases: failed ({log}): {' '.join(cmd)}")


def simulate(bin_dir, seq, flags):
    name = os.path.basename(seq)
    if not os.path.exists(os.path.join(seq, name + "_gt.tum")):
        run([os.path.join(bin_dir, "vims_sim"), "--scenario", "tank", "--out", seq] + flags, seq + ".sim.log")


def teach(bin_dir, work, seed, duration):
    seq = os.path.join(work, f"teach_s{seed}_{int(duration)}")
    out = seq + "_out"
    simulate(bin_dir, seq, ["--duration", str(duration), "--seed", str(seed)])
    if not os.path.exists(os.path.join(out, "map.vimsmap")):
        run([os.path.join(bin_dir, "vims_offline"), "--quiet", "--sequence", seq, "--out", out, "--map-save",
             os.path.join(out, "map.vimsmap")], out + ".log")
    return seq, out


def start_time(seq):
    """The sequence's start on the bag clock [s], from its truth file."""
    with open(os.path.join(seq, os.path.basename(seq) + "_truth.yaml")) as f:
        return float(yaml.safe_load(f)["start_time"])


def summary_value(out, key):
    """A `pose_graph` value of OUT/summary.yaml ("" when absent)."""
    with open(os.path.join(out, "summary.yaml")) as f:
        return str(yaml.safe_load(f).get("pose_graph", {}).get(key, ""))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--work", required=True)
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--seeds", nargs="+", type=int, default=[4])
    parser.add_argument("--duration", type=float, default=300.0)
    parser.add_argument("--teach-seed", type=int, default=3)
    parser.add_argument("--map-mode", default="localisation", choices=["mapping", "extend", "localisation"])
    parser.add_argument("--build", default=os.path.join(ROOT, "_build"))
    args = parser.parse_args()
    work = prepare_work_dir(args.work, "repeat_cases")
    bin_dir = tool_dir(args.build)

    header = ("| case | seed | relocalised, s into the run (after entering the map) | error there | loops into the map "
              "(correct / wrong) | ATE in the map's frame | / teach |")
    rows = [header, "| --- | --- | --- | --- | --- | --- | --- |"]
    print(header, flush=True)
    for case in args.cases:
        flags, teach_duration, same_world = CASES[case]
        teach_seq, teach_out = teach(bin_dir, work, args.teach_seed, teach_duration or args.duration)
        world = args.teach_seed if same_world else args.teach_seed + OTHER_WORLD_OFFSET
        for seed in args.seeds:
            seq = os.path.join(work, f"{case}_s{seed}")
            out = seq + "_out"
            simulate(bin_dir, seq, ["--duration", str(args.duration), "--seed", str(seed), "--world-seed", str(world),
                                    "--rig-seed", str(args.teach_seed)] + flags)
            if not os.path.exists(os.path.join(out, "summary.yaml")):
                run([os.path.join(bin_dir, "vims_offline"), "--quiet", "--sequence", seq, "--out", out, "--map-load",
                     os.path.join(teach_out, "map.vimsmap"), "--map-mode", args.map_mode], out + ".log")
            if same_world:
                proc = subprocess.run([os.path.join(bin_dir, "vims_eval"), "relocalisation", "--teach-sequence",
                                       teach_seq, "--teach-out", teach_out, "--sequence", seq, "--out", out],
                                      capture_output=True, text=True)
                line = next((l for l in proc.stdout.splitlines() if l.startswith("VIMS_EVAL_RELOC ")), None)
                if line is None:
                    sys.exit(f"repeat_cases: vims_eval relocalisation printed no summary:\n{proc.stdout}{proc.stderr}")
                kv = dict(item.split("=", 1) for item in line.split()[1:])
                if kv["relocalised"] == "1":
                    entered = f" ({kv['delay_s']} s)" if kv["entered"] == "1" else " (never entered)"
                    when = f"{float(kv['t_relocalised']) - start_time(seq):.1f} s{entered}"
                    error = f"{kv['error_at_relocalisation_m']} m, {'correct' if kv['correct'] == '1' else 'WRONG'}"
                    ate, ratio = f"{kv['ate_map_rmse_m']} m", f"{kv['ratio']}x"
                else:
                    when, error, ate, ratio = "never", "-", "-", "-"
                loops = f"{kv['map_loops_correct']} / {kv['map_loops_wrong']}"
            else:
                # Another world: there is no right place in the map, so any loop into it is wrong.
                reloc = summary_value(out, "relocalised_t")
                when = "never (correct)" if reloc == "" else f"{reloc} s (WRONG)"
                error, ate, ratio = "-", "-", "-"
                loops = f"0 / {summary_value(out, 'loops_into_map') or '?'}"
            row = f"| {case} | {seed} | {when} | {error} | {loops} | {ate} | {ratio} |"
            rows.append(row)
            print(row, flush=True)
    with open(os.path.join(work, "repeat_cases.md"), "w") as f:
        f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
