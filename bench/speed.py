#!/usr/bin/python3
"""Speed of the whole pipeline on one sequence (issue 19): real-time factor, CPU per second of
sequence, CPU per stage, peak RSS, on two cores and (--one-core) on one, for one or more variants
side by side, with the accuracy of each variant next to its speed.

    bench/speed.py --sequence SEQ --work DIR [--runs 3] [--one-core] [--build _build]
                   [--variant NAME[@BUILD][=CONFIG[,CONFIG...]]]...

A variant is a build folder and vims_offline configuration files: `--variant default` (this
build, built-in defaults), `--variant embedded=config/embedded.yaml`, `--variant old@/tmp/old_build`
(another commit's build, to compare two commits). Without --variant: `default`. The runs
alternate between the variants (run 1 of each, then run 2 of each, ...), so a machine that slows
down or speeds up during the benchmark moves every variant alike; each figure is the median over
the runs, with the minimum and maximum of the real-time factor, and the ratio of the medians to
the first variant's. --one-core repeats every run under `taskset -c 0` (the embedded budget: one
core does the tracker, the estimator and the pose graph). The accuracy (vims_eval run: VIO and
global SE(3) ATE, loops) is taken once per variant: the outputs do not depend on the run or the
cores (docs/offline_outputs.md). Writes WORK/speed.md and WORK/speed.csv.

CPU per stage: `frontend` (the tracker's thread) and `backend` (the estimator's calls) from
summary.yaml's `vio_cpu_s`, `rest` the process's CPU time (the kernel's, user + system) minus both:
the pose graph's description, loop detection and solves, the magnetometer front end, reading the
bag. Peak RSS is the kernel's too. Quiet machine wanted: another job on
the CPU lowers the real-time factor but not the CPU seconds.
"""
import argparse
import csv
import os
import statistics
import subprocess
import sys

import yaml

from bench_common import ROOT, eval_run, prepare_work_dir, publish_table, tool_dir


def parse_variant(text, default_build):
    """NAME[@BUILD][=CONFIG[,CONFIG...]] -> (name, build folder, [config paths])."""
    head, _, configs = text.partition("=")
    name, _, build = head.partition("@")
    if not name:
        sys.exit(f"speed.py: --variant '{text}' has no name")
    paths = [os.path.abspath(c) for c in configs.split(",") if c]
    for p in paths:
        if not os.path.isfile(p):
            sys.exit(f"speed.py: --variant {name}: no configuration file '{p}'")
    return name, os.path.abspath(build or default_build), paths


def run_once(bin_dir, sequence, configs, out, one_core):
    """One vims_offline run; returns its figures. The process's CPU time and peak RSS come from the
    kernel's accounting of the child (os.wait4), so builds of older commits, whose summary.yaml
    has fewer keys, compare alike; the rest from summary.yaml."""
    cmd = ([] if not one_core else ["taskset", "-c", "0"]) + [
        os.path.join(bin_dir, "vims_offline"), "--quiet", "--sequence", sequence, "--out", out]
    for c in configs:
        cmd += ["--config", c]
    os.makedirs(out, exist_ok=True)
    with open(out + ".log", "w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        sys.exit(f"speed.py: vims_offline failed, see {out}.log")
    with open(os.path.join(out, "summary.yaml")) as f:
        summary = yaml.safe_load(f)
    cpu = usage.ru_utime + usage.ru_stime
    front = summary["vio_cpu_s"]["frontend"]
    back = summary["vio_cpu_s"]["backend"]
    return {"rtf": summary["real_time_factor"], "wall_s": summary["wall_time_s"], "cpu_s": cpu,
            "cpu_per_s": cpu / summary["sequence_duration_s"], "frontend_s": front, "backend_s": back,
            "rest_s": cpu - front - back, "rss_mb": usage.ru_maxrss / 1024.0, "keyframes": summary["vio"]["keyframes"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequence", required=True, help="sequence folder (contract: <name>.bag, <name>.yaml)")
    ap.add_argument("--work", required=True, help="folder for the outputs (not inside the repo)")
    ap.add_argument("--variant", action="append", default=[], help="NAME[@BUILD][=CONFIG[,CONFIG...]]")
    ap.add_argument("--runs", type=int, default=3, help="runs per variant (and per core setting)")
    ap.add_argument("--one-core", action="store_true", help="also run every variant under taskset -c 0")
    ap.add_argument("--build", default=os.path.join(ROOT, "_build"), help="default build folder")
    args = ap.parse_args()
    if args.runs < 1:
        sys.exit("speed.py: --runs must be at least 1")
    work = prepare_work_dir(args.work, "speed.py")
    sequence = os.path.abspath(args.sequence)
    variants = [parse_variant(v, args.build) for v in (args.variant or ["default"])]
    if len({v[0] for v in variants}) != len(variants):
        sys.exit("speed.py: two variants share a name")
    settings = [(name, build, configs, one_core) for name, build, configs in variants
                for one_core in ([False, True] if args.one_core else [False])]

    runs = {(s[0], s[3]): [] for s in settings}
    for i in range(args.runs):
        for name, build, configs, one_core in settings:
            out = os.path.join(work, f"{name}_{'1core' if one_core else '2cores'}_run{i + 1}")
            runs[(name, one_core)].append(run_once(tool_dir(build), sequence, configs, out, one_core))
            print(f"{name} {'1 core' if one_core else '2 cores'} run {i + 1}: "
                  f"real-time factor {runs[(name, one_core)][-1]['rtf']:.2f}", flush=True)
    accuracy = {name: eval_run(tool_dir(build), sequence, os.path.join(work, f"{name}_2cores_run1"))
                for name, build, _ in variants}

    def median(key, name, one_core):
        return statistics.median(r[key] for r in runs[(name, one_core)])

    base = variants[0][0]
    lines = [f"Sequence {os.path.basename(sequence)}, {args.runs} run(s) per row, medians "
             "(real-time factor: median, min-max; ratios: this row's median over the first variant's "
             "on the same cores)", "",
             "| variant | cores | real-time factor | x first | CPU s per s | x first | frontend / backend / rest "
             "CPU [s] | peak RSS [MB] | keyframes | VIO ATE | global ATE | loops correct / wrong |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    rows = []
    for name, _, configs, one_core in settings:
        rtf = [r["rtf"] for r in runs[(name, one_core)]]
        a = accuracy[name]
        row = {"variant": name, "cores": 1 if one_core else 2, "configs": " ".join(configs)}
        for key in ("rtf", "wall_s", "cpu_s", "cpu_per_s", "frontend_s", "backend_s", "rest_s", "rss_mb", "keyframes"):
            row[key] = median(key, name, one_core)
        row["rtf_ratio"] = row["rtf"] / median("rtf", base, one_core)
        row["cpu_ratio"] = row["cpu_per_s"] / median("cpu_per_s", base, one_core)
        row.update({k: a[k] for k in ("vio_m", "vio_pct", "global_m", "global_pct", "loops_correct", "loops_wrong")})
        rows.append(row)
        lines.append(
            f"| {name} | {row['cores']} | {row['rtf']:.1f} ({min(rtf):.1f}-{max(rtf):.1f}) | {row['rtf_ratio']:.2f} | "
            f"{row['cpu_per_s']:.3f} | {row['cpu_ratio']:.2f} | {row['frontend_s']:.1f} / {row['backend_s']:.1f} / "
            f"{row['rest_s']:.1f} | {row['rss_mb']:.0f} | {row['keyframes']:.0f} | {1000 * a['vio_m']:.1f} mm "
            f"({a['vio_pct']:.3f} %) | {1000 * a['global_m']:.1f} mm ({a['global_pct']:.3f} %) | "
            f"{a['loops_correct']} / {a['loops_wrong']} |")
    publish_table(work, "speed", lines)
    with open(os.path.join(work, "speed.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
