#!/usr/bin/env bash
# Builds the package in a catkin workspace inside the repository (.ws/, git-ignored).
# Usage: scripts/build.sh [--tests]      everything; --tests also the test binaries
#        scripts/build.sh TARGET...        only these targets and what they need (scripts/demo.sh)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
mkdir -p "$ROS_HOME"
link_package
JOBS="${NE_JOBS:-$(nproc)}"
TARGETS=()
[ "${1:-}" = "--tests" ] || TARGETS=("$@")
cd "$WS"
catkin_make -j"$JOBS" -DCMAKE_BUILD_TYPE=Release ${TARGETS[@]+"${TARGETS[@]}"} > "$WS/build.log" 2>&1 || { tail -n 60 "$WS/build.log"; echo "build failed (full log: $WS/build.log)"; exit 1; }
if [ "${1:-}" = "--tests" ]; then
  catkin_make -j"$JOBS" tests >> "$WS/build.log" 2>&1 || { tail -n 60 "$WS/build.log"; echo "test build failed (full log: $WS/build.log)"; exit 1; }
fi
echo "build: ok ($WS)"
