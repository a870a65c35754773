#!/usr/bin/env bash
# The Estimator across a real lossy network (docs/ros_interface.md, "Transport per input"): the
# robot demo split over two network namespaces of the test's own joined by a veth pair
# (scripts/real_link_lib.sh), the robot (roscore, the PlantSimulator publishing /odom 50 Hz,
# /imu/data 10 Hz, /fix 5 Hz) in one, the base station in the other: an Estimator reading the
# sensors straight off the link over tcp and one over udp (latency_budget: auto), each in its own
# process. nftables in the base station drops the robot's data packets at random (`numgen random
# mod 100 < N`: 0, 5, 10 and 20 %), then in bursts: a helper thread of the driver switches the
# drop rule along a Gilbert-Elliott chain (p = 0.02, r = 0.1 per 20 ms step, the plant's: seeded,
# its switches half a step away from the samples). The bursty phase is also recorded at the base
# station over udp (rosbag record --udp) into WORK/bursty.bag, with the chain the toggler drew in
# WORK/toggler.csv: fit_link fits the link from that bag and a trace channel replays it.
#
# test/real_link_check.py asserts, per phase: over udp each sensor's arrival rate agrees with the
# delivered fraction of the kernel's counters, the latency budget stays under 50 ms, the squared
# error agrees with montecarlo's prediction for the link the kernel made and the live link
# verdict's (p, r) with the drops (random phases) and, in the bursty phase, the live (p, r) with
# the toggler's chain; over tcp nothing is lost and the budget adapts. Over the whole run: tcp
# received every message sent, udp exactly what the kernel let through. On the bursty phase's bag:
# fit_link's expected messages are those the robot sent, received or lost as the toggler's chain
# said, its Gilbert p and r are the drawn chain's and hold the toggler's, and a trace channel of
# the bag replays the base station's arrivals.
#
# Usage: test_real_link.sh SETUP_BASH SOURCE_DIR WORK_DIR TOOLS_DIR
# Needs root, iproute2 and nftables: where a network namespace cannot be made (not root, a container
# without CAP_SYS_ADMIN, no nftables) the test is SKIPPED, says why, and passes (ctest shows it as
# skipped); with NE_REQUIRE_REAL_LINK=1 a skip is a failure. About 3 minutes of wall time.
set -uo pipefail
setup="$1" src="$2" work="$3" tools="$4"
source "$src/scripts/env.sh"   # Debian's python3 (ROS's modules), not a pyenv interpreter
set +u
source "$setup"
set -u
source "$src/scripts/real_link_lib.sh"

why="$(real_link_unavailable)"
if [ -n "$why" ]; then
  echo "real_link: SKIPPED: $why"
  if [ "${NE_REQUIRE_REAL_LINK:-0}" = 1 ]; then
    echo "real_link: FAIL: NE_REQUIRE_REAL_LINK=1 but the test was skipped"
    exit 1
  fi
  exit 0
fi
trap real_link_cleanup EXIT
start=$SECONDS
mkdir -p "$work"
plan="$work/plan.json"
cat > "$plan" <<EOF
{
  "robot_ip": "$REAL_LINK_ROBOT_IP", "base_ip": "$REAL_LINK_BASE_IP", "tcpros_port": $REAL_LINK_TCPROS_PORT,
  "warmup": 6, "settle": 4, "tail": 8,
  "phases": [
    {"name": "random_0", "kind": "random", "percent": 0, "seconds": 20},
    {"name": "random_5", "kind": "random", "percent": 5, "seconds": 20},
    {"name": "random_10", "kind": "random", "percent": 10, "seconds": 20},
    {"name": "random_20", "kind": "random", "percent": 20, "seconds": 20},
    {"name": "bursty", "kind": "bursty", "p": 0.02, "r": 0.1, "period": 0.02, "seed": 36, "seconds": 32,
     "record": true}
  ]
}
EOF
if ! real_link_run "$work" "$plan"; then
  echo "real_link: FAIL: the run did not complete (logs in $work/log)"
  exit 1
fi
python3 "$src/scripts/real_link.py" table "$work" "$work/table.csv"
python3 "$src/test/real_link_check.py" "$work" "$src" "$tools"
rc=$?
echo "real_link: $((SECONDS - start)) s of wall time"
exit "$rc"
