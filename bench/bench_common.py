"""What the bench scripts share: where the tools are, the work folder, the ATE of a trajectory."""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tool_dir(build):
    """The folder of vims_sim, vims_offline and vims_eval in the build folder `build`."""
    return os.path.join(os.path.abspath(build), "devel", "lib", "vims")


def prepare_work_dir(work, script):
    """Creates the work folder and returns its absolute path; sequences and outputs never go into
    the repository, so a folder inside it ends the script (`script` names it in the message)."""
    work = os.path.abspath(work)
    if work.startswith(ROOT + os.sep):
        sys.exit(f"{script}: --work must be outside the repository")
    os.makedirs(work, exist_ok=True)
    return work


class EvalError(RuntimeError):
    """vims_eval printed no ATE (its output is the message)."""


def ate_se3_m(bin_dir, sequence, estimate):
    """SE(3)-aligned ATE [m] of the TUM file `estimate` against the sequence's <name>_gt.tum."""
    name = os.path.basename(os.path.normpath(sequence))
    gt = os.path.join(sequence, name + "_gt.tum")
    proc = subprocess.run([os.path.join(bin_dir, "vims_eval"), "traj", "--align", "se3", "--gt", gt, "--est", estimate],
                          capture_output=True, text=True)
    m = re.search(r" ate_se3_m=([0-9.eE+-]+|nan)", proc.stdout)
    if not m:
        raise EvalError(proc.stdout + proc.stderr)
    return float(m.group(1))


def run_logged(cmd, log):
    """Runs `cmd` with its stdout and stderr in the file `log`; returns its exit status."""
    with open(log, "w") as f:
        return subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode


def publish_table(work, stem, lines):
    """Prints the markdown table of `lines` and writes it to WORK/STEM.md."""
    table = "\n".join(lines)
    with open(os.path.join(work, stem + ".md"), "w") as f:
        f.write(table + "\n")
    print(table)


def _summary(line):
    return dict(kv.split("=", 1) for kv in line.split()[1:] if "=" in kv)


def eval_run(bin_dir, sequence, out):
    """`vims_eval run` on a finished vims_offline output folder: VIO and global SE(3) ATE [% of
    distance and m], the ground truth's distance [m], rotation RMSE, tilt error [deg] and height
    error [m] (both after the position-and-yaw alignment), loops. nan (or -1 loops) for what the
    folder lacks (e.g. --vio-only runs have no global trajectory)."""
    proc = subprocess.run([os.path.join(bin_dir, "vims_eval"), "run", "--sequence", sequence, "--out", out],
                          capture_output=True, text=True)
    nan = float("nan")
    figures = {"vio_pct": nan, "vio_m": nan, "vio_rot_deg": nan, "vio_tilt_deg": nan, "vio_height_m": nan,
               "global_pct": nan, "global_m": nan, "global_rot_deg": nan, "global_tilt_deg": nan,
               "global_height_m": nan, "distance_m": nan,
               "loops_correct": -1, "loops_wrong": -1}
    for line in proc.stdout.splitlines():
        if line.startswith("VIMS_EVAL "):
            kv = _summary(line)
            label = kv.get("label")
            if label == "vio":
                figures["distance_m"] = float(kv.get("dist_m", nan))
            if label in ("vio", "global"):
                figures[f"{label}_pct"] = float(kv.get("ate_se3_pct", nan))
                figures[f"{label}_m"] = float(kv.get("ate_se3_m", nan))
                figures[f"{label}_rot_deg"] = float(kv.get("rot_rmse_deg", nan))
                figures[f"{label}_tilt_deg"] = float(kv.get("tilt_rmse_deg", nan))
                figures[f"{label}_height_m"] = float(kv.get("height_rmse_m", nan))
        elif line.startswith("VIMS_EVAL_LOOPS "):
            kv = _summary(line)
            figures["loops_correct"] = int(kv.get("correct", -1))
            figures["loops_wrong"] = int(kv.get("wrong", -1))
    if figures["vio_pct"] != figures["vio_pct"]:
        raise EvalError(proc.stdout + proc.stderr)
    return figures
