#!/bin/bash
# Configures and builds the `vims` package (and, with --tests, the test executables) in _build/.
set -eo pipefail
source "$(dirname "$0")/env.sh"
cd "$VIMS_ROOT"
JOBS="${JOBS:-$(nproc)}"
mkdir -p "$VIMS_BUILD"
# VIMS_WARNINGS_AS_ERRORS=ON|OFF (scripts/test.sh sets ON); unset keeps the build tree's setting, so
# alternating the test and the main command does not rebuild everything.
WERROR=()
[ -n "${VIMS_WARNINGS_AS_ERRORS:-}" ] && WERROR=(-DVIMS_WARNINGS_AS_ERRORS="$VIMS_WARNINGS_AS_ERRORS")
cmake -S . -B "$VIMS_BUILD" -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" "${WERROR[@]}" \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 > "$VIMS_BUILD/configure.log" 2>&1 \
  || { cat "$VIMS_BUILD/configure.log"; exit 1; }
cmake --build "$VIMS_BUILD" -j"$JOBS"
if [ "${1:-}" = "--tests" ]; then
  cmake --build "$VIMS_BUILD" -j"$JOBS" --target tests
fi
