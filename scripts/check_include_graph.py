#!/usr/bin/python3
"""Checks that the module include graph flows one way (docs/conventions.md, "Modules").

Every core library may include the headers of the modules below it and no others; the front ends'
results that the back ends consume live in vims_common, so no back end and no ROS glue includes a
front end. ROS headers appear only in vims_ros, the nodes and the command-line tools. Tests,
nodes, tools and benchmarks are entry points: they may include any core.

    /usr/bin/python3 scripts/check_include_graph.py          # exit 1 and one line per violation
    /usr/bin/python3 scripts/check_include_graph.py --graph  # also print the module graph

CTest: test_include_graph.
"""
import argparse
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The core libraries, lowest first: the module prefixes each may include (its own always).
ALLOWED = {
    "vims_common": set(),
    "vims_sonar": {"vims_common"},
    "vims_magnetometer": {"vims_common"},
    "vims_tracking": {"vims_common"},
    "vims_estimator": {"vims_common"},
    "vims_pose_graph": {"vims_common"},
    "vims_sim": {"vims_common"},
    "vims_eval": {"vims_common", "vims_pose_graph"},
    "vims_ros": {"vims_common"},
    "vims_system": {"vims_common", "vims_sonar", "vims_magnetometer", "vims_tracking", "vims_estimator",
                    "vims_pose_graph"},
}
# ROS headers (angle-bracket includes of these packages) belong to vims_ros and the entry points.
ROS_PACKAGES = ("ros/", "rosbag/", "sensor_msgs/", "std_msgs/", "geometry_msgs/", "nav_msgs/", "tf2",
                "visualization_msgs/", "cv_bridge/", "image_transport/", "vims/", "xmlrpcpp/", "roslib/")
ROS_ALLOWED = {"vims_ros"}
# Entry points: nodes, the offline runner, command-line tools, benchmarks and tests.
ENTRY_POINT = re.compile(r"(^|/)(test|tests|tools|bench|ros)/|^vims_offline/|_main\.cpp$|_node\.cpp$")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def module_of(path):
    """The core module a source file belongs to, or None for an entry point or a non-module file."""
    if ENTRY_POINT.search(path):
        return None
    top = path.split("/", 1)[0]
    return top if top in ALLOWED else None


def tracked_sources():
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                         check=True, capture_output=True, text=True).stdout.split()
    return [p for p in out if p.endswith((".h", ".hpp", ".cpp", ".cc"))]


def read(path):
    with open(os.path.join(ROOT, path), errors="replace") as f:
        return f.read()


def check(paths, text_of=read):
    """Returns (violations, edges): one line per forbidden include, and {(from, to): count}."""
    violations, edges = [], {}
    for path in paths:
        module = module_of(path)
        if module is None:
            continue
        for number, line in enumerate(text_of(path).splitlines(), 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            bracket, header = m.groups()
            target = header.split("/", 1)[0]
            if bracket == '"' and target in ALLOWED:
                if target != module:
                    edges[(module, target)] = edges.get((module, target), 0) + 1
                if target != module and target not in ALLOWED[module]:
                    violations.append("%s:%d: %s includes %s (%s may include only %s)" % (
                        path, number, module, header, module, ", ".join(sorted(ALLOWED[module])) or "itself"))
            elif bracket == "<" and header.startswith(ROS_PACKAGES) and module not in ROS_ALLOWED:
                violations.append("%s:%d: %s includes the ROS header %s (only vims_ros and the entry points may)"
                                  % (path, number, module, header))
    return violations, edges


def self_test():
    """The check must be able to fail: a back end including a front end, a core including ROS."""
    files = {
        "vims_pose_graph/src/map/x.cpp": '#include "vims_magnetometer/signature_extractor.h"\n',
        "vims_estimator/src/y.cpp": "#include <ros/ros.h>\n",
        "vims_ros/src/z.cpp": '#include "vims_sonar/sonar_altitude_filter.h"\n',
        "vims_pose_graph/src/ros/node.cpp": '#include "vims_system/system_config.h"\n#include <ros/ros.h>\n',
        "vims_system/src/ok.cpp": '#include "vims_sonar/sonar_altitude_filter.h"\n',
    }
    violations, _ = check(sorted(files), text_of=files.get)
    expected = ["vims_estimator/src/y.cpp:1", "vims_pose_graph/src/map/x.cpp:1", "vims_ros/src/z.cpp:1"]
    found = sorted(v.split(": ", 1)[0] for v in violations)
    if found != expected:
        print("check_include_graph self-test: expected violations at %s, found %s" % (expected, found))
        return False
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--graph", action="store_true", help="print the module graph (edges with include counts)")
    args = ap.parse_args()
    if not self_test():
        return 1
    violations, edges = check(tracked_sources())
    if args.graph:
        for (a, b), n in sorted(edges.items()):
            print("%-18s -> %-18s %3d" % (a, b, n))
    for v in violations:
        print(v)
    if violations:
        print("check_include_graph: %d include(s) against the module graph" % len(violations), file=sys.stderr)
        return 1
    print("check_include_graph: the include graph flows one way (%d module edges)" % len(edges))
    return 0


if __name__ == "__main__":
    sys.exit(main())
