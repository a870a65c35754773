# The robot demo across a real kernel link (sourced by test/test_real_link.sh and
# scripts/bench_real_link.sh, after the workspace's devel/setup.bash): two network namespaces of
# the run's own joined by a veth pair, the robot (roscore, the PlantSimulator, the recorder of
# scripts/real_link.py: scripts/real_link_robot.launch) in one and the base station (the Estimator
# over tcp and the Estimator over udp: scripts/real_link_base.launch) in the other, and
# `real_link.py drive` in the base station setting nftables' drop rules phase by phase (its PLAN).
#
# The addresses exist only inside the two namespaces (a /30 on the veth pair, nothing in the
# machine's own namespace), and so does every packet of the run. Needs root, iproute2 (`ip`) and
# nftables (`nft`); real_link_unavailable says why a machine cannot run it.
#
#   real_link_unavailable            prints the reason the run cannot be made here (nothing: it can)
#   real_link_run WORK PLAN          one run into WORK (logs, the recorder's files, phases.json);
#                                    returns the driver's status. Call real_link_cleanup from an
#                                    EXIT trap: it stops every process the run started, by its PID
#                                    (and any left in the namespaces), and deletes the namespaces.

REAL_LINK_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REAL_LINK_ROBOT_IP=10.213.36.1
REAL_LINK_BASE_IP=10.213.36.2
REAL_LINK_MASTER_PORT=11311
REAL_LINK_TCPROS_PORT=11411   # the robot manager's TCPROS server port (the drop rules name it)
REAL_LINK_PIDS=()
REAL_LINK_NS=()

real_link_unavailable()
{
  if [ "$(id -u)" -ne 0 ]; then
    echo "not root: network namespaces and nftables need root"
    return 0
  fi
  if ! command -v ip > /dev/null; then
    echo "no 'ip' (iproute2)"
    return 0
  fi
  if ! command -v nft > /dev/null; then
    echo "no 'nft' (nftables; scripts/install_deps.sh --tests installs it)"
    return 0
  fi
  local probe="ne_rl_probe_$$" why=""
  if ! ip netns add "$probe" 2> /dev/null; then
    echo "cannot create a network namespace ('ip netns add' failed: no CAP_SYS_ADMIN, or a container without them)"
    return 0
  fi
  if ! ip -n "$probe" link add rlp0 type veth peer name rlp1 2> /dev/null; then
    why="cannot create a veth pair in a network namespace (no veth support)"
  elif ! ip netns exec "$probe" nft add table inet ne_probe 2> /dev/null; then
    why="nftables does not work in a network namespace (no nf_tables support)"
  fi
  ip netns del "$probe" 2> /dev/null
  [ -z "$why" ] || echo "$why"
  return 0
}

# Starts a command in namespace $1 with the ROS environment of address $2, output into $3.
real_link_start()
{
  local ns="$1" ip_addr="$2" log="$3"
  shift 3
  ip netns exec "$ns" env -u ROS_HOSTNAME ROS_MASTER_URI="http://$REAL_LINK_ROBOT_IP:$REAL_LINK_MASTER_PORT" ROS_IP="$ip_addr" \
    "$@" > "$log" 2>&1 < /dev/null &
  REAL_LINK_PIDS+=($!)
}

# Stops one process by its PID: SIGINT (roslaunch then stops its nodes), SIGTERM after 20 s,
# SIGKILL after 5 more.
real_link_stop()
{
  local pid="$1" i
  kill -INT "$pid" 2> /dev/null || return 0
  for i in $(seq 1 200); do
    kill -0 "$pid" 2> /dev/null || break
    sleep 0.1
  done
  if kill -0 "$pid" 2> /dev/null; then
    kill -TERM "$pid" 2> /dev/null
    sleep 5
    kill -KILL "$pid" 2> /dev/null
  fi
  wait "$pid" 2> /dev/null
  return 0
}

real_link_cleanup()
{
  local i pid ns
  for ((i = ${#REAL_LINK_PIDS[@]} - 1; i >= 0; i--)); do
    real_link_stop "${REAL_LINK_PIDS[$i]}"
  done
  REAL_LINK_PIDS=()
  for ns in "${REAL_LINK_NS[@]}"; do
    # Anything of the run still in its namespace (a node its roslaunch did not take down).
    for pid in $(ip netns pids "$ns" 2> /dev/null); do
      kill -KILL "$pid" 2> /dev/null
    done
    ip netns del "$ns" 2> /dev/null
  done
  REAL_LINK_NS=()
  return 0
}

real_link_run()
{
  local work="$1" plan="$2" duration robot base rc
  mkdir -p "$work"
  rm -rf "$work"/log "$work"/*.csv "$work"/*.jsonl "$work"/*.bag "$work"/phases.json "$work"/recorder_ready
  mkdir -p "$work/log"
  export ROS_LOG_DIR="$work/log" ROS_HOME="$work/log"
  duration="$(python3 "$REAL_LINK_DIR/real_link.py" duration "$plan")" || return 1
  robot="ne_rl_robot_$$"
  base="ne_rl_base_$$"
  ip netns add "$robot" || return 1
  REAL_LINK_NS+=("$robot")
  ip netns add "$base" || return 1
  REAL_LINK_NS+=("$base")
  ip -n "$robot" link add rl0 type veth peer name rl1 netns "$base" || return 1
  ip -n "$robot" addr add "$REAL_LINK_ROBOT_IP/30" dev rl0 || return 1
  ip -n "$base" addr add "$REAL_LINK_BASE_IP/30" dev rl1 || return 1
  for ns in "$robot" "$base"; do
    ip -n "$ns" link set lo up || return 1
  done
  ip -n "$robot" link set rl0 up || return 1
  ip -n "$base" link set rl1 up || return 1
  echo "real_link: namespaces $robot ($REAL_LINK_ROBOT_IP) and $base ($REAL_LINK_BASE_IP), plant ${duration} s"
  real_link_start "$robot" "$REAL_LINK_ROBOT_IP" "$work/log/robot.log" roslaunch -p "$REAL_LINK_MASTER_PORT" \
    --sigint-timeout=5 --sigterm-timeout=2 "$REAL_LINK_DIR/real_link_robot.launch" duration:="$duration" \
    work:="$work" tcpros_port:="$REAL_LINK_TCPROS_PORT"
  real_link_start "$base" "$REAL_LINK_BASE_IP" "$work/log/base.log" roslaunch --wait \
    --sigint-timeout=5 --sigterm-timeout=2 "$REAL_LINK_DIR/real_link_base.launch"
  # The driver in the foreground (its own PID too, for the trap).
  real_link_start "$base" "$REAL_LINK_BASE_IP" "$work/log/driver.log" python3 "$REAL_LINK_DIR/real_link.py" \
    drive "$work" "$plan"
  local driver="${REAL_LINK_PIDS[-1]}"
  tail -f "$work/log/driver.log" --pid="$driver" 2> /dev/null &
  local tailer=$!
  wait "$driver"
  rc=$?
  wait "$tailer" 2> /dev/null
  # The robot side last (its master): the base station's nodes first, then the recorder's files close.
  real_link_cleanup
  return "$rc"
}
