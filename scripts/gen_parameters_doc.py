#!/usr/bin/python3
"""Generates docs/parameters.md from the committed config/*.yaml files and the options tables.

The config files are the single source of every parameter's default and meaning (their comments
explain each value; test_committed_configs checks that the values equal the code's defaults); the
code's option tables (vims_common/option_table.h) are the single source of the values each key
accepts, printed by `vims_offline --list-options`. This script joins them into one reference page
so the documentation cannot drift from either:

    /usr/bin/python3 scripts/gen_parameters_doc.py           # rewrite docs/parameters.md
    /usr/bin/python3 scripts/gen_parameters_doc.py --check   # exit 1 if the page is stale, a key has no
                                                             # comment, or the files and the tables
                                                             # disagree on the keys (CTest test_parameters_doc)
    [--vims-offline PATH]   the built runner (default: $VIMS_BUILD or _build, devel/lib/vims/vims_offline)

Comment rules understood (the style of the config files): a comment block directly above one or
more keys describes them all; an inline comment after a value describes that key only; a comment
block followed by a blank line is a section note; nesting is shown as dotted key paths.
"""
import argparse
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Order and one-line purpose of each configuration file.
CONFIG_FILES = [
    ("sonar.yaml", "sonar altitude filter (vims_sonar_filter_node, `sonar` section)"),
    ("magnetometer.yaml", "magnetic signatures and geomagnetic field (vims_magnetometer_node, `magnetometer` section)"),
    ("tracker.yaml", "KLT feature tracker (vims_estimator_node, `tracker` section)"),
    ("estimator.yaml", "sliding-window VIO (vims_estimator_node, `estimator` section)"),
    ("pose_graph.yaml", "pose graph, multi-scale map and loop closing (vims_pose_graph_node, `pose_graph` section)"),
]
KEY_LINE = re.compile(r"^(?P<indent> *)(?P<key>[A-Za-z_][A-Za-z0-9_]*):(?P<rest>.*)$")


def split_inline_comment(text):
    """Splits 'value  # comment' (a '#' inside quotes or brackets does not start a comment)."""
    depth, quote = 0, None
    for i, ch in enumerate(text):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "#" and depth == 0 and (i == 0 or text[i - 1] in " \t"):
            return text[:i].strip(), text[i + 1:].strip()
    return text.strip(), ""


def parse_config(path):
    """Returns (file_note, rows); a row is [keys, values, meaning]."""
    with open(path) as f:
        lines = f.read().splitlines()
    file_note, rows = "", []
    block, block_row = [], None  # the comment block in force and the row it describes
    previous_was_comment = False
    parents = []  # (indent, key) of the enclosing mappings
    seen_key = False
    for line in lines:
        stripped = line.strip()
        if not stripped:  # a blank line ends a comment block's reach
            if block and not seen_key:
                file_note = " ".join(block)
            block, block_row, previous_was_comment = [], None, False
            continue
        if stripped.startswith("#"):
            if not previous_was_comment:
                block, block_row = [], None
            block.append(stripped.lstrip("#").strip())
            previous_was_comment = True
            continue
        previous_was_comment = False
        m = KEY_LINE.match(line)
        if not m:
            continue
        indent = len(m.group("indent"))
        while parents and parents[-1][0] >= indent:
            parents.pop()
        value, inline = split_inline_comment(m.group("rest"))
        path_key = ".".join([p[1] for p in parents] + [m.group("key")])
        block_text = " ".join(block)
        if not value:  # a mapping: its keys follow, indented
            parents.append((indent, m.group("key")))
            if block and not seen_key:  # the file's header comment sits on its only section
                file_note, block = block_text, []
            elif block:
                rows.append([[path_key + ".*"], [""], block_text])
                block_row = rows[-1]
            seen_key = True
            continue
        seen_key = True
        if inline:
            heading = block_text + ": " if block and block_row is None and len(block_text) < 60 else ""
            rows.append([[path_key], [value], heading + inline])
        elif block_row is not None:
            block_row[0].append(path_key)  # one more key under the same comment block
            block_row[1].append(value)
        else:
            rows.append([[path_key], [value], block_text])
            if block:
                block_row = rows[-1]
    return file_note, rows


def option_table(vims_offline):
    """{key path: allowed values} from the code's option tables."""
    if not os.path.exists(vims_offline):
        raise SystemExit("%s not found: build VIMS first (scripts/build.sh) or pass --vims-offline" % vims_offline)
    text = subprocess.run([vims_offline, "--list-options"], check=True, capture_output=True, text=True).stdout
    return dict(line.split("\t", 1) for line in text.splitlines() if line)


def render(allowed):
    out = [
        "# Parameters",
        "",
        "<!-- Generated by scripts/gen_parameters_doc.py from config/*.yaml: edit those files, then run",
        "     `/usr/bin/python3 scripts/gen_parameters_doc.py`. CTest test_parameters_doc fails when stale. -->",
        "",
        "Every tunable parameter of VIMS, with its default and meaning, as stated in the committed",
        "configuration files (test_committed_configs checks that the files equal the code's defaults),",
        "and the values it accepts, as the code checks them (`vims_offline --list-options`). A key that",
        "is missing from a user's file keeps its default; an unknown key or a value outside its allowed",
        "range stops the node or `vims_offline` with an error naming the key.",
        "",
        "Where the values go: every entry point reads a *system configuration*, one or more YAML files",
        "whose top-level keys are the sections `sonar`, `magnetometer`, `tracker`, `estimator` and",
        "`pose_graph` (each holding the keys below; a section in two files is an error), through one",
        "loader (`vims::SystemConfig`, vims_system):",
        "- ROS: each node's `~config_file` (a path or a list of paths) and uses its sections; the",
        "  launch args sonar_options, magnetometer_options, estimator_config (sections `tracker` and",
        "  `estimator`) and pose_graph_options name the files.",
        "- Offline: `vims_offline --config FILE` (repeatable), e.g. the four files the launch files use.",
        "- Calibration (camera intrinsics and distortion, extrinsics `T_b_c`/`T_b_s`/`T_b_m`, IMU and sonar",
        "  noise, coil frequency, declination) is never a parameter here: it is read from the sequence's",
        "  YAML (docs/sensor-contract.md), so a recording from another vehicle needs no retuning.",
        "- Command-line options: `vims_offline --help`, `vims_eval --help`, `vims_sim --help`; launch",
        "  arguments: docs/running.md.",
        "",
    ]
    for name, purpose in CONFIG_FILES:
        path = os.path.join(ROOT, "config", name)
        if not os.path.exists(path):
            continue
        note, rows = parse_config(path)
        out += ["## config/%s: %s" % (name, purpose), ""]
        if note:
            out += [note, ""]
        out += ["| key | default | allowed | meaning |", "| --- | --- | --- | --- |"]
        for keys, values, meaning in rows:
            key_text = "<br>".join("`%s`" % k for k in keys)
            value_text = "<br>".join("`%s`" % v if v else "" for v in values)
            allowed_text = "<br>".join(allowed.get(k, "") for k in keys)
            out.append("| %s | %s | %s | %s |" % (key_text, value_text, allowed_text, meaning.replace("|", "\\|")))
        out.append("")
    return "\n".join(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if docs/parameters.md is stale")
    build = os.environ.get("VIMS_BUILD", os.path.join(ROOT, "_build"))
    parser.add_argument("--vims-offline", default=os.path.join(build, "devel", "lib", "vims", "vims_offline"))
    args = parser.parse_args()
    target = os.path.join(ROOT, "docs", "parameters.md")
    allowed = option_table(args.vims_offline)
    text = render(allowed)
    if args.check:
        documented = {k for name, _ in CONFIG_FILES if os.path.exists(os.path.join(ROOT, "config", name))
                      for keys, _, _ in parse_config(os.path.join(ROOT, "config", name))[1]
                      for k in keys if not k.endswith(".*")}
        missing = sorted(set(allowed) - documented)
        stray = sorted(documented - set(allowed))
        if missing or stray:
            if missing:
                print("keys the code reads but no config/*.yaml states: " + ", ".join(missing))
            if stray:
                print("keys in config/*.yaml the code does not read: " + ", ".join(stray))
            return 1
        undocumented = [k for name, _ in CONFIG_FILES if os.path.exists(os.path.join(ROOT, "config", name))
                         for keys, _, meaning in parse_config(os.path.join(ROOT, "config", name))[1]
                         if not meaning for k in keys]
        if undocumented:
            print("keys without a comment saying what they mean: " + ", ".join(undocumented))
            return 1
        current = open(target).read() if os.path.exists(target) else ""
        if current != text:
            print("docs/parameters.md is stale: run /usr/bin/python3 scripts/gen_parameters_doc.py")
            return 1
        print("docs/parameters.md is up to date")
        return 0
    with open(target, "w") as f:
        f.write(text)
    print("wrote", target)
    return 0


if __name__ == "__main__":
    sys.exit(main())
