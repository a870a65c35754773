#!/usr/bin/env bash
# Side by side with the peer (docs/architecture.md, "Performance beside robot_localization"): one
# bag, by default robot_localization's Jackal bag test/data/test2.bag (nav_msgs/Odometry on
# /jackal_velocity_controller/odom and sensor_msgs/Imu on /imu/data, 50 Hz each), played with
# `rosbag play --clock -r RATE` (default 4) in turn into
#   robot_localization  ekf_localization_node, configured as robot_localization's own test of this
#                       bag (its "bag2" test: 15-state 3-D EKF, odometry velocities + IMU
#                       orientation, angular velocity and acceleration, 50 Hz timer);
#   estimator           our Estimator nodelet (nodelet standalone) with --params FILE, by default
#                       config/robot/jackal.yaml, the configuration of the rostests on this bag
#                       (kfio, a linear 6-state model: position and heading with their rates;
#                       odometry x, y + IMU yaw); config/peer_tests/jackal_bag2.yaml is
#                       robot_localization's own configuration of this bag translated (ekfio,
#                       omni_3d, 15 states);
#   null                BenchNullReceiver (nodelet standalone), a receiver that drops every message
#                       after one hand-off: what receiving the stream costs in roscpp;
#   relay               the same receiver, publishing every odometry message again on
#                       /odometry/filtered (~relay): an estimator's traffic (both inputs in, one
#                       output per 50 Hz step out, to the probe by TCP) with no estimation: what
#                       receiving and publishing cost in roscpp;
#   decoding_relay      the relay that also deserializes the IMU messages into sensor_msgs/Imu
#                       (~decode), as any node that reads their values must (the relay passes
#                       them on as bytes): the floor of an estimator on these inputs.
# Each run of each system has its own roscore on a free port; every process it starts is stopped
# by its PID. Measured per run:
#   CPU per input    utime + stime of the system's process (/proc/PID/stat) over the playback
#                    divided by the number of input messages of the two topics (and the same from
#                    /proc/PID/task/*/schedstat, exact where ticks are sampled);
#   latency          seen from a third process (scripts/latency_probe.py --match received) that
#                    subscribes to the inputs and to /odometry/filtered: for each output stamped t,
#                    the input that completed it is the last one received before it with a stamp
#                    within 10 ms (half the 50 Hz period) of t; latency = the output's receipt
#                    minus that input's receipt (wall time, both in the probe); median and p99;
#   idle             CPU of the process while a /clock keeps running at RATE times real time for
#                    IDLE seconds after the playback, with no input (% of one core);
#   final position   x, y, z of the last /odometry/filtered received;
#   context switches of all the process's threads (/proc/PID/task/*/status), per input over the
#                    playback and per second idle: where a small VM's time goes;
#   by thread        the playback's CPU (schedstat) and context switches per input of the
#                    nodelet's input thread (ne_dispatch), roscpp's receive thread and the rest.
# The table holds the median over the runs of each column; every run is in the CSV. The ratios to
# the relays are given both ways: of the medians, and round by round (each round runs every system
# once, back to back) with the median of those.
# Builds nothing: scripts/build.sh first, and the peer's workspace (robot_localization built with
# catkin) given by PEER_WS; without it the benchmark is skipped (exit 0).
# Usage: PEER_WS=<peer workspace> scripts/bench_peer.sh [--runs N] [--rate R] [--idle-seconds S]
#          [--clock-hz HZ] [--systems "robot_localization estimator null relay decoding_relay"] [--params FILE] [BAG]
#   defaults: 3 runs, rate 4, 10 s idle, all five systems, test/data/test2.bag, /clock at 100 Hz
#   (wall: rosbag play's default). Under sim time a ros::Timer fires at most once per /clock
#   message: at -r 4 a 100 Hz /clock advances 40 ms a message, and robot_localization's 50 Hz
#   timer fires at 25 Hz of sim time; --clock-hz 200 lets it run at its 50 Hz.
# Results: $WS/bench/peer.csv, $WS/bench/peer_threads.csv and tables on stdout; logs (each run's
# threads at the playback's start and end among them) in $WS/bench/peer_runs/.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"

RUNS_WANTED=3
RATE=4
IDLE_SECONDS=10
BAG=""
SYSTEMS="robot_localization estimator null relay decoding_relay"
CLOCK_HZ=100
PARAMS=""
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) RUNS_WANTED="$2"; shift 2 ;;
    --rate) RATE="$2"; shift 2 ;;
    --idle-seconds) IDLE_SECONDS="$2"; shift 2 ;;
    --systems) SYSTEMS="$2"; shift 2 ;;
    --clock-hz) CLOCK_HZ="$2"; shift 2 ;;
    --params) PARAMS="$2"; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench_peer: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) BAG="$1"; shift ;;
  esac
done
BAG="${BAG:-$REPO/test/data/test2.bag}"
PARAMS="${PARAMS:-$REPO/config/robot/jackal.yaml}"
[ -f "$PARAMS" ] || { echo "bench_peer: --params: no file '$PARAMS'" >&2; exit 2; }
for v in "$RUNS_WANTED" "$IDLE_SECONDS"; do
  [[ "$v" =~ ^[1-9][0-9]*$ ]] || { echo "bench_peer: --runs and --idle-seconds take a positive integer, found '$v'" >&2; exit 2; }
done
for v in "$RATE" "$CLOCK_HZ"; do
  [[ "$v" =~ ^[0-9]*\.?[0-9]+$ ]] || { echo "bench_peer: --rate and --clock-hz take a positive number, found '$v'" >&2; exit 2; }
done
[ -f "$BAG" ] || { echo "bench_peer: no bag '$BAG'" >&2; exit 2; }
for sys in $SYSTEMS; do
  case "$sys" in
    robot_localization|estimator|null|relay|decoding_relay) ;;
    *) echo "bench_peer: --systems: unknown system '$sys' (expected robot_localization, estimator, null, relay, decoding_relay)" >&2; exit 2 ;;
  esac
done

EKF="${PEER_WS:+$PEER_WS/devel/lib/robot_localization/ekf_localization_node}"
if [ -z "${PEER_WS:-}" ]; then
  echo "bench_peer: skipped: PEER_WS is not set (a catkin workspace with robot_localization built in it)"
  exit 0
fi
if [ ! -x "$EKF" ]; then
  echo "bench_peer: skipped: no robot_localization built in PEER_WS=$PEER_WS (expected $EKF)"
  exit 0
fi
source "$(dirname "${BASH_SOURCE[0]}")/bench_lib.sh"

OUT="$WS/bench"
LOGS="$OUT/peer_runs"
CSV="$OUT/peer.csv"
rm -rf "$LOGS"
mkdir -p "$LOGS" "$ROS_LOG_DIR"
NODE_PID=""
PROBE_PID=""
CLOCK_PID=""
MASTER_PID=""
cleanup()
{
  local p
  for p in "$CLOCK_PID" "$PROBE_PID" "$NODE_PID" "$MASTER_PID"; do
    [ -n "$p" ] && stop_pid "$p"
  done
  return 0
}
trap cleanup EXIT

ODOM=/jackal_velocity_controller/odom
IMU=/imu/data
read -r INPUTS BAG_START BAG_END < <(python3 - "$BAG" "$ODOM" "$IMU" <<'PY'
import sys, rosbag
b = rosbag.Bag(sys.argv[1])
topics = b.get_type_and_topic_info().topics
n = sum(topics[t].message_count for t in sys.argv[2:] if t in topics)
print(n, b.get_start_time(), b.get_end_time())
PY
)
[ "$INPUTS" -gt 0 ] || { echo "bench_peer: the bag has no message on $ODOM or $IMU" >&2; exit 2; }
PLAY_WALL="$(python3 -c "print(($BAG_END - $BAG_START) / $RATE)")"
HZ="$(getconf CLK_TCK)"

# robot_localization's configuration of its test on this bag (the bag2 test): 3-D mode, the
# odometry's linear velocities and yaw rate, the IMU's orientation, angular velocity and linear
# acceleration (gravity removed), its process noise and a near-zero initial covariance.
python3 - "$LOGS/ekf.yaml" "$ODOM" "$IMU" <<'PY'
import sys, yaml
q = [0.03, 0.03, 0.4, 0.03, 0.03, 0.06, 0.025, 0.025, 0.05, 0.002, 0.002, 0.004, 0.01, 0.01, 0.01]
def diag(d):
    return [d[i] if i == j else 0.0 for i in range(15) for j in range(15)]
cfg = {
    "frequency": 50, "sensor_timeout": 0.1, "two_d_mode": False,
    "map_frame": "map", "odom_frame": "odom", "base_link_frame": "base_link", "world_frame": "odom",
    "odom0": sys.argv[2], "imu0": sys.argv[3],
    "odom0_config": [False] * 6 + [True, True, True] + [False, False, True] + [False] * 3,
    "imu0_config": [False] * 3 + [True] * 3 + [False] * 3 + [True] * 6,
    "odom0_differential": False, "imu0_differential": False,
    "odom0_queue_size": 10, "imu0_queue_size": 10,
    "imu0_remove_gravitational_acceleration": True,
    "print_diagnostics": False, "debug": False,
    "process_noise_covariance": diag(q),
    "initial_estimate_covariance": diag([1e-9] * 15),
}
yaml.safe_dump(cfg, open(sys.argv[1], "w"), default_flow_style=None)
PY

# Starts system $1 in the current master; sets NODE_PID and waits until it subscribes to the IMU.
start_system()
{
  local sys="$1" name log="$LOGS/$1_$2.log" i
  rosparam set /use_sim_time true
  case "$sys" in
    robot_localization)
      name=ekf
      rosparam load "$LOGS/ekf.yaml" /$name
      LD_LIBRARY_PATH="$PEER_WS/devel/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
        "$EKF" __name:=$name > "$log" 2>&1 < /dev/null &
      ;;
    estimator)
      name=estimator
      rosparam load "$PARAMS" /$name
      rosrun nodelet nodelet standalone networked_estimation/Estimator __name:=$name > "$log" 2>&1 < /dev/null &
      ;;
    null)
      name=null_receiver
      rosparam set /$name/topics "[$ODOM, $IMU]"
      rosrun nodelet nodelet standalone networked_estimation/BenchNullReceiver __name:=$name > "$log" 2>&1 < /dev/null &
      ;;
    relay)
      name=relay
      rosparam set /$name/topics "[$ODOM, $IMU]"
      rosparam set /$name/relay "$ODOM"
      rosrun nodelet nodelet standalone networked_estimation/BenchNullReceiver __name:=$name > "$log" 2>&1 < /dev/null &
      ;;
    decoding_relay)
      name=decoding_relay
      rosparam set /$name/topics "[$ODOM, $IMU]"
      rosparam set /$name/relay "$ODOM"
      rosparam set /$name/decode true
      rosrun nodelet nodelet standalone networked_estimation/BenchNullReceiver __name:=$name > "$log" 2>&1 < /dev/null &
      ;;
  esac
  NODE_PID=$!
  for i in $(seq 1 60); do
    kill -0 "$NODE_PID" 2>/dev/null || { echo "  $sys did not start (log $log)" >&2; return 1; }
    rostopic info "$IMU" 2>/dev/null | grep -q "/$name " && return 0
    sleep 0.5
  done
  echo "  $sys did not subscribe to $IMU within 30 s (log $log)" >&2
  return 1
}

THREADS_CSV="$OUT/peer_threads.csv"
echo "system,run,group,cpu_us_per_input,switches_per_input" > "$THREADS_CSV"
echo "system,run,inputs,cpu_us_per_input,cpu_us_per_input_schedstat,latency_median_us,latency_p99_us,outputs,matched,idle_pct_core,idle_pct_core_schedstat,x,y,z,switches_per_input,idle_switches_per_s" > "$CSV"

run_one()  # system run
{
  local sys="$1" run="$2" c0 c1 c2 c3 s0 s1 s2 s3 t2 t3 probe
  start_master "$LOGS/roscore_${sys}_$run.log" || { echo "  no roscore came up (log $LOGS/roscore_${sys}_$run.log)" >&2; return 1; }
  start_system "$sys" "$run" || { cleanup; NODE_PID=""; MASTER_PID=""; return 1; }
  python3 "$REPO/scripts/latency_probe.py" --odom "$ODOM" --imu "$IMU" --estimate /odometry/filtered \
    --period 0.02 --match received --odometry --seconds "$(python3 -c "print($PLAY_WALL + 1.5)")" \
    > "$LOGS/probe_${sys}_$run.txt" 2> "$LOGS/probe_${sys}_$run.log" &
  PROBE_PID=$!
  sleep 2
  c0="$(cpu "$NODE_PID")"; s0="$(switches "$NODE_PID")"; threads "$NODE_PID" > "$LOGS/threads_${sys}_${run}_start.txt"
  rosbag play -q --clock --hz "$CLOCK_HZ" -r "$RATE" -d 1 "$BAG" > "$LOGS/play_${sys}_$run.log" 2>&1 < /dev/null
  sleep 0.5
  c1="$(cpu "$NODE_PID")"; s1="$(switches "$NODE_PID")"; threads "$NODE_PID" > "$LOGS/threads_${sys}_${run}_end.txt"
  wait "$PROBE_PID" || true
  PROBE_PID=""
  probe="$(cat "$LOGS/probe_${sys}_$run.txt")"
  # Idle: the clock runs on from the bag's end, no input.
  sim_clock "$BAG_END" "$RATE" "$((IDLE_SECONDS + 2))" "$CLOCK_HZ" > "$LOGS/clock_${sys}_$run.log" 2>&1 &
  CLOCK_PID=$!
  sleep 1.5
  c2="$(cpu "$NODE_PID")"; s2="$(switches "$NODE_PID")"; t2="$(date +%s.%N)"
  sleep "$IDLE_SECONDS"
  c3="$(cpu "$NODE_PID")"; s3="$(switches "$NODE_PID")"; t3="$(date +%s.%N)"
  wait "$CLOCK_PID" || true
  CLOCK_PID=""
  stop_pid "$NODE_PID"; NODE_PID=""
  stop_pid "$MASTER_PID"; MASTER_PID=""
  python3 - "$sys" "$run" "$INPUTS" "$HZ" "$c0" "$c1" "$c2" "$c3" "$t2" "$t3" "$probe" "$CSV" "$s0" "$s1" "$s2" "$s3" <<'PY'
import sys
sys_name, run, inputs, hz = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
(k0, n0), (k1, n1), (k2, n2), (k3, n3) = [tuple(float(x) for x in v.split(":")) for v in sys.argv[5:9]]
t2, t3 = float(sys.argv[9]), float(sys.argv[10])
probe = dict(kv.split("=") for kv in sys.argv[11].split()) if "=" in sys.argv[11] else {}
cpu_ticks, cpu_ns = 1e6 * (k1 - k0) / hz / inputs, 1e-3 * (n1 - n0) / inputs
idle_ticks, idle_ns = 100.0 * (k3 - k2) / hz / (t3 - t2), 1e-7 * (n3 - n2) / (t3 - t2)
s0, s1, s2, s3 = (float(v) for v in sys.argv[13:17])
switches_per_input, idle_switches_per_s = (s1 - s0) / inputs, (s3 - s2) / (t3 - t2)
has_output = int(probe.get("estimates", "0")) > 0
row = [sys_name, run, "%d" % inputs, "%.1f" % cpu_ticks, "%.1f" % cpu_ns,
       probe.get("median_us", "") if has_output else "", probe.get("p99_us", "") if has_output else "",
       probe.get("estimates", ""), probe.get("matched", ""), "%.3f" % idle_ticks, "%.3f" % idle_ns,
       probe.get("x", ""), probe.get("y", ""), probe.get("z", ""),
       "%.2f" % switches_per_input, "%.0f" % idle_switches_per_s]
open(sys.argv[12], "a").write(",".join(row) + "\n")
print("  %-18s run %s: CPU per input %6.1f us (schedstat %6.1f); latency median %8s us, p99 %8s us (%s outputs, %s matched);"
      " idle %.2f %% of a core; last position %s %s %s; context switches %.2f per input, %.0f/s idle"
      % (sys_name, run, cpu_ticks, cpu_ns, row[5] or "-", row[6] or "-", row[7] or "0", row[8] or "0", idle_ticks,
         row[11] or "-", row[12] or "-", row[13] or "-", switches_per_input, idle_switches_per_s))
PY
  per_thread "$sys" "$run"
}

# The playback's CPU and context switches per input, thread by thread (threads in bench_lib.sh),
# in three groups: the nodelet's own input thread (ne_dispatch), roscpp's receive thread (the one
# waiting in epoll) and every other thread (roscpp's timers, clock and log threads, the nodelet
# manager's, a node's main thread); a row per group into $THREADS_CSV.
per_thread()  # system run
{
  python3 - "$1" "$2" "$INPUTS" "$LOGS/threads_$1_$2_start.txt" "$LOGS/threads_$1_$2_end.txt" "$THREADS_CSV" <<'PY'
import sys
name, run, inputs = sys.argv[1], sys.argv[2], float(sys.argv[3])
def read(path):
    out = {}
    for line in open(path):
        f = line.split()
        out[f[0]] = (f[1], int(f[2]), int(f[3]), f[4] if len(f) > 4 else "")
    return out
start, end = read(sys.argv[4]), read(sys.argv[5])
groups = {"ne_dispatch": [0, 0], "roscpp_receive": [0, 0], "other": [0, 0]}
for tid, (comm, ns, sw, wchan) in end.items():
    ns0, sw0 = start[tid][1:3] if tid in start else (0, 0)
    g = "ne_dispatch" if comm == "ne_dispatch" else "roscpp_receive" if "epoll" in wchan else "other"
    groups[g][0] += ns - ns0
    groups[g][1] += sw - sw0
with open(sys.argv[6], "a") as out:
    for g, (ns, sw) in groups.items():
        out.write("%s,%s,%s,%.1f,%.2f\n" % (name, run, g, 1e-3 * ns / inputs, sw / inputs))
print("  %-18s run %s by thread (CPU us; context switches per input): %s" % (name, run, "; ".join(
    "%s %.1f; %.2f" % (g, 1e-3 * ns / inputs, sw / inputs) for g, (ns, sw) in groups.items())))
PY
}

echo "== Side by side with robot_localization: $(basename "$BAG"), $INPUTS inputs over $(python3 -c "print(round($BAG_END - $BAG_START, 1))") s, rosbag play --clock -r $RATE (/clock at $CLOCK_HZ Hz); $RUNS_WANTED run(s); idle $IDLE_SECONDS s (logs in $LOGS)"
echo "machine: $(nproc) cores, $(uname -r); load before: $(uptime | sed 's/.*load average/load average/')"
for run in $(seq 1 "$RUNS_WANTED"); do
  for sys in $SYSTEMS; do
    run_one "$sys" "$run" || echo "  $sys run $run: FAILED"
  done
done
echo "load after: $(uptime | sed 's/.*load average/load average/')"

python3 - "$CSV" "$(sed -n 's/^algorithm: *\([a-z_]*\).*/\1/p' "$PARAMS" | head -n 1), $(basename "$PARAMS")" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
cols = ["cpu_us_per_input", "cpu_us_per_input_schedstat", "latency_median_us", "latency_p99_us",
        "idle_pct_core", "idle_pct_core_schedstat", "x", "y", "z", "switches_per_input", "idle_switches_per_s"]
med = {}
for name in ("robot_localization", "estimator", "null", "relay", "decoding_relay"):
    mine = [r for r in rows if r["system"] == name]
    med[name] = {c: (statistics.median(float(r[c]) for r in mine) if mine and all(r[c] for r in mine) else None)
                 for c in cols}
    med[name]["runs"] = len(mine)
    if not mine and name in ("relay", "decoding_relay"):  # not asked for (--systems)
        del med[name]
def f(v, fmt):
    return "-" if v is None else fmt % v
print()
print("| system | model | runs | CPU per input (us) | latency median (us) | latency p99 (us) | idle (% of a core) | final x, y, z (m) | context switches per input; idle per s |")
print("|---|---|---|---|---|---|---|---|---|")
model = {"robot_localization": "EKF, 15 states (3-D pose, velocities, accelerations)",
         "estimator": sys.argv[2],
         "null": "none (drops every message)",
         "relay": "none (publishes the odometry again)",
         "decoding_relay": "none (the relay, deserializing the IMU)"}
for name, m in med.items():
    pos = "-" if m["x"] is None else "%.3f, %.3f, %.3f" % (m["x"], m["y"], m["z"])
    print("| %s | %s | %d | %s (%s) | %s | %s | %s (%s) | %s | %s; %s |" % (
        name, model[name], m["runs"], f(m["cpu_us_per_input"], "%.1f"), f(m["cpu_us_per_input_schedstat"], "%.1f"),
        f(m["latency_median_us"], "%.0f"), f(m["latency_p99_us"], "%.0f"), f(m["idle_pct_core"], "%.2f"),
        f(m["idle_pct_core_schedstat"], "%.2f"), pos, f(m["switches_per_input"], "%.2f"),
        f(m["idle_switches_per_s"], "%.0f")))
print("(medians over the runs; CPU per input: utime + stime, in brackets schedstat; idle: the same two)")
e, r, n = med["estimator"], med["robot_localization"], med["null"]
if e["cpu_us_per_input"] and r["cpu_us_per_input"] and n["cpu_us_per_input"]:
    print("estimator / robot_localization CPU per input: %.2f (schedstat %.2f); estimator / null: %.2f (schedstat %.2f)"
          % (e["cpu_us_per_input"] / r["cpu_us_per_input"],
             e["cpu_us_per_input_schedstat"] / r["cpu_us_per_input_schedstat"],
             e["cpu_us_per_input"] / n["cpu_us_per_input"],
             e["cpu_us_per_input_schedstat"] / n["cpu_us_per_input_schedstat"]))
def per_run(floor):
    # Each round runs every system once, back to back: the ratio within a round is taken while the
    # VM is in one phase (its speed moves by a third between rounds), then the median over rounds.
    cpu = {(r["system"], r["run"]): float(r["cpu_us_per_input"]) for r in rows if r["cpu_us_per_input"]}
    ratios = [cpu[("estimator", run)] / cpu[(floor, run)]
              for run in sorted({r["run"] for r in rows}, key=int)
              if ("estimator", run) in cpu and (floor, run) in cpu and cpu[(floor, run)] > 0]
    if not ratios:
        return ""
    return "; round by round %s, their median %.2f" % (" ".join("%.2f" % x for x in ratios), statistics.median(ratios))
p = med.get("relay")
if p and e["cpu_us_per_input"] and p["cpu_us_per_input"]:
    print("estimator / relay CPU per input: %.2f (schedstat %.2f)%s"
          % (e["cpu_us_per_input"] / p["cpu_us_per_input"],
             e["cpu_us_per_input_schedstat"] / p["cpu_us_per_input_schedstat"], per_run("relay")))
d = med.get("decoding_relay")
if d and e["cpu_us_per_input"] and d["cpu_us_per_input"]:
    print("estimator / decoding_relay CPU per input: %.2f (schedstat %.2f)%s"
          % (e["cpu_us_per_input"] / d["cpu_us_per_input"],
             e["cpu_us_per_input_schedstat"] / d["cpu_us_per_input_schedstat"], per_run("decoding_relay")))
PY
python3 - "$THREADS_CSV" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
groups = ("ne_dispatch", "roscpp_receive", "other")
print()
print("| system | " + " | ".join("%s: CPU per input (us); switches per input" % g for g in groups) + " |")
print("|---|---|---|---|")
for name in ("robot_localization", "estimator", "null", "relay", "decoding_relay"):
    cells = []
    for g in groups:
        mine = [r for r in rows if r["system"] == name and r["group"] == g]
        if not mine:
            break
        cells.append("%.1f; %.2f" % (statistics.median(float(r["cpu_us_per_input"]) for r in mine),
                                      statistics.median(float(r["switches_per_input"]) for r in mine)))
    if cells:
        print("| %s | %s |" % (name, " | ".join(cells)))
print("(the playback's schedstat CPU and context switches by thread, medians over the runs)")
PY
echo "results: $CSV, $THREADS_CSV"
