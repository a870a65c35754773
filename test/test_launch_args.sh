#!/usr/bin/env bash
# launch/robot.launch's arguments, parsed by roslaunch (no master, no node started, rviz not needed):
#   - by default: the manager and the Estimator, no rviz, odometry/filtered not remapped;
#   - output:=/odometry/filtered remaps the Estimator's odometry/filtered (roslaunch --args);
#   - rviz:=true adds an rviz node in the Estimator's namespace with config/robot.rviz and the fixed
#     frame (roslaunch --nodes; its arguments and remaps through roslaunch's own loader, which
#     --args would need the rviz package installed for);
#   - config/robot.rviz shows odometry/filtered with its covariance, odometry/gps and the tf tree, by
#     relative topics (rviz runs in the Estimator's namespace).
#   usage: test_launch_args.sh REPO_ROOT DEVEL_SETUP
set -uo pipefail

: "${2:?usage: test_launch_args.sh REPO_ROOT DEVEL_SETUP}"
ROOT=$(cd "$1" && pwd) WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_launch_args.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
# shellcheck disable=SC1090
set +u  # ROS's setup scripts read unset variables
source "$2"
set -u
source "$(dirname "${BASH_SOURCE[0]}")/check_lib.sh"
LAUNCH=$ROOT/launch/robot.launch

run_rc rc roslaunch --nodes "$LAUNCH"
cp "$WORK/out.txt" "$WORK/nodes_default.txt"
check "default: roslaunch --nodes parses robot.launch" [ "$rc" = 0 ]
check "default: the manager and the Estimator" \
  bash -c 'grep -qx /robot_estimator_manager "$1" && grep -qx /robot_estimator/estimator "$1"' _ "$WORK/nodes_default.txt"
check "default: no rviz" bash -c '! grep -q rviz "$1"' _ "$WORK/nodes_default.txt"
run_rc rc roslaunch --args /robot_estimator/estimator "$LAUNCH"
check "default: odometry/filtered not remapped" bash -c '[ "$0" = 0 ] && grep -q "nodelet load networked_estimation/Estimator" "$1" && ! grep -q "odometry/filtered:=" "$1"' "$rc" "$WORK/out.txt"

run_rc rc roslaunch --args /robot_estimator/estimator "$LAUNCH" output:=/odometry/filtered
check "output:=/odometry/filtered remaps the Estimator's output" \
  bash -c '[ "$0" = 0 ] && grep -q "odometry/filtered:=/odometry/filtered" "$1"' "$rc" "$WORK/out.txt"

run_rc rc roslaunch --nodes "$LAUNCH" rviz:=true
check "rviz:=true: an rviz node in the Estimator's namespace" \
  bash -c '[ "$0" = 0 ] && grep -qx /robot_estimator/rviz "$1" && grep -qx /robot_estimator/estimator "$1"' "$rc" "$WORK/out.txt"
run_rc rc roslaunch --nodes "$LAUNCH" rviz:=maybe
check "rviz:=maybe: refused by roslaunch" bash -c '[ "$0" != 0 ]' "$rc"

rviz_node() {  # ARG...: the rviz node's package, type, arguments and remaps, as roslaunch loads them
  python3 - "$LAUNCH" "$@" <<'PY'
import sys
import roslaunch.config
launch, args = sys.argv[1], sys.argv[2:]
config = roslaunch.config.load_config_default([(launch, args)], None, verbose=False)
nodes = [n for n in config.nodes if n.name == "rviz"]
if len(nodes) != 1:
    sys.exit("expected one rviz node, found %d" % len(nodes))
n = nodes[0]
print("package %s type %s namespace %s" % (n.package, n.type, n.namespace))
print("args %s" % n.args)
for a, b in n.remap_args:
    print("remap %s %s" % (a, b))
PY
}
run_rc rc rviz_node rviz:=true
check "rviz:=true: rviz/rviz with config/robot.rviz and fixed frame odom, no remap" \
  bash -c '[ "$0" = 0 ] && grep -qx "package rviz type rviz namespace /robot_estimator/" "$1" &&
           grep -qE "^args -d .*/config/robot.rviz -f odom$" "$1" && ! grep -q "^remap" "$1"' "$rc" "$WORK/out.txt"
run_rc rc rviz_node rviz:=true output:=/odometry/filtered fixed_frame:=map name:=rover
check "rviz with output:= and fixed_frame:=: shows the remapped topic in that frame" \
  bash -c '[ "$0" = 0 ] && grep -qx "package rviz type rviz namespace /rover/" "$1" &&
           grep -qE "^args -d .*/config/robot.rviz -f map$" "$1" &&
           grep -qx "remap odometry/filtered /odometry/filtered" "$1"' "$rc" "$WORK/out.txt"

rviz_config() {
  python3 - "$ROOT/config/robot.rviz" <<'PY'
import sys, yaml
d = yaml.safe_load(open(sys.argv[1]))["Visualization Manager"]["Displays"]
by_topic = {x.get("Topic"): x for x in d if "Topic" in x}
bad = []
f = by_topic.get("odometry/filtered")
if not f or f["Class"] != "rviz/Odometry" or not f["Covariance"]["Value"] or not f["Covariance"]["Position"]["Value"]:
    bad.append("odometry/filtered: expected an rviz/Odometry display with its covariance")
g = by_topic.get("odometry/gps")
if not g or g["Class"] != "rviz/Odometry":
    bad.append("odometry/gps: expected an rviz/Odometry display")
if not any(x["Class"] == "rviz/TF" and x["Enabled"] for x in d):
    bad.append("no enabled rviz/TF display")
if any(t.startswith("/") for t in by_topic):
    bad.append("absolute topics: %s" % [t for t in by_topic if t.startswith("/")])
print("\n".join(bad))
sys.exit(1 if bad else 0)
PY
}
check "config/robot.rviz: odometry/filtered with covariance, odometry/gps, the tf tree, relative topics" rviz_config

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
