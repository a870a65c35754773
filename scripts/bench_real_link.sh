#!/usr/bin/env bash
# The Estimator across a real lossy link, over tcp and over udp (docs/ros_interface.md, "Transport
# per input"; docs/architecture.md holds the latest run): the robot demo split over two network
# namespaces joined by a veth pair (scripts/real_link_lib.sh: the robot's PlantSimulator publishing
# /odom 50 Hz, /imu/data 10 Hz, /fix 5 Hz; at the base station one Estimator over tcp and one over
# udp, each in its own process, latency_budget: auto), nftables dropping the robot's data packets
# at random (0, 5, 10, 20 %) and then in bursts (a Gilbert-Elliott chain per 20 ms step, p = 0.02,
# r = 0.1), NE_BENCH_REAL_LINK_SECONDS (default 30) per condition.
# Prints per condition and transport: the latency budget (its largest value), late-dropped inputs,
# the due arrival rate, each sensor's delay p99 (receipt - stamp, the Estimator's), how late the
# estimates left (stamp to their arrival at the robot, p50 / p99), the squared error against the
# plant's truth, and the CPU of the Estimator's process per input message received.
# Needs root, iproute2 and nftables (scripts/install_deps.sh --tests); builds nothing
# (scripts/build.sh first). Results: $WS/bench/real_link.csv, the run's files in $WS/bench/real_link/.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
source "$(dirname "${BASH_SOURCE[0]}")/bench_lib.sh"
source "$(dirname "${BASH_SOURCE[0]}")/real_link_lib.sh"

SECONDS_PER_CONDITION="${NE_BENCH_REAL_LINK_SECONDS:-30}"
[[ "$SECONDS_PER_CONDITION" =~ ^[1-9][0-9]*$ ]] ||
  { echo "bench_real_link: NE_BENCH_REAL_LINK_SECONDS takes a positive integer, found '$SECONDS_PER_CONDITION'" >&2; exit 2; }
why="$(real_link_unavailable)"
if [ -n "$why" ]; then
  echo "bench_real_link: cannot run here: $why" >&2
  exit 2
fi
OUT="$WS/bench"
WORK="$OUT/real_link"
mkdir -p "$WORK"
trap real_link_cleanup EXIT
s="$SECONDS_PER_CONDITION"
cat > "$WORK/plan.json" <<EOF
{
  "robot_ip": "$REAL_LINK_ROBOT_IP", "base_ip": "$REAL_LINK_BASE_IP", "tcpros_port": $REAL_LINK_TCPROS_PORT,
  "warmup": 6, "settle": 4, "tail": 4,
  "phases": [
    {"name": "random_0", "kind": "random", "percent": 0, "seconds": $s},
    {"name": "random_5", "kind": "random", "percent": 5, "seconds": $s},
    {"name": "random_10", "kind": "random", "percent": 10, "seconds": $s},
    {"name": "random_20", "kind": "random", "percent": 20, "seconds": $s},
    {"name": "bursty", "kind": "bursty", "p": 0.02, "r": 0.1, "period": 0.02, "seed": 36, "seconds": $s}
  ]
}
EOF
echo "bench_real_link: 5 conditions x $s s, tcp and udp side by side ($(nproc) cores)"
real_link_run "$WORK" "$WORK/plan.json"
python3 "$REPO/scripts/real_link.py" table "$WORK" "$OUT/real_link.csv"
echo "bench_real_link: $OUT/real_link.csv"
