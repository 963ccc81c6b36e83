#!/usr/bin/python3
"""Sonar outages over several seeds (issue 6): how much a sonar outage costs against the clean run.

For each seed: simulate a tank sequence without a fault and the same one with the sonar off for
--off (seconds from the start, vims_sim --sonar-off), run vims_offline on the clean sequence and
on the faulty one twice: with the default configuration (features of range-less keyframes held
at the last measured seabed height, docs/factors.md 5b) and visual-inertial only through the
outage (carry_seabed_through_outages: false). Prints one row per seed: the SE(3) ATE of vio.tum
and global.tum of each run [mm] and the ratios to the clean run, and writes WORK/sonar_outage.md.

    bench/sonar_outage.py --work /work/data/faults/outage [--seeds 11 12 13 14 15 16]
                          [--duration 300] [--off 100:130] [--scenario tank|field]
                          [--sim-args "--terrain slope4 --pressure"] [--build _build] [--jobs 2]

--sim-args adds vims_sim options to both sequences of a seed (terrain, pressure sensor, ...); with
a pressure sensor the estimator's pressure factor holds the height through the outage. Sequences
and finished runs already in WORK are reused (delete WORK/out after a code change).

The fault test (test/fault_tolerance, fault_tolerance_sonar: seed 11, 300 s, off 100:130) is the
first row of the default set. The other studies of docs/benchmarks.md, "Fault tolerance": the
stress case --duration 100 --off 30:60 (the outage is 30 % of the run), --duration 750 with the
outage early or late, and a 90 s outage (--seeds 21 22 --duration 180 --off 40:130).
"""
import argparse
import os
import shlex
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

from bench_common import ROOT, EvalError, ate_se3_m, prepare_work_dir, tool_dir

VI_ONLY_CONFIG = "estimator:\n  factors:\n    sonar_depth:\n      carry_seabed_through_outages: false\n"


def run(cmd, log):
    with open(log, "w") as f:
        return subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode


def ate_mm(bin_dir, sequence, estimate):
    try:
        return 1000.0 * ate_se3_m(bin_dir, sequence, estimate)
    except EvalError as e:
        sys.exit(f"sonar_outage.py: vims_eval failed on {estimate}:\n{e}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", required=True, help="folder for sequences and outputs (not inside the repo)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[11, 12, 13, 14, 15, 16])
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--off", default="100:130", help="sonar outage BEGIN:END [s from the start]")
    ap.add_argument("--scenario", default="tank", choices=["tank", "field"])
    ap.add_argument("--sim-args", default="", help="further vims_sim options for both sequences of a seed")
    ap.add_argument("--build", default=os.path.join(ROOT, "_build"))
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()

    bin_dir = tool_dir(args.build)
    work = prepare_work_dir(args.work, "sonar_outage.py")
    # The sequences are reused by later calls with the same folder: they must be of one setting.
    setting_file = os.path.join(work, "setting.txt")
    setting = f"--scenario {args.scenario} --duration {args.duration:g} --off {args.off} {args.sim_args}".strip()
    if os.path.exists(setting_file) and open(setting_file).read().strip() != setting:
        sys.exit(f"sonar_outage.py: {work} holds sequences of another setting ({open(setting_file).read().strip()}); "
                 "use another --work")
    with open(setting_file, "w") as f:
        f.write(setting + "\n")
    vi_only = os.path.join(work, "vi_only.yaml")
    with open(vi_only, "w") as f:
        f.write(VI_ONLY_CONFIG)

    def simulate(seed, faulty):
        name = f"{'off' if faulty else 'clean'}_s{seed}"
        seq = os.path.join(work, name)
        if not os.path.exists(os.path.join(seq, name + ".bag")):
            cmd = [os.path.join(bin_dir, "vims_sim"), "--scenario", args.scenario, "--duration", f"{args.duration:g}",
                   "--seed", str(seed), "--lz4", "--out", seq] + shlex.split(args.sim_args)
            if faulty:
                cmd += ["--sonar-off", args.off]
            if run(cmd, seq + "_sim.log") != 0:
                sys.exit(f"sonar_outage.py: vims_sim failed, see {seq}_sim.log")
        return seq

    def offline(seq, label, config=None):
        out = os.path.join(work, "out", f"{os.path.basename(seq)}_{label}")
        cmd = [os.path.join(bin_dir, "vims_offline"), "--quiet", "--sequence", seq, "--out", out]
        if config:
            cmd += ["--config", config]
        # A finished run of an earlier call (its summary is written last) is reused.
        if not os.path.exists(os.path.join(out, "summary.yaml")) and run(cmd, out + ".log") != 0:
            sys.exit(f"sonar_outage.py: vims_offline failed, see {out}.log")
        return {k: ate_mm(bin_dir, seq, os.path.join(out, k + ".tum")) for k in ("vio", "global")}

    os.makedirs(os.path.join(work, "out"), exist_ok=True)
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        sequences = {(s, f): pool.submit(simulate, s, f) for s in args.seeds for f in (False, True)}
        sequences = {k: v.result() for k, v in sequences.items()}
        jobs = {}
        for s in args.seeds:
            jobs[(s, "clean")] = pool.submit(offline, sequences[(s, False)], "default")
            jobs[(s, "held")] = pool.submit(offline, sequences[(s, True)], "default")
            jobs[(s, "vi")] = pool.submit(offline, sequences[(s, True)], "vi_only", vi_only)
        results = {k: v.result() for k, v in jobs.items()}

    setting = f"{args.scenario} {args.sim_args}".strip()
    lines = [f"Sonar off {args.off} s in {args.duration:g} s {setting} sequences; SE(3) ATE [mm] and ratio to the clean run",
             "",
             "| seed | clean VIO | clean global | held VIO | held global | VI-only VIO | VI-only global |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for s in args.seeds:
        c = results[(s, "clean")]
        cells = [f"{c['vio']:.1f}", f"{c['global']:.1f}"]
        for variant in ("held", "vi"):
            r = results[(s, variant)]
            cells += [f"{r[k]:.1f} ({r[k] / c[k]:.2f}x)" for k in ("vio", "global")]
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(work, "sonar_outage.md"), "w") as f:
        f.write(table + "\n")


if __name__ == "__main__":
    main()
