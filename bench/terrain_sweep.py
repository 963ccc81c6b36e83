#!/usr/bin/python3
"""Terrain sweep (issue 17): VIO and global accuracy of each seabed model over slopes and roughness.

For every scenario x slope x roughness: one simulated sequence (vims_sim --terrain-slope-deg S,
roughness R as --terrain-roughness-m R up to 0.2 m and as rocks up to R tall above, rolling relief
as the `slope4` preset, pressure sensor on), then
vims_offline with the seabed model `horizontal` and `local_plane`, each with and without the
pressure factor. Prints one row per run and writes WORK/terrain_sweep.md, .csv and an SVG plot of
the VIO ATE against the slope (WORK/terrain_sweep.svg).

    bench/terrain_sweep.py --work /work/data/terrain [--scenarios tank field] [--slopes 0 2 4 8]
                           [--roughness 0 0.1 0.3] [--duration 300] [--seed 1] [--build _build] [--jobs 2]
                           [--models horizontal local_plane] [--pressure on off]
                           [--runs horizontal:on local_plane:on local_plane:off]

Sequences and finished runs already in WORK are reused, so a sweep can be extended (more slopes,
another model) or resumed after an interruption without recomputing them; delete WORK to start
afresh after a code change.

Figures: VIO and global translation ATE (SE3) in % of the distance, VIO rotation RMSE and tilt
error (deg, after a yaw-only alignment), wrong loops. docs/benchmarks.md, "Terrain", holds the
measured tables and the command of each.
"""
import argparse
import csv
import itertools
import os
import sys
from concurrent.futures import ThreadPoolExecutor

from bench_common import ROOT, eval_run, prepare_work_dir, publish_table, run_logged, tool_dir


def config_text(model, pressure):
    return f"estimator:\n  seabed: {{model: {model}}}\n  pressure: {{enabled: {'true' if pressure else 'false'}}}\n"


def roughness_flags(rough):
    """vims_sim flags for a roughness level [m]: up to 0.2 m the rms height of the 1-5 m roughness
    (the simulator's range); above, 0.1 m of roughness plus rocks up to `rough` tall (0.05 per m^2)."""
    if rough <= 0.2:
        return ["--terrain-roughness-m", str(rough)]
    return ["--terrain-roughness-m", "0.1", "--terrain-rock-height-m", str(rough), "--terrain-rock-density", "0.05"]


def svg_plot(rows, path, key="vio_pct"):
    """A small line plot (no plotting library needed): `key` against the slope, one line per
    scenario x roughness x model x pressure."""
    series = {}
    for r in rows:
        label = f"{r['scenario']} rough {r['roughness']} {r['model']}{' +p' if r['pressure'] == 'on' else ''}"
        series.setdefault(label, []).append((float(r["slope"]), float(r[key])))
    xs = [x for pts in series.values() for x, _ in pts]
    ys = [y for pts in series.values() for _, y in pts if y == y]
    if not xs or not ys:
        return
    w, h, m = 760, 420, 60
    x0, x1, y1 = min(xs), max(xs) or 1.0, max(ys) * 1.1 or 1.0
    sx = lambda x: m + (x - x0) / ((x1 - x0) or 1.0) * (w - 2 * m - 200)
    sy = lambda y: h - m - y / y1 * (h - 2 * m)
    colours = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
               "#bcbd22", "#17becf"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<line x1="{m}" y1="{h - m}" x2="{w - m - 200}" y2="{h - m}" stroke="black"/>',
           f'<line x1="{m}" y1="{m}" x2="{m}" y2="{h - m}" stroke="black"/>',
           f'<text x="{(w - 200) / 2}" y="{h - 20}" text-anchor="middle">seabed slope [deg]</text>',
           f'<text x="15" y="{h / 2}" transform="rotate(-90 15 {h / 2})" text-anchor="middle">{key} [% of distance]</text>']
    for x in sorted(set(xs)):
        out.append(f'<text x="{sx(x):.1f}" y="{h - m + 15}" text-anchor="middle">{x:g}</text>')
    for k in range(5):
        y = y1 * k / 4
        out.append(f'<text x="{m - 5}" y="{sy(y) + 4:.1f}" text-anchor="end">{y:.3f}</text>')
    for i, (label, pts) in enumerate(sorted(series.items())):
        c = colours[i % len(colours)]
        pts = sorted(p for p in pts if p[1] == p[1])
        dash = ' stroke-dasharray="5,3"' if "horizontal" in label else ""
        out.append(f'<polyline fill="none" stroke="{c}" stroke-width="2"{dash} points="' +
                   " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in pts) + '"/>')
        out.append(f'<text x="{w - m - 190}" y="{m + 14 * i}" fill="{c}">{label}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", required=True, help="folder for sequences and outputs (not inside the repo)")
    ap.add_argument("--scenarios", nargs="+", default=["tank", "field"])
    ap.add_argument("--slopes", type=float, nargs="+", default=[0.0, 2.0, 4.0, 8.0])
    ap.add_argument("--roughness", type=float, nargs="+", default=[0.0, 0.1, 0.3])
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--models", nargs="+", default=["horizontal", "local_plane"])
    ap.add_argument("--pressure", nargs="+", default=["off", "on"], choices=["on", "off"])
    ap.add_argument("--runs", nargs="+", metavar="MODEL:PRESSURE",
                    help="the model/pressure pairs to run (e.g. horizontal:on local_plane:on local_plane:off) "
                         "instead of every --models x --pressure pair")
    ap.add_argument("--vio-only", action="store_true", help="no pose graph (VIO figures only, faster)")
    ap.add_argument("--build", default=os.path.join(ROOT, "_build"))
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    if args.runs:
        pairs = [tuple(r.split(":", 1)) for r in args.runs]
        bad = [r for r, pair in zip(args.runs, pairs)
               if len(pair) != 2 or pair[0] not in ("horizontal", "local_plane") or pair[1] not in ("on", "off")]
        if bad:
            sys.exit(f"terrain_sweep.py: --runs takes MODEL:PRESSURE with MODEL horizontal|local_plane and "
                     f"PRESSURE on|off, got {' '.join(bad or args.runs)}")
    else:
        pairs = [(model, p) for model in args.models for p in args.pressure]
    work = prepare_work_dir(args.work, "terrain_sweep.py")
    bin_dir = tool_dir(args.build)

    worlds = list(itertools.product(args.scenarios, args.slopes, args.roughness))

    def simulate(world):
        scenario, slope, rough = world
        seq = os.path.join(work, f"{scenario}_s{slope:g}_r{rough:g}")
        if not os.path.exists(os.path.join(seq, os.path.basename(seq) + ".bag")):
            cmd = [os.path.join(bin_dir, "vims_sim"), "--scenario", scenario, "--duration", str(args.duration),
                   "--seed", str(args.seed), "--out", seq, "--terrain", "slope4", "--terrain-slope-deg", str(slope),
                   "--pressure", "--threads", "1"] + roughness_flags(rough)
            if run_logged(cmd, seq + "_sim.log") != 0:
                sys.exit(f"terrain_sweep.py: vims_sim failed, see {seq}_sim.log")
        return seq

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        sequences = dict(zip(worlds, pool.map(simulate, worlds)))

    jobs = [(w, model, p) for w in worlds for model, p in pairs]

    def estimate(job):
        world, model, pressure = job
        seq = sequences[world]
        out = f"{seq}_{model}_{'p' if pressure == 'on' else 'nop'}"
        cfg = out + ".yaml"
        with open(cfg, "w") as f:
            f.write(config_text(model, pressure == "on"))
        cmd = [os.path.join(bin_dir, "vims_offline"), "--sequence", seq, "--out", out, "--config", cfg, "--quiet"]
        if args.vio_only:
            cmd.append("--vio-only")
        # A finished run of an earlier call (its summary is written last) is reused.
        if not os.path.exists(os.path.join(out, "summary.yaml")) and run_logged(cmd, out + ".log") != 0:
            sys.exit(f"terrain_sweep.py: vims_offline failed, see {out}.log")
        figures = eval_run(bin_dir, seq, out)
        scenario, slope, rough = world
        return {"scenario": scenario, "slope": slope, "roughness": rough, "model": model, "pressure": pressure,
                **figures}

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(estimate, jobs))

    keys = ["scenario", "slope", "roughness", "model", "pressure", "vio_pct", "vio_rot_deg", "vio_tilt_deg",
            "global_pct", "global_rot_deg", "loops_correct", "loops_wrong"]
    with open(os.path.join(work, "terrain_sweep.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    lines = ["| scenario | slope [deg] | roughness [m] | seabed model | pressure | VIO ATE [%] | VIO rot [deg] | "
             "VIO tilt [deg] | global ATE [%] | global rot [deg] | loops correct / wrong |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    fmt = lambda v, d: "nan" if v != v else f"{v:.{d}f}"
    for r in rows:
        lines.append(f"| {r['scenario']} | {r['slope']:g} | {r['roughness']:g} | {r['model']} | {r['pressure']} | "
                     f"{fmt(r['vio_pct'], 3)} | {fmt(r['vio_rot_deg'], 2)} | {fmt(r['vio_tilt_deg'], 3)} | "
                     f"{fmt(r['global_pct'], 3)} | {fmt(r['global_rot_deg'], 2)} | "
                     f"{r['loops_correct']} / {r['loops_wrong']} |")
    svg_plot(rows, os.path.join(work, "terrain_sweep.svg"))
    publish_table(work, "terrain_sweep", lines)


if __name__ == "__main__":
    main()
