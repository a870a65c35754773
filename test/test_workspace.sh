#!/usr/bin/env bash
# The package as a ROS user gets it: placed in a fresh catkin workspace of its own (a copy of the
# repository's files), built with catkin_make and installed with `catkin_make install`. Then, with
# only the install space sourced, it must be found by rospack, its tools run through rosrun (without
# "File system loop" warnings), its launch files resolve, and the demo graph runs to its summary.
# Also checks that rosrun prints no such warning with the repository's own workspace (DEVEL_SETUP).
# Usage: test_workspace.sh REPO_ROOT [DEVEL_SETUP]      Prints "N passed, M failed".
set -uo pipefail
ROOT="$(dirname "$(readlink -f "$1/CMakeLists.txt")")"
DEVEL_SETUP="${2:+$(readlink -f "$2")}"
WORK="$(mktemp -d "${TMPDIR:-/tmp}/ne_ws.XXXXXX")"
trap 'rm -rf "$WORK"' EXIT
passed=0 failed=0
check() {  # description, then a command that must succeed
  local what="$1"
  shift
  if "$@" > "$WORK/out" 2>&1; then passed=$((passed + 1)); echo "ok: $what"
  else failed=$((failed + 1)); echo "FAIL: $what"; tail -n 30 "$WORK/out"; fi
}
no_loop() {  # the command's output must not mention a file system loop
  "$@" > "$WORK/loop" 2>&1 || { cat "$WORK/loop"; return 1; }
  ! grep -q "File system loop" "$WORK/loop" || { grep "File system loop" "$WORK/loop" | head -3; return 1; }
}

# The package's files, as a clone has them (tracked files; uncommitted edits included).
mkdir -p "$WORK/ws/src/networked_estimation"
if git -C "$ROOT" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  (cd "$ROOT" && git ls-files -z | xargs -0 tar cf - 2>/dev/null) | tar xf - -C "$WORK/ws/src/networked_estimation"
else
  (cd "$ROOT" && tar cf - --exclude=./.ws --exclude=./.git .) | tar xf - -C "$WORK/ws/src/networked_estimation"
fi

# A clean environment: nothing of the repository's own workspace, ROS's files inside $WORK.
unset ROS_PACKAGE_PATH CMAKE_PREFIX_PATH LD_LIBRARY_PATH PKG_CONFIG_PATH PYTHONPATH ROS_ROOT ROS_DISTRO ROS_ETC_DIR
export ROS_HOME="$WORK/ros_home" ROS_LOG_DIR="$WORK/ros_home/log"
JOBS="${NE_JOBS:-2}"
cd "$WORK/ws"
check "catkin_make in a fresh workspace" catkin_make -j"$JOBS" -DCATKIN_ENABLE_TESTING=OFF -DCMAKE_BUILD_TYPE=Release
check "catkin_make install" catkin_make -j"$JOBS" install -DCATKIN_ENABLE_TESTING=OFF
if [ ! -f "$WORK/ws/install/setup.bash" ]; then
  echo "FAIL: no install space"; echo "$passed passed, $((failed + 1)) failed"; exit 1
fi

# Only the install space from here on (a subshell with its setup sourced).
run_installed() {
  bash -c 'set +u; source "$0/ws/install/setup.bash"; set -u; "$@"' "$WORK" "$@"
}
check "rospack finds the installed package" bash -c '[ "$(bash -c "source $0/ws/install/setup.bash; rospack find networked_estimation")" = "$0/ws/install/share/networked_estimation" ]' "$WORK"
share="$WORK/ws/install/share/networked_estimation"
check "rosrun runs an installed tool (analyze) without find warnings" \
  no_loop run_installed rosrun networked_estimation analyze --model "$share/config/models/zhou_example.yaml" --channel "$share/config/channels/bernoulli_0.2.yaml"
check "the nodelet plugins are exported" bash -c 'source "$0/ws/install/setup.bash"; rospack plugins --attrib=plugin nodelet | grep -q "networked_estimation .*install/share/networked_estimation/nodelet_plugins.xml"' "$WORK"
check "every launch file resolves (roslaunch --files)" bash -c 'source "$0/ws/install/setup.bash"; share="$0/ws/install/share/networked_estimation"
  for f in $(ls "$share/launch"); do
    case "$f" in
      estimator.launch) args=(model:="$share/config/models/zhou_example.yaml") ;;
      lossy_channel.launch) args=(in:=/imu out:=/imu_lossy) ;;
      *) args=() ;;
    esac
    roslaunch --files networked_estimation "$f" "${args[@]}" > /dev/null || { echo "$f"; exit 1; }
  done' "$WORK"
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
check "the installed demo graph runs to its summary" \
  bash -c 'source "$0/ws/install/setup.bash"; export ROS_MASTER_URI=http://localhost:$1 ROS_HOSTNAME=localhost;
           timeout 120 roslaunch -p "$1" networked_estimation demo.launch duration:=3 summary_text:="$0/summary.txt" > "$0/demo.log" 2>&1;
           grep -q kfio "$0/summary.txt" && grep -q aoe "$0/summary.txt" || { tail -20 "$0/demo.log"; exit 1; }' "$WORK" "$port"

if [ -n "$DEVEL_SETUP" ]; then
  check "rosrun in the repository's own workspace prints no find warnings" \
    no_loop bash -c 'source "$0"; rosrun networked_estimation analyze --model "$1/config/models/zhou_example.yaml"' "$DEVEL_SETUP" "$ROOT"
fi
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
