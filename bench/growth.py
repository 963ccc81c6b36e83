#!/usr/bin/python3
"""Growth benchmark (issue 6): how vims_offline's cost grows with the sequence length.

For each duration D (default 60 300 750 1800 s) it simulates a tank sequence (or reuses one),
runs vims_offline under /usr/bin/time -v and reports against D:
  - wall time and real-time factor, time per camera frame (wall / images),
  - the per-frame latency percentiles of summary.yaml `latency_ms` (front end, back end, and any
    per-stage keys present, e.g. pose-graph optimisation),
  - pose-graph optimisations and accepted loops, and the optimisation time per loop when
    summary.yaml reports an optimisation latency,
  - peak RSS (maximum resident set size of /usr/bin/time -v),
  - the global trajectory's ATE (vims_eval traj, se3) as a sanity check.
Writes growth.csv and growth.md into --work and prints the markdown table.

    bench/growth.py --work /work/data/faults/growth [--durations 60 300 750 1800] [--seed 1]
                    [--reuse 750=/work/data/tank750] [--build _build] [--keep-sequences]

Sequences are simulated with `--lz4` into WORK/tankD (deleted after the run unless
--keep-sequences; a reused sequence is never deleted). Documented in docs/benchmarks_growth.md.
"""
import argparse
import csv
import os
import re
import shutil
import subprocess
import sys
import time

import yaml

from bench_common import ROOT, EvalError, ate_se3_m, prepare_work_dir, publish_table, tool_dir


def run_timed(cmd, log_path):
    """Runs cmd under /usr/bin/time -v; returns (exit code, wall s, peak RSS MB, CPU s = user + system)."""
    start = time.monotonic()
    with open(log_path, "w") as log:
        proc = subprocess.run(["/usr/bin/time", "-v"] + cmd, stdout=log, stderr=subprocess.STDOUT)
    wall = time.monotonic() - start
    rss_mb = float("nan")
    cpu_s = 0.0
    with open(log_path) as log:
        for line in log:
            m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", line)
            if m:
                rss_mb = int(m.group(1)) / 1024.0
            m = re.search(r"(User|System) time \(seconds\): ([0-9.]+)", line)
            if m:
                cpu_s += float(m.group(2))
    return proc.returncode, wall, rss_mb, cpu_s


def flatten(prefix, node, out):
    if isinstance(node, dict):
        for k, v in node.items():
            flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    else:
        out[prefix] = node


def ate_se3(bin_dir, sequence, estimate):
    """The ATE, or nan for a run that wrote no trajectory or one vims_eval cannot evaluate."""
    if not os.path.exists(estimate) or os.path.getsize(estimate) == 0:
        return float("nan")
    try:
        return ate_se3_m(bin_dir, sequence, estimate)
    except EvalError:
        return float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", required=True, help="folder for sequences, outputs and results (not inside the repo)")
    ap.add_argument("--durations", type=float, nargs="+", default=[60, 300, 750, 1800])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--build", default=os.path.join(ROOT, "_build"), help="build folder (devel/lib/vims inside)")
    ap.add_argument("--reuse", action="append", default=[], metavar="D=DIR",
                    help="use the existing sequence DIR for duration D (e.g. 750=/work/data/tank750)")
    ap.add_argument("--keep-sequences", action="store_true")
    args = ap.parse_args()

    bin_dir = tool_dir(args.build)
    work = prepare_work_dir(args.work, "growth.py")
    reuse = {}
    for item in args.reuse:
        d, path = item.split("=", 1)
        reuse[float(d)] = os.path.abspath(path)

    rows = []
    for duration in args.durations:
        label = f"tank{duration:g}"
        sequence = reuse.get(duration, os.path.join(work, label))
        generated = duration not in reuse
        sim_wall = float("nan")
        if generated and not os.path.exists(os.path.join(sequence, label + ".bag")):
            print(f"[growth] simulating {label} ...", flush=True)
            code, sim_wall, _, _ = run_timed([os.path.join(bin_dir, "vims_sim"), "--scenario", "tank", "--duration",
                                           f"{duration:g}", "--seed", str(args.seed), "--lz4", "--out", sequence],
                                          os.path.join(work, label + "_sim.log"))
            if code != 0:
                sys.exit(f"growth.py: vims_sim failed, see {work}/{label}_sim.log")
        out = os.path.join(work, label + "_out")
        shutil.rmtree(out, ignore_errors=True)
        print(f"[growth] vims_offline on {sequence} ...", flush=True)
        code, wall, rss_mb, cpu_s = run_timed([os.path.join(bin_dir, "vims_offline"), "--quiet", "--sequence", sequence,
                                        "--out", out], os.path.join(work, label + "_offline.log"))
        if code != 0:
            sys.exit(f"growth.py: vims_offline failed on {sequence}, see {work}/{label}_offline.log")
        with open(os.path.join(out, "summary.yaml")) as f:
            summary = yaml.safe_load(f)
        flat = {}
        flatten("", summary, flat)
        images = int(summary["messages"]["/cam0/image_raw"]["count"])
        pose_graph = summary.get("pose_graph", {}) or {}
        latency = summary.get("latency_ms", {}) or {}
        row = {
            "duration_s": duration,
            "sequence": sequence,
            "sim_wall_s": round(sim_wall, 1),
            "offline_wall_s": round(float(summary["wall_time_s"]), 1),
            "rtf": round(float(summary["real_time_factor"]), 2),
            "images": images,
            "ms_per_frame": round(1000.0 * float(summary["wall_time_s"]) / max(images, 1), 2),
            # CPU time (user + system, all threads) per frame: unlike wall time, not inflated by
            # other jobs on the machine.
            "cpu_ms_per_frame": round(1000.0 * cpu_s / max(images, 1), 2),
            "peak_rss_mb": round(rss_mb, 1),
            "keyframes": pose_graph.get("keyframes"),
            "optimisations": pose_graph.get("optimisations"),
            "loop_attempts": pose_graph.get("loop_attempts"),
            "loops_accepted": pose_graph.get("loops_accepted"),
            "global_ate_m": round(ate_se3(bin_dir, sequence, os.path.join(out, "global.tum")), 4),
        }
        # Every latency key summary.yaml has (other modules add per-stage keys: read them all).
        for key, value in latency.items():
            row["latency_" + str(key)] = value
        for section in ("stage_total_s", "vio_cpu_s"):
            for key, value in (summary.get(section, {}) or {}).items():
                row[f"{section}_{key}"] = value
        # Optimisation time per loop: the optimisation latency keys, if any are reported.
        opt_keys = [k for k in latency if re.search(r"optim|pose_graph|loop", str(k))]
        row["optimisation_latency_keys"] = " ".join(f"{k}={latency[k]}" for k in opt_keys) or "not reported"
        rows.append(row)
        print(f"[growth] {label}: {row}", flush=True)
        if generated and not args.keep_sequences:
            shutil.rmtree(sequence, ignore_errors=True)

    keys = []
    for row in rows:
        keys += [k for k in row if k not in keys]
    with open(os.path.join(work, "growth.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    cols = ["duration_s", "images", "offline_wall_s", "rtf", "ms_per_frame", "cpu_ms_per_frame", "peak_rss_mb",
            "keyframes",
            "optimisations", "loops_accepted"] + [k for k in keys if k.startswith("latency_")] + ["global_ate_m"]
    lines = ["| " + " | ".join(cols) + " |", "|" + " --- |" * len(cols)]
    for row in rows:
        lines.append("| " + " | ".join(str(row.get(c, "")) for c in cols) + " |")
    publish_table(work, "growth", lines)


if __name__ == "__main__":
    main()
