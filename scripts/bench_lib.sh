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
# and sleep, the largest single cost of a message on a small VM. The sum of threads' column.
switches()
{
  threads "$1" | awk '{ s += $4 } END { printf "%d", s }'
}

# Each thread of process $1, a line each: "TID NAME CPU_NS SWITCHES WCHAN": its name (roscpp's
# threads carry the process's, the nodelets' own input threads their own: ne_dispatch), its
# nanoseconds on CPU so far (schedstat), its context switches so far (voluntary and not) and the
# kernel function it waits in now (roscpp's receive thread waits in do_epoll_wait). A thread that
# ends while it is read is left out.
threads()
{
  local t line
  for t in /proc/"$1"/task/*; do
    line="${t##*/} $(tr -c '[:alnum:]_\n-' '_' < "$t/comm" 2>/dev/null) $(cut -d' ' -f1 "$t/schedstat" 2>/dev/null)"
    line="$line $(awk '/^(non)?voluntary_ctxt_switches/ { s += $2 } END { print s }' "$t/status" 2>/dev/null)"
    line="$line $(cat "$t/wchan" 2>/dev/null)"
    [ "$(echo "$line" | wc -w)" -ge 4 ] && echo "$line"
  done
  return 0
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

# Idle after a bag ends (scripts/bench_robot.sh, part 4): the Estimator with the parameters $2 and
# BenchNullReceiver side by side in one master, each in its own process (nodelet standalone), on
# the odometry and IMU topics of $1 (robot_localization's Jackal bag). Per run of $3: $5 s of the
# bag at -r 4, then the CPU of both over $4 s while the clock stands still (the bag ended: no input,
# rosbag's /clock stopped with it), then over $4 s while a /clock runs on at 4x (sim_clock), no
# input. Logs in $6; rows appended to the CSV $7; prints each run, the medians and the ratios.
IDLE_PIDS=""
idle_cleanup()
{
  local p
  for p in $IDLE_PIDS; do stop_pid "$p"; done
  IDLE_PIDS=""
}
idle_after_bag()
{
  local bag="$1" params="$2" runs="$3" seconds="$4" play="$5" logs="$6" csv="$7"
  local odom=/jackal_velocity_controller/odom imu=/imu/data hz run est null i e0 e1 e2 e3 n0 n1 n2 n3
  local se0 se1 se2 se3 sn0 sn1 sn2 sn3 t0 t1 t2 t3 start clock_pid rows=""
  hz="$(getconf CLK_TCK)"
  start="$(python3 -c "import rosbag, sys; print(rosbag.Bag(sys.argv[1]).get_start_time())" "$bag")"
  for run in $(seq 1 "$runs"); do
    start_master "$logs/idle_roscore_$run.log" || { echo "  idle run $run: no roscore came up" >&2; return 1; }
    IDLE_PIDS="$MASTER_PID"
    rosparam set /use_sim_time true
    rosparam load "$params" /estimator
    rosparam set /null_receiver/topics "[$odom, $imu]"
    rosrun nodelet nodelet standalone networked_estimation/Estimator __name:=estimator \
      > "$logs/idle_estimator_$run.log" 2>&1 < /dev/null &
    est=$!
    rosrun nodelet nodelet standalone networked_estimation/BenchNullReceiver __name:=null_receiver \
      > "$logs/idle_null_$run.log" 2>&1 < /dev/null &
    null=$!
    IDLE_PIDS="$est $null $MASTER_PID"
    for i in $(seq 1 60); do
      rostopic info "$imu" 2>/dev/null | grep -q "/estimator " && rostopic info "$imu" 2>/dev/null | grep -q "/null_receiver " && break
      sleep 0.5
    done
    rosbag play -q --clock -r 4 -u "$play" "$bag" > "$logs/idle_play_$run.log" 2>&1 < /dev/null
    sleep 1
    e0="$(cpu "$est")"; n0="$(cpu "$null")"; se0="$(switches "$est")"; sn0="$(switches "$null")"; t0="$(date +%s.%N)"
    sleep "$seconds"
    e1="$(cpu "$est")"; n1="$(cpu "$null")"; se1="$(switches "$est")"; sn1="$(switches "$null")"; t1="$(date +%s.%N)"
    sim_clock "$(python3 -c "print($start + $play)")" 4 "$((seconds + 3))" > "$logs/idle_clock_$run.log" 2>&1 &
    clock_pid=$!
    IDLE_PIDS="$clock_pid $IDLE_PIDS"
    sleep 1.5
    e2="$(cpu "$est")"; n2="$(cpu "$null")"; se2="$(switches "$est")"; sn2="$(switches "$null")"; t2="$(date +%s.%N)"
    sleep "$seconds"
    e3="$(cpu "$est")"; n3="$(cpu "$null")"; se3="$(switches "$est")"; sn3="$(switches "$null")"; t3="$(date +%s.%N)"
    wait "$clock_pid" || true
    idle_cleanup
    rows="$rows $run:$e0:$e1:$n0:$n1:$se0:$se1:$sn0:$sn1:$t0:$t1:$e2:$e3:$n2:$n3:$se2:$se3:$sn2:$sn3:$t2:$t3"
  done
  python3 - "$hz" "$csv" $rows <<'PY'
import statistics, sys
hz, csv = float(sys.argv[1]), sys.argv[2]
out = {}
for row in sys.argv[3:]:
    v = row.split(":")
    run = int(v[0])
    for clock, off in (("stopped", 1), ("running", 15)):
        e0, e0n, e1, e1n, n0, n0n, n1, n1n = (float(x) for x in v[off:off + 8])
        se0, se1, sn0, sn1, t0, t1 = (float(x) for x in v[off + 8:off + 14])
        dt = t1 - t0
        r = {"estimator": (1e3 * (e1 - e0) / hz / dt, 1e-6 * (e1n - e0n) / dt, (se1 - se0) / dt),
             "null": (1e3 * (n1 - n0) / hz / dt, 1e-6 * (n1n - n0n) / dt, (sn1 - sn0) / dt)}
        out.setdefault(clock, []).append(r)
        print("  run %d, clock %s: Estimator %.2f ms of CPU per s (schedstat %.2f), %.0f context switches/s; "
              "null receiver %.2f (%.2f), %.0f/s; ratio %.2f (%.2f)"
              % (run, clock, r["estimator"][0], r["estimator"][1], r["estimator"][2], r["null"][0], r["null"][1],
                 r["null"][2], r["estimator"][0] / r["null"][0] if r["null"][0] else float("nan"),
                 r["estimator"][1] / r["null"][1]))
        with open(csv, "a") as f:
            for name in ("estimator", "null"):
                f.write("bag_idle_%s_%s_ms_cpu_per_s_ticks,%d,,,,%.3f,,,,,\n" % (clock, name, run, r[name][0]))
                f.write("bag_idle_%s_%s_ms_cpu_per_s_schedstat,%d,,,,%.3f,,,,,\n" % (clock, name, run, r[name][1]))
for clock, rs in out.items():
    med = {n: [statistics.median(r[n][i] for r in rs) for i in range(3)] for n in ("estimator", "null")}
    ratios = sorted(r["estimator"][1] / r["null"][1] for r in rs)
    print("  idle, clock %s, medians of %d runs: Estimator %.2f ms of CPU per s (schedstat %.2f; runs %s), %.0f switches/s;"
          " null receiver %.2f (%.2f; runs %s), %.0f/s; Estimator / null %.2f (schedstat %.2f; runs %.2f to %.2f)"
          % (clock, len(rs), med["estimator"][0], med["estimator"][1],
             " ".join("%.2f" % r["estimator"][1] for r in rs), med["estimator"][2], med["null"][0], med["null"][1],
             " ".join("%.2f" % r["null"][1] for r in rs), med["null"][2],
             med["estimator"][0] / med["null"][0] if med["null"][0] else float("nan"),
             med["estimator"][1] / med["null"][1], ratios[0], ratios[-1]))
PY
}
