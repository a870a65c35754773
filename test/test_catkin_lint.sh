#!/usr/bin/env bash
# catkin_lint at -W2 (every warning and notice counts as a problem) on the package folder.
# Usage: test_catkin_lint.sh PACKAGE_DIR   (a folder named like the package, e.g. a workspace's
# src/networked_estimation). Without catkin_lint installed (Debian: catkin-lint) the check is SKIPPED.
set -uo pipefail
if ! command -v catkin_lint > /dev/null 2>&1; then
  echo "catkin_lint: SKIPPED (not installed; Debian package catkin-lint)"
  exit 0
fi
# The rosdep database is optional here (it needs the network); catkin_lint then says that unknown
# dependencies are ignored, which is not a problem of the package.
out=$(catkin_lint -W2 --strict "$1" 2>&1)
rc=$?
echo "$out"
[ "$rc" -eq 0 ] && echo "1 passed, 0 failed" || echo "0 passed, 1 failed"
exit "$rc"
