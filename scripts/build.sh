#!/usr/bin/env bash
# Builds the package in a catkin workspace inside the repository (.ws/, git-ignored).
# Usage: scripts/build.sh [--tests]      everything; --tests also the test binaries
#        scripts/build.sh TARGET...        only these targets and what they need (scripts/demo.sh)
# The whole output goes to .ws/build.log. The terminal gets make's progress (the percentage of the
# goal's steps done, as make prints it in the log): a line at each tenth (5 s apart at least), at
# most every 15 s while it moves, and once a minute while one long unit compiles, naming it, e.g.
#   build: 40 %, 3 min 05 s
#   build: networked_estimation_nodelets (1 of 7): 53 %, 4 min 10 s, compiling unity_6_cxx.cxx
#          (networked_estimation_core)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
mkdir -p "$ROS_HOME"
link_package
JOBS="${NE_JOBS:-$(nproc)}"
TARGETS=()
[ "${1:-}" = "--tests" ] || TARGETS=("$@")
LOG="$WS/build.log"
START=$SECONDS
cd "$WS"
: > "$LOG"

fail() {
  tail -n 60 "$LOG"
  echo "$1 (full log: $LOG)"
  exit 1
}

elapsed() {
  local s=$((SECONDS - START))
  printf '%d min %02d s' $((s / 60)) $((s % 60))
}

# make_with_progress LABEL [GOAL]: make one goal (none: all) in the configured build folder, as
# catkin_make would, its output into the log, printing its progress meanwhile. One goal at a time:
# make's percentage restarts at each goal of a command line.
PROGRESS_RE='^\[ *[0-9]+%\]'
make_with_progress() {
  local label="$1" pct shown=-1 tenth=-1 last=$SECONDS from pid unit
  shift
  from=$(($(wc -l < "$LOG") + 1))
  make -C "$WS/build" -j"$JOBS" "$@" >> "$LOG" 2>&1 &
  pid=$!
  while kill -0 "$pid" 2> /dev/null; do
    sleep 2
    pct=$(tail -n +"$from" "$LOG" | grep -oE "$PROGRESS_RE" | tail -n 1 | tr -dc '0-9' || true)
    [ -n "$pct" ] || continue
    # Not at 100 % (the next line says so), nor within 5 s of the last line.
    [ "$pct" -lt 100 ] && [ $((SECONDS - last)) -ge 5 ] || continue
    if { [ "$pct" -ne "$shown" ] && { [ $((pct / 10)) -gt "$tenth" ] || [ $((SECONDS - last)) -ge 15 ]; }; } ||
       [ $((SECONDS - last)) -ge 60 ]; then
      unit=""
      if [ "$pct" -eq "$shown" ]; then
        # "[ 51%] Building CXX object <dir>/CMakeFiles/<target>.dir/<path>/<unit>.o" -> "<unit> (<target>)"
        unit=$(tail -n +"$from" "$LOG" | grep -E "$PROGRESS_RE Building" | tail -n 1 |
               sed -E 's|.*CMakeFiles/([^/]+)\.dir/(.*/)?([^/]+)\.o$|\3 (\1)|' || true)
        [ -z "$unit" ] || unit=", compiling $unit"
      fi
      echo "$label: $pct %, $(elapsed)$unit"
      shown=$pct
      tenth=$((pct / 10))
      last=$SECONDS
    fi
  done
  wait "$pid"
}

echo "build: configuring (log: $LOG)"
# catkin_make runs CMake when the workspace is new or its arguments changed, else make's own check.
catkin_make -DCMAKE_BUILD_TYPE=Release cmake_check_build_system >> "$LOG" 2>&1 || fail "build failed: CMake"
if [ ${#TARGETS[@]} -eq 0 ]; then
  make_with_progress build || fail "build failed"
else
  i=0
  for t in "${TARGETS[@]}"; do
    i=$((i + 1))
    make_with_progress "build: $t ($i of ${#TARGETS[@]})" "$t" || fail "build of $t failed"
  done
fi
if [ "${1:-}" = "--tests" ]; then
  make_with_progress "build: tests" tests || fail "test build failed"
fi
echo "build: ok ($WS, $(elapsed))"
