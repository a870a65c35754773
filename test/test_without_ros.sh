#!/usr/bin/env bash
# The build without ROS, as a researcher runs it (README, scripts/research.sh): a copy of the repository
# in a clean temporary folder, `pip install --no-build-isolation --no-index .` into a new virtual
# environment (setup.py -> CMake with NE_WITH_ROS=OFF: the core and the Python module only, offline),
# then the Python module's tests against that installation, with no ROS path on the environment and
# results compared with the catkin build's tools (TOOLS_DIR). Checks that the module links no ROS library.
# Usage: test_without_ros.sh PACKAGE_DIR TOOLS_DIR   (PACKAGE_DIR: the repository or the workspace's
# src/networked_estimation). NE_JOBS: compile jobs (default 2).
set -uo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 PACKAGE_DIR TOOLS_DIR" >&2
  exit 2
fi
# the repository behind the workspace's links
ROOT=$(cd "$(dirname "$(readlink -f "$1/CMakeLists.txt")")" && pwd)
TOOLS=$(cd "$2" && pwd)
WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_without_ros.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
source "$ROOT/test/check_lib.sh"

# Debian's interpreter, and an environment without the workspace's ROS and Python paths
PY=/usr/bin/python3
CLEAN=(env -u PYTHONPATH -u CMAKE_PREFIX_PATH -u ROS_PACKAGE_PATH -u LD_LIBRARY_PATH -u PKG_CONFIG_PATH
       PATH=/usr/local/bin:/usr/bin:/bin HOME="$WORK" NE_JOBS="${NE_JOBS:-2}")

# the files git knows (committed or not, not ignored): what a clone has (without git: the folder
# but for the build outputs)
SRC=$WORK/src
mkdir -p "$SRC"
if git -C "$ROOT" rev-parse --git-dir >/dev/null 2>&1; then
  (cd "$ROOT" && git ls-files -co --exclude-standard -z | xargs -0 cp --parents -t "$SRC" 2>/dev/null)
else
  tar -C "$ROOT" --exclude=./.ws --exclude=./build --exclude=./.venv -cf - . | tar -C "$SRC" -xf -
fi
check "the copy has the sources" [ -f "$SRC/setup.py" -a -f "$SRC/pyproject.toml" -a -f "$SRC/cmake/without_ros.cmake" ]

run_rc rc "${CLEAN[@]}" "$PY" -m venv --system-site-packages "$WORK/venv"
check "a virtual environment" [ "$rc" = 0 ]
start=$(date +%s)
(cd "$SRC" && run_rc rc "${CLEAN[@]}" "$WORK/venv/bin/python3" -m pip install --no-build-isolation --no-index \
  --no-deps -v . && echo "$rc" >"$WORK/pip_rc")
cat "$WORK/err.txt" | tail -20
check "pip install --no-build-isolation --no-index . exits 0 ($(( $(date +%s) - start )) s)" \
  [ "$(cat "$WORK/pip_rc" 2>/dev/null)" = 0 ]
# (pip -v passes on CMake's output: the status line of cmake/without_ros.cmake)
check "the build configured without ROS" grep -q "the build without ROS (NE_WITH_ROS=OFF)" "$WORK/out.txt" "$WORK/err.txt"

SITE=$("${CLEAN[@]}" "$WORK/venv/bin/python3" -c "import networked_estimation as ne, os; print(os.path.dirname(ne.__file__))" 2>"$WORK/err.txt")
check "the module imports from the environment" [ "${SITE#$WORK/venv/}" != "$SITE" ]
check "the module has the core (ne.Model, ne.montecarlo)" "${CLEAN[@]}" "$WORK/venv/bin/python3" -c \
  "import networked_estimation as ne; ne.Model; ne.montecarlo"
check "the compiled module links no ROS library" \
  bash -c "ldd '$SITE'/_core*.so > '$WORK/ldd.txt' && ! grep -Ei 'ros|catkin|console_bridge' '$WORK/ldd.txt'"

# The Python tests (not the messages' test: no ROS messages without ROS), from the copy, against the
# environment's module and the catkin build's tools.
(cd "$SRC/test/python" && "${CLEAN[@]}" NE_TOOLS="$TOOLS" NE_ROOT="$SRC" "$WORK/venv/bin/python3" -m pytest -q -rs \
  -p no:cacheprovider --ignore=test_messages_without_core.py . >"$WORK/pytest.txt" 2>&1)
rc=$?
tail -5 "$WORK/pytest.txt"
check "the Python module's tests pass on the build without ROS" [ "$rc" = 0 ]

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
