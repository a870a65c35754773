# Shared by the benchmark scripts (sourced after workspace.sh): the built workspace's environment, a free
# port for a private master, stopping a roslaunch cleanly, a process's CPU time, a private roscore
# and a process stopped by its PID, and a /clock that runs on after a bag.
if [ ! -f "$WS/devel/setup.bash" ]; then
  echo "no build in $WS: run scripts/build.sh first" >&2
  exit 1
fi
set +u
source "$WS/devel/setup.bash"
set -u
free_port()
{
  python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])'
}

# Stops one roslaunch started by run: SIGINT (it stops its nodes, then its master), then SIGTERM.
stop_launch()
{
  local pid="$1" i
  kill -INT "$pid" 2>/dev/null || true
  for i in $(seq 1 100); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.2
  done
  if kill -0 "$pid" 2>/dev/null; then
    echo "  roslaunch $pid still running 20 s after SIGINT: SIGTERM" >&2
    kill -TERM "$pid" 2>/dev/null || true
    sleep 5
    if kill -0 "$pid" 2>/dev/null; then
      echo "  roslaunch $pid: SIGKILL (its nodes may survive it)" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
  wait "$pid" 2>/dev/null || true
}


# CPU used so far by process $1, "ticks:ns": utime + stime from /proc/PID/stat (clock ticks, as
# `time` and top count them) and the nanoseconds on CPU of all its threads from
# /proc/PID/task/*/schedstat (exact, where ticks are sampled).
cpu()
{
  echo "$(awk '{ print $14 + $15 }' "/proc/$1/stat"):$(cat /proc/"$1"/task/*/schedstat | awk '{ s += $1 } END { printf "%d", s }')"
}

# Context switches so far of all threads of process $1 (voluntary and not): a thread's wake-up
# and sleep, the largest single cost of a message on a small VM.
switches()
{
  cat /proc/"$1"/task/*/status | awk '/^(non)?voluntary_ctxt_switches/ { s += $2 } END { printf "%d", s }'
}

# Stops one process started by the calling script, by its PID: SIGINT, then SIGKILL after 5 s.
stop_pid()
{
  local pid="$1" i
  kill -INT "$pid" 2>/dev/null || true
  for i in $(seq 1 50); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  kill -KILL "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
}

# Starts a private roscore on a free port, logging to $1; exports ROS_MASTER_URI and sets
# MASTER_PID. Returns 1 when none came up after three tries.
start_master()
{
  local log="$1" try i
  MASTER_PID=""
  for try in 1 2 3; do
    export ROS_MASTER_URI="http://localhost:$(free_port)"
    roscore -p "${ROS_MASTER_URI##*:}" > "$log" 2>&1 < /dev/null &
    MASTER_PID=$!
    for i in $(seq 1 60); do
      kill -0 "$MASTER_PID" 2>/dev/null || break
      rosparam list > /dev/null 2>&1 && return 0
      sleep 0.5
    done
    stop_pid "$MASTER_PID"
    MASTER_PID=""
  done
  return 1
}

# Publishes /clock from sim time $1 (s) at $2 times real time, $4 (default 100) times a wall second,
# for $3 wall seconds: a clock that keeps running after a bag's playback has ended.
sim_clock()
{
  python3 - "$1" "$2" "$3" "${4:-100}" <<'PY'
import sys, time
import rospy
from rosgraph_msgs.msg import Clock
start, rate, seconds, hz = (float(v) for v in sys.argv[1:5])
rospy.init_node("bench_clock", anonymous=True, disable_signals=True)
pub = rospy.Publisher("/clock", Clock, queue_size=10)
t0 = time.monotonic()
while True:
    elapsed = time.monotonic() - t0
    if elapsed > seconds:
        break
    pub.publish(Clock(clock=rospy.Time.from_sec(start + rate * elapsed)))
    time.sleep(1.0 / hz)
PY
}
