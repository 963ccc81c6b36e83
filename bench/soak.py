#!/usr/bin/python3
"""Soak benchmark (issue 6): memory of vims_offline over a long (default 1 h) simulated sequence.

Simulates a tank sequence (or reuses one), runs vims_offline on it and samples every --interval
seconds of wall time the process's resident set (VmRSS and VmHWM of /proc/PID/status) and how
far it has read the bag (rchar of /proc/PID/io over the bag size, so each sample is placed on the
sequence clock). Writes WORK/soak.csv (wall_s, bag_fraction, sequence_s, rss_mb, hwm_mb) and
reports RSS per quarter of the sequence, the growth rate of each quarter [MB per 1000 s of
sequence] and whether memory stops growing: the last quarter grows by less than
--plateau-pct percent (default 5) of the RSS at its start.

The map is meant to grow while the vehicle sees new places (or known places at a new altitude),
so the run also saves the map and `vims_eval map-size` gives the submap memory held per
keyframe (WORK/map_growth.csv). Each quarter then also reports the map's memory, the visual
submaps it stored, and RSS minus map: what the process holds besides the map (buffers, the
sliding window, queues, allocator slack), which must stop growing whatever the map does.

    bench/soak.py --work /work/data/faults/soak [--duration 3600] [--seed 1] [--reuse DIR]
                  [--interval 10] [--build _build] [--keep-sequence] [--config FILE] [--analyse-only]

Documented in docs/benchmarks_growth.md.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import time

import yaml

from bench_common import ROOT, prepare_work_dir, tool_dir


def read_status_mb(pid):
    """(VmRSS, VmHWM) in MB, or None when the process is gone."""
    try:
        values = {}
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    key, value = line.split(":", 1)
                    values[key] = int(value.split()[0]) / 1024.0
        return values.get("VmRSS"), values.get("VmHWM")
    except (FileNotFoundError, ProcessLookupError):
        return None


def read_rchar(pid):
    try:
        with open(f"/proc/{pid}/io") as f:
            for line in f:
                if line.startswith("rchar:"):
                    return int(line.split()[1])
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        pass
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", required=True, help="folder for the sequence, the output and soak.csv (not in the repo)")
    ap.add_argument("--duration", type=float, default=3600.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--reuse", help="an existing sequence directory instead of simulating one")
    ap.add_argument("--interval", type=float, default=10.0, help="sampling period [s of wall time]")
    ap.add_argument("--plateau-pct", type=float, default=5.0)
    ap.add_argument("--build", default=os.path.join(ROOT, "_build"))
    ap.add_argument("--keep-sequence", action="store_true")
    ap.add_argument("--config", help="passed to vims_offline --config (e.g. pose-graph options to compare)")
    ap.add_argument("--analyse-only", action="store_true",
                    help="report from an earlier run's WORK/soak.csv, WORK/out/summary.yaml and map (no new run)")
    args = ap.parse_args()

    bin_dir = tool_dir(args.build)
    work = prepare_work_dir(args.work, "soak.py")
    label = f"tank{args.duration:g}"
    sequence = os.path.abspath(args.reuse) if args.reuse else os.path.join(work, label)
    name = os.path.basename(os.path.normpath(sequence))
    bag = os.path.join(sequence, name + ".bag")
    if not args.reuse and not os.path.exists(bag):
        print(f"[soak] simulating {label} ...", flush=True)
        with open(os.path.join(work, "sim.log"), "w") as log:
            code = subprocess.call([os.path.join(bin_dir, "vims_sim"), "--scenario", "tank", "--duration",
                                    f"{args.duration:g}", "--seed", str(args.seed), "--lz4", "--out", sequence],
                                   stdout=log, stderr=subprocess.STDOUT)
        if code != 0:
            sys.exit(f"soak.py: vims_sim failed, see {work}/sim.log")
    bag_bytes = os.path.getsize(bag)
    with open(os.path.join(sequence, name + "_truth.yaml")) as f:
        truth = yaml.safe_load(f)
    duration = float(truth["duration"])
    start_time = float(truth.get("start_time", 0.0))

    out = os.path.join(work, "out")
    map_file = os.path.join(out, "map.vimsmap")
    if args.analyse_only:
        samples, wall = read_samples(os.path.join(work, "soak.csv"))
    else:
        samples, wall = run_and_sample(args, sequence, out, map_file, work, bin_dir, bag_bytes, duration)
    report(args, samples, wall, out, map_file, work, bin_dir, duration, start_time)
    if not args.reuse and not args.keep_sequence and not args.analyse_only:
        shutil.rmtree(sequence, ignore_errors=True)


def read_samples(path):
    """Samples of an earlier run's soak.csv and its wall time."""
    with open(path) as f:
        samples = [(float(r["wall_s"]), float(r["bag_fraction"]), float(r["sequence_s"]), float(r["rss_mb"]),
                    float(r["hwm_mb"])) for r in csv.DictReader(f)]
    return samples, samples[-1][0] if samples else 0.0


def run_and_sample(args, sequence, out, map_file, work, bin_dir, bag_bytes, duration):
    """Runs vims_offline (saving the map) and samples its memory; writes WORK/soak.csv."""
    shutil.rmtree(out, ignore_errors=True)
    print(f"[soak] vims_offline on {sequence}, sampling every {args.interval:g} s ...", flush=True)
    start = time.monotonic()
    samples = []
    with open(os.path.join(work, "offline.log"), "w") as log:
        cmd = [os.path.join(bin_dir, "vims_offline"), "--sequence", sequence, "--out", out, "--map-save", map_file]
        if args.config:
            cmd += ["--config", os.path.abspath(args.config)]
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
        while proc.poll() is None:
            status = read_status_mb(proc.pid)
            rchar = read_rchar(proc.pid)
            if status and status[0] is not None:
                fraction = min(1.0, rchar / bag_bytes) if rchar is not None else float("nan")
                samples.append((time.monotonic() - start, fraction, fraction * duration, status[0], status[1]))
            time.sleep(args.interval)
    wall = time.monotonic() - start
    if proc.returncode != 0:
        sys.exit(f"soak.py: vims_offline failed ({proc.returncode}), see {work}/offline.log")
    with open(os.path.join(work, "soak.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["wall_s", "bag_fraction", "sequence_s", "rss_mb", "hwm_mb"])
        for s in samples:
            writer.writerow([f"{s[0]:.1f}", f"{s[1]:.4f}", f"{s[2]:.1f}", f"{s[3]:.1f}", f"{s[4]:.1f}"])
    return samples, wall


def report(args, samples, wall, out, map_file, work, bin_dir, duration, start_time):
    """Prints the per-quarter table (RSS, the map's submap memory, RSS minus the map)."""
    with open(os.path.join(out, "summary.yaml")) as f:
        summary = yaml.safe_load(f)

    # The map's submap memory by keyframe time (cumulative), from the saved map.
    map_csv = os.path.join(work, "map_growth.csv")
    code = subprocess.call([os.path.join(bin_dir, "vims_eval"), "map-size", "--map", map_file, "--csv", map_csv,
                            "--package-root", ROOT])
    if code != 0:
        sys.exit("soak.py: vims_eval map-size failed")
    map_rows = []  # (sequence_s, cumulative_mb, visual_submap)
    with open(map_csv) as f:
        for row in csv.DictReader(f):
            map_rows.append((float(row["t"]) - start_time, float(row["cumulative_mb"]), int(row["visual_submap"])))

    def map_at(seq_s):
        """(cumulative submap MB, stored visual submaps) of the keyframes up to sequence time seq_s."""
        mb, stored = 0.0, 0
        for t, cumulative, visual in map_rows:
            if t > seq_s:
                break
            mb, stored = cumulative, stored + visual
        return mb, stored

    def sample_at(seq_s):
        """The last sample at or before sequence time seq_s (the first one if none)."""
        before = [s for s in samples if s[2] <= seq_s]
        return before[-1] if before else samples[0]

    print(f"[soak] {duration:g} s of sequence in {wall:.0f} s wall; {len(samples)} samples; "
          f"peak RSS {max(s[4] for s in samples):.1f} MB; keyframes {summary['pose_graph']['keyframes']}")
    print("| quarter | sequence s | RSS at end [MB] | RSS growth [MB per 1000 s] | map submaps at end [MB] "
          "| visual submaps stored in the quarter | RSS - map at end [MB] | RSS - map growth [MB per 1000 s] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    quarters = [duration * q / 4.0 for q in range(5)]
    growth, other = [], []
    # Quarter 1 starts at the first sample after start-up (1 % of the bag read: the vocabulary
    # and the first buffers are loaded), not at the empty process.
    started = [s for s in samples if s[1] > 0.01] or samples
    # Quarter 4 ends at the last sample taken while the bag was still being read: after it come
    # the end-of-data steps (the final whole-graph solve, writing the outputs and the map), whose
    # transient memory is reported on its own line below.
    reading = [s for s in samples if s[1] < 0.999] or samples
    for q in range(4):
        # Each end is a sample, and the map is taken at that sample's own sequence time (a sample
        # comes every ~100 s of sequence at 10x real time).
        sa = started[0] if q == 0 else sample_at(quarters[q])
        sb = reading[-1] if q == 3 else sample_at(quarters[q + 1] - 1e-6)
        a, b = sa[3], sb[3]
        (map_a, stored_a), (map_b, stored_b) = map_at(sa[2]), map_at(sb[2])
        span = max(sb[2] - sa[2], 1e-9) / 1000.0
        growth.append((a, b))
        other.append((a - map_a, b - map_b))
        print(f"| {q + 1} | {quarters[q]:.0f}-{quarters[q + 1]:.0f} | {b:.1f} | {(b - a) / span:.1f} | {map_b:.1f} "
              f"| {stored_b - stored_a} | {b - map_b:.1f} | {((b - map_b) - (a - map_a)) / span:.1f} |")
    print(f"[soak] quarter 4 ends at {reading[-1][2]:.0f} s of sequence (last sample while reading); end of data "
          f"(final solve, outputs, map file): RSS {reading[-1][3]:.1f} -> {samples[-1][3]:.1f} MB, "
          f"peak {max(s[4] for s in samples):.1f} MB")
    heap = summary.get("heap_mb", {})
    if heap:
        print(f"[soak] at the end: heap in use {heap['in_use']:.1f} MB (map submaps {map_rows[-1][1]:.1f} MB), "
              f"freed but retained by the allocator {heap['free_retained']:.1f} MB, RSS {samples[-1][3]:.1f} MB")
    for label, (a, b) in (("RSS", growth[3]), ("RSS - map (memory besides the map)", other[3])):
        pct = 100.0 * (b - a) / a if a > 0 else float("nan")
        verdict = "stops growing" if pct < args.plateau_pct else "still growing"
        print(f"[soak] last quarter: {label} {a:.1f} -> {b:.1f} MB ({pct:+.1f} %): {verdict} "
              f"(plateau threshold {args.plateau_pct:g} %)")


if __name__ == "__main__":
    main()
