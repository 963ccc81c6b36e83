#!/usr/bin/python3
"""Rig sweep (issue 20): the same trajectory and world flown with each rig of config/rigs.

For every rig x seed: one simulated sequence (vims_sim --rig config/rigs/RIG.yaml, the tank by
default), then vims_offline (the full system, default options: everything the rig differs in is
read from the sequence YAML) and vims_eval run. Prints one row per run, then per rig the mean
over the seeds against the default rig's, and writes WORK/rig_sweep.md and .csv.

    bench/rig_sweep.py --work /work/data/rigs [--rigs default fisheye tilted_hd rotated low_rate]
                       [--seeds 3 4 5] [--scenario tank] [--duration 300] [--build _build] [--jobs 2]
                       [--config C.yaml]

Sequences and finished runs already in WORK are reused; delete WORK to start afresh after a code
change. Figures: VIO and global translation ATE (SE3) in mm and % of the distance, global rotation
RMSE, loops correct / wrong, the run's real-time factor (summary.yaml; with --jobs 2 the two runs
share the CPU, so it is a lower bound). docs/benchmarks.md, "Rig sweep", holds the measured table.
"""
import argparse
import csv
import glob
import os
import re
import sys
from concurrent.futures import ThreadPoolExecutor

from bench_common import ROOT, eval_run, prepare_work_dir, publish_table, run_logged, tool_dir


def summary_value(out, key):
    """A top-level number of OUT/summary.yaml (nan if absent)."""
    with open(os.path.join(out, "summary.yaml")) as f:
        m = re.search(rf"^{key}: ([0-9.eE+-]+)$", f.read(), re.MULTILINE)
    return float(m.group(1)) if m else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", required=True, help="folder for sequences and outputs (not inside the repo)")
    ap.add_argument("--rigs", nargs="+", help="rig names of config/rigs (default: every file, default first)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 4, 5])
    ap.add_argument("--scenario", default="tank", choices=["tank", "field"])
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--build", default=os.path.join(ROOT, "_build"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--config", help="vims_offline --config file for every run (an A/B against the defaults: "
                    "use another --work, or link the sequences into it)")
    args = ap.parse_args()
    rig_dir = os.path.join(ROOT, "config", "rigs")
    rigs = args.rigs or sorted((os.path.splitext(os.path.basename(p))[0] for p in glob.glob(rig_dir + "/*.yaml")),
                               key=lambda name: (name != "default", name))
    missing = [r for r in rigs if not os.path.exists(os.path.join(rig_dir, r + ".yaml"))]
    if missing:
        sys.exit(f"rig_sweep.py: no rig file config/rigs/{missing[0]}.yaml")
    work = prepare_work_dir(args.work, "rig_sweep.py")
    bin_dir = tool_dir(args.build)
    jobs = [(rig, seed) for rig in rigs for seed in args.seeds]

    def fly(job):
        rig, seed = job
        seq = os.path.join(work, f"{args.scenario}{args.duration:g}_{rig}_s{seed}")
        if not os.path.exists(os.path.join(seq, os.path.basename(seq) + ".bag")):
            cmd = [os.path.join(bin_dir, "vims_sim"), "--scenario", args.scenario, "--duration", str(args.duration),
                   "--seed", str(seed), "--rig", os.path.join(rig_dir, rig + ".yaml"), "--out", seq, "--threads", "1"]
            if run_logged(cmd, seq + "_sim.log") != 0:
                sys.exit(f"rig_sweep.py: vims_sim failed, see {seq}_sim.log")
        out = seq + "_out"
        # A finished run of an earlier call (its summary is written last) is reused.
        if not os.path.exists(os.path.join(out, "summary.yaml")):
            cmd = [os.path.join(bin_dir, "vims_offline"), "--sequence", seq, "--out", out, "--quiet"]
            if args.config:
                cmd += ["--config", os.path.abspath(args.config)]
            if run_logged(cmd, out + ".log") != 0:
                sys.exit(f"rig_sweep.py: vims_offline failed, see {out}.log")
        figures = eval_run(bin_dir, seq, out)
        return {"rig": rig, "seed": seed, "real_time_factor": summary_value(out, "real_time_factor"), **figures}

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(fly, jobs))

    keys = ["rig", "seed", "distance_m", "vio_m", "vio_pct", "vio_height_m", "global_m", "global_pct",
            "global_rot_deg", "global_height_m", "loops_correct", "loops_wrong", "real_time_factor"]
    with open(os.path.join(work, "rig_sweep.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    mm = lambda r, key: 1000.0 * r[key]
    lines = ["| rig | seed | VIO ATE | global ATE | global rot [deg] | loops correct / wrong | real-time factor |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['rig']} | {r['seed']} | {mm(r, 'vio_m'):.1f} mm ({r['vio_pct']:.3f} %) | "
                     f"{mm(r, 'global_m'):.1f} mm ({r['global_pct']:.3f} %) | {r['global_rot_deg']:.2f} | "
                     f"{r['loops_correct']} / {r['loops_wrong']} | {r['real_time_factor']:.1f} |")
    mean = lambda rig, key: sum(mm(r, key) for r in rows if r["rig"] == rig) / len(args.seeds)
    lines += ["", "| rig | mean VIO ATE | x default | mean global ATE | x default | wrong loops |",
              "| --- | --- | --- | --- | --- | --- |"]
    base = rigs[0]
    for rig in rigs:
        wrong = sum(r["loops_wrong"] for r in rows if r["rig"] == rig)
        lines.append(f"| {rig} | {mean(rig, 'vio_m'):.1f} mm | {mean(rig, 'vio_m') / mean(base, 'vio_m'):.2f} | "
                     f"{mean(rig, 'global_m'):.1f} mm | "
                     f"{mean(rig, 'global_m') / mean(base, 'global_m'):.2f} | {wrong} |")
    publish_table(work, "rig_sweep", lines)


if __name__ == "__main__":
    main()
