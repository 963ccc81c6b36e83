#!/bin/bash
# The README's test command: installs what is needed, builds everything, runs every test
# (unit tests, rostests, system tests on freshly simulated sequences). Exits non-zero on any failure.
set -eo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
VIMS_WARNINGS_AS_ERRORS=ON bash scripts/build.sh --tests  # a new compiler warning fails the tests
source scripts/env.sh
mkdir -p "$ROS_HOME"
rm -rf "$VIMS_BUILD/test_results"   # ctest does not clean old XML results
ctest --test-dir "$VIMS_BUILD" --output-on-failure -j"${JOBS:-$(nproc)}" "$@" || {
  catkin_test_results --verbose "$VIMS_BUILD/test_results" || true
  exit 1
}
