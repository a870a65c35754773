#!/usr/bin/env bash
# The package as a ROS user gets it, without compiling it a second time:
#  1. a copy of the repository's tracked files in a fresh catkin workspace configures with
#     catkin_make (testing off), generates its messages and settings headers, and every translation
#     unit's includes resolve there (the compiler's preprocessor on each unit, with the copy's own
#     compile commands): nothing the build needs is missing from a clone;
#  2. the workspace that ran this test (it compiled the same sources with the same flags) installs
#     into its install space (what `catkin_make install` does after its build);
#  3. with only that install space sourced, the package is found by rospack, its tools run through
#     rosrun (without "File system loop" warnings), its Python module imports and runs, its nodelets are exported, every launch file of
#     the repository is installed and resolves, the demo graph runs to its summary, and a small
#     package of its own workspace compiles and links against the installed headers and libraries
#     and runs an estimator.
# Also checks that rosrun prints no "File system loop" warning with the repository's own workspace
# (DEVEL_SETUP).
# Usage: test_workspace.sh REPO_ROOT BUILD_DIR [DEVEL_SETUP]      Prints "N passed, M failed".
# BUILD_DIR is the catkin workspace's build folder; its install prefix must be the workspace's own
# install space (catkin_make's default, <workspace>/install).
set -uo pipefail
ROOT="$(dirname "$(readlink -f "$1/CMakeLists.txt")")"
BUILD="$(readlink -f "$2")"
DEVEL_SETUP="${3:+$(readlink -f "$3")}"
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
JOBS="${NE_JOBS:-2}"

# The install space of the workspace that built the package.
PREFIX="$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "$BUILD/CMakeCache.txt" 2>/dev/null)"
if [ -z "$PREFIX" ]; then
  echo "FAIL: $BUILD/CMakeCache.txt not found or names no CMAKE_INSTALL_PREFIX (BUILD_DIR must be a configured catkin build folder)"
  echo "0 passed, 1 failed"; exit 1
fi
if [ "$(readlink -f "$PREFIX")" != "$(readlink -f "$(dirname "$BUILD")")/install" ]; then
  echo "FAIL: the build's install prefix is $PREFIX, not its workspace's own install space" \
       "$(dirname "$BUILD")/install: this test installs only there (configure without CMAKE_INSTALL_PREFIX)"
  echo "0 passed, 1 failed"; exit 1
fi

# 1. The package's files, as a clone has them (tracked files; uncommitted edits included).
mkdir -p "$WORK/ws/src/networked_estimation"
if git -C "$ROOT" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  (cd "$ROOT" && git ls-files -z | xargs -0 tar cf - 2>/dev/null) | tar xf - -C "$WORK/ws/src/networked_estimation"
else
  (cd "$ROOT" && tar cf - --exclude=./.ws --exclude=./.git .) | tar xf - -C "$WORK/ws/src/networked_estimation"
fi

# A clean environment: nothing of the repository's own workspace, ROS's files inside $WORK.
unset ROS_PACKAGE_PATH CMAKE_PREFIX_PATH LD_LIBRARY_PATH PKG_CONFIG_PATH PYTHONPATH ROS_ROOT ROS_DISTRO ROS_ETC_DIR
export ROS_HOME="$WORK/ros_home" ROS_LOG_DIR="$WORK/ros_home/log"
cd "$WORK/ws"
check "catkin_make configures a fresh workspace and generates the messages and settings headers" \
  catkin_make -j"$JOBS" -DCATKIN_ENABLE_TESTING=OFF -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
  networked_estimation_generate_messages_cpp networked_estimation_gencfg
# Each unit's own compile command, preprocessing only (-E): a header missing from the clone fails it.
includes_resolve() {
  python3 - "$WORK/ws/build/compile_commands.json" "$WORK/ws/src/networked_estimation" > "$WORK/pp_commands" <<'PY' || return 1
import json, shlex, sys
db, pkg = sys.argv[1:3]
entries = [e for e in json.load(open(db)) if e["file"].startswith(pkg + "/")]
if len(entries) < 10:
    sys.exit("only %d of the package's translation units in %s" % (len(entries), db))
for e in entries:
    args = e["arguments"] if "arguments" in e else shlex.split(e["command"])
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a == "-o":
            skip = True
        elif a != "-c":
            out.append(a)
    print(json.dumps({"dir": e["directory"], "cmd": out + ["-E", "-o", "/dev/null"]}))
PY
  echo "$(wc -l < "$WORK/pp_commands") translation units"
  tr '\n' '\0' < "$WORK/pp_commands" | xargs -0 -n1 -P"$JOBS" python3 -c '
import json, subprocess, sys
e = json.loads(sys.argv[1])
r = subprocess.run(e["cmd"], cwd=e["dir"], capture_output=True, text=True)
if r.returncode != 0:
    print("\n".join(r.stderr.splitlines()[:10]))
    sys.exit(1)
'
}
check "every translation unit's includes resolve in the fresh workspace" includes_resolve

# 2. The workspace that ran this test installs into its own install space.
INSTALL="$PREFIX"
check "the built workspace installs (cmake --install)" cmake --install "$BUILD"
if [ ! -f "$INSTALL/setup.bash" ]; then
  echo "FAIL: no install space at $INSTALL"; echo "$passed passed, $((failed + 1)) failed"; exit 1
fi

# 3. Only the install space from here on (a subshell with its setup sourced).
run_installed() {
  bash -c 'set +u; source "$0/setup.bash"; set -u; "$@"' "$INSTALL" "$@"
}
share="$INSTALL/share/networked_estimation"
check "the install space stands alone (its setup chains to neither the build's devel space nor its sources)" \
  bash -c 'source "$0/setup.bash"; ws="$1"
           for v in "CMAKE_PREFIX_PATH=$CMAKE_PREFIX_PATH" "ROS_PACKAGE_PATH=$ROS_PACKAGE_PATH"; do
             case ":${v#*=}:" in *":$ws/devel"[:/]*|*":$ws/src"[:/]*) echo "$v names the build workspace $ws"; exit 1 ;; esac
           done' "$INSTALL" "$(dirname "$BUILD")"
check "rospack finds the installed package" bash -c '[ "$(bash -c "source $0/setup.bash; rospack find networked_estimation")" = "$1" ]' "$INSTALL" "$share"
check "rosrun runs an installed tool (analyze) without find warnings" \
  no_loop run_installed rosrun networked_estimation analyze --model "$share/config/models/zhou_example.yaml" --channel "$share/config/channels/bernoulli_0.2.yaml"
check "the Python module imports from the install space and runs an estimator, next to the messages" \
  run_installed python3 -c 'import sys, networked_estimation as ne, networked_estimation.msg as msg
m = ne.Model.from_yaml(sys.argv[1])
sim = ne.simulate(m, ne.Bernoulli(0.2), steps=50, seed=1)
x, P, trace = ne.make_estimator(m, "kfio").run(sim["y"], sim["gamma"])
assert x.shape == (50, m.n) and "/install/" in ne._core.__file__ and msg.Estimate, ne._core.__file__' \
  "$share/config/models/zhou_example.yaml"
check "the nodelet plugins are exported" bash -c 'source "$0/setup.bash"; rospack plugins --attrib=plugin nodelet | grep -q "networked_estimation .*$0/share/networked_estimation/nodelet_plugins.xml"' "$INSTALL"
check "every launch file is installed and resolves (roslaunch --files)" bash -c 'source "$0/setup.bash"; share="$0/share/networked_estimation"
  for f in $(cd "$1/launch" && ls); do
    [ -f "$share/launch/$f" ] || { echo "$f: not installed"; exit 1; }
    case "$f" in
      estimator.launch) args=(model:="$share/config/models/zhou_example.yaml") ;;
      lossy_channel.launch) args=(in:=/imu out:=/imu_lossy) ;;
      peer_bag_test.launch) args=(bag:=/any.bag params:="$share/config/peer_tests/jackal_bag2.yaml") ;;
      *) args=() ;;
    esac
    roslaunch --files networked_estimation "$f" "${args[@]}" > /dev/null || { echo "$f"; exit 1; }
  done' "$INSTALL" "$WORK/ws/src/networked_estimation"
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
check "the installed demo graph runs to its summary" \
  bash -c 'source "$0/setup.bash"; export ROS_MASTER_URI=http://localhost:$1 ROS_HOSTNAME=localhost;
           timeout 120 roslaunch -p "$1" networked_estimation demo.launch duration:=3 summary_text:="$2/summary.txt" > "$2/demo.log" 2>&1;
           grep -q kfio "$2/summary.txt" && grep -q aoe "$2/summary.txt" || { tail -20 "$2/demo.log"; exit 1; }' "$INSTALL" "$port" "$WORK"

# A user's package built against the install space: the exported include folders (the package's,
# Eigen's, yaml-cpp's) and libraries, found through find_package(catkin COMPONENTS ...).
consumer="$WORK/consumer_ws/src/ne_consumer"
mkdir -p "$consumer"
cat > "$consumer/package.xml" <<'EOF'
<?xml version="1.0"?>
<package format="3">
  <name>ne_consumer</name>
  <version>0.0.1</version>
  <description>Uses networked_estimation from its install space (test_workspace.sh).</description>
  <maintainer email="nobody@example.com">nobody</maintainer>
  <license>BSD</license>
  <buildtool_depend>catkin</buildtool_depend>
  <depend>networked_estimation</depend>
</package>
EOF
cat > "$consumer/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.10)
project(ne_consumer)
set(CMAKE_CXX_STANDARD 17)
find_package(catkin REQUIRED COMPONENTS networked_estimation)
catkin_package()
include_directories(${catkin_INCLUDE_DIRS})
add_executable(ne_consumer main.cpp)
target_link_libraries(ne_consumer ${catkin_LIBRARIES})
EOF
cat > "$consumer/main.cpp" <<'EOF'
// Loads a model and estimator settings, steps the estimator over a few samples, prints the trace
// of its covariance: it must be finite and positive.
#include <networked_estimation/config/estimator_settings.hpp>
#include <networked_estimation/config/model.hpp>
#include <networked_estimation/estimators/estimator.hpp>

#include <cmath>
#include <iostream>

int main(int argc, char** argv)
{
  using namespace networked_estimation;
  if (argc != 3)
    return 2;
  const Model model = loadModel(argv[1]);
  std::unique_ptr<Estimator> est = makeEstimator(model, loadEstimatorSettings(argv[2]));
  Sample s;
  s.y = Eigen::VectorXd::Ones(model.m());
  for (int k = 0; k < 10; ++k)
    est->step(s);
  const double tr = est->covariance().trace();
  std::cout << est->implementation() << " trace " << tr << "\n";
  return std::isfinite(tr) && tr > 0.0 ? 0 : 1;
}
EOF
check "a package of another workspace compiles and links against the install space" \
  bash -c 'source "$0/setup.bash"; cd "$1/consumer_ws" && catkin_make -j"$2" -DCMAKE_BUILD_TYPE=Release' "$INSTALL" "$WORK" "$JOBS"
check "and its program runs an installed estimator" \
  bash -c 'source "$1/consumer_ws/devel/setup.bash"; share="$0/share/networked_estimation";
           rosrun ne_consumer ne_consumer "$share/config/models/zhou_example.yaml" "$share/config/estimators/kfio.yaml"' "$INSTALL" "$WORK"

if [ -n "$DEVEL_SETUP" ]; then
  check "rosrun in the repository's own workspace prints no find warnings" \
    no_loop bash -c 'source "$0"; rosrun networked_estimation analyze --model "$1/config/models/zhou_example.yaml"' "$DEVEL_SETUP" "$ROOT"
fi
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
