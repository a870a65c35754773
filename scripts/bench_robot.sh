#!/usr/bin/env bash
# Benchmarks of the Estimator on a robot's standard message types (docs/ros_interface.md, "Benchmarks"):
#  1. Latency of the mixed graph (launch/bench_robot.launch: sensor_msgs/Imu at 200 Hz,
#     nav_msgs/Odometry at 100 Hz and sensor_msgs/NavSatFix at 10 Hz from the PlantSimulator, each
#     through a LossyChannel, into the Estimator with n = 6, one nodelet manager): the step's stamp to
#     the Estimate's arrival, median and p99, against a bare typed nodelet hop at the same step rate
#     (launch/bench_estimator.launch mode:=passthrough).
#  2. The highest total input rate with no missed step: the same graph at the step rates
#     NE_BENCH_ROBOT_RATES (total input rate 1.55 x the step rate); a step is missed when its
#     Estimate does not arrive, when no sample was in hand at its deadline, or when a due sample came
#     after it was taken (late dropped); every sample must be accepted.
#  3. A recorded bag (launch/bench_bag.launch): Odometry 10 Hz + Imu 30 Hz recorded from the
#     PlantSimulator, played with `rosbag play --clock -r 4` into the Estimator alone in its own
#     process: CPU per input message (utime + stime of that process over the playback / inputs),
#     input-to-output latency (scripts/latency_probe.py, another process), and the CPU it uses
#     idle under sim time (the bag's clock running, no input); and the floor: the same playback into
#     a receiver that drops every message (BenchNullReceiver; with one hand-off per message, and in
#     roscpp's receive thread), what roscpp alone costs per input.
#  4. Idle after a bag ends: the Estimator (config/robot/jackal.yaml, tf on) and the null receiver
#     side by side in one master, each in its own process, fed NE_BENCH_IDLE_BAG_SECONDS of
#     test/data/test2.bag at -r 4; then, with no input, the CPU (utime + stime, and schedstat) of
#     each over NE_BENCH_IDLE_SECONDS while the clock stands still (the bag ended: rosbag's /clock
#     stops with it) and while a /clock runs on at 4x; NE_BENCH_IDLE_RUNS runs, medians and the
#     ratio Estimator / null receiver.
# NE_BENCH_ROBOT_PARTS selects the parts (default "1 2 3 4"), e.g. NE_BENCH_ROBOT_PARTS=4.
# Builds nothing (scripts/build.sh first). Results: $WS/bench/robot.csv and a table on stdout; logs in
# $WS/bench/robot_runs/.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
source "$(dirname "${BASH_SOURCE[0]}")/bench_lib.sh"

RATES="${NE_BENCH_ROBOT_RATES:-400 800 1600 3200}"
SECONDS_PER_RUN="${NE_BENCH_ROBOT_SECONDS:-5}"
BAG_SECONDS="${NE_BENCH_BAG_SECONDS:-120}"
PARTS="${NE_BENCH_ROBOT_PARTS:-1 2 3 4}"
IDLE_RUNS="${NE_BENCH_IDLE_RUNS:-3}"
IDLE_SECONDS="${NE_BENCH_IDLE_SECONDS:-20}"
IDLE_BAG_SECONDS="${NE_BENCH_IDLE_BAG_SECONDS:-20}"
for p in $PARTS; do
  case "$p" in 1|2|3|4) ;; *) echo "bench_robot: NE_BENCH_ROBOT_PARTS: expected parts 1 to 4, found '$p'" >&2; exit 2 ;; esac
done
for v in "$IDLE_RUNS" "$IDLE_SECONDS" "$IDLE_BAG_SECONDS"; do
  [[ "$v" =~ ^[1-9][0-9]*$ ]] || { echo "bench_robot: NE_BENCH_IDLE_RUNS, _SECONDS and _BAG_SECONDS take a positive integer, found '$v'" >&2; exit 2; }
done
want() { [[ " $PARTS " == *" $1 "* ]]; }
OUT="$WS/bench"
RUNS="$OUT/robot_runs"
CSV="$OUT/robot.csv"
rm -rf "$RUNS"
mkdir -p "$RUNS" "$ROS_LOG_DIR"
LAUNCH_PID=""
trap 'if [ -n "$LAUNCH_PID" ]; then stop_launch "$LAUNCH_PID"; fi; idle_cleanup' EXIT
echo "label,rate_hz,inputs_hz,sent,received,median_us,p99_us,missed,late_dropped,accepted,expected_inputs" > "$CSV"

# Waits for a result row in $1 (at most $2 s) while roslaunch $LAUNCH_PID runs, then stops it.
wait_result()
{
  local res="$1" deadline=$((SECONDS + $2))
  while [ "$SECONDS" -lt "$deadline" ] && kill -0 "$LAUNCH_PID" 2>/dev/null; do
    if [ -f "$res" ] && [ "$(wc -l < "$res")" -ge 2 ]; then
      break
    fi
    sleep 0.2
  done
  stop_launch "$LAUNCH_PID"
  LAUNCH_PID=""
}

graph()  # label rate: the mixed graph at a step rate
{
  local label="$1" rate="$2" res="$RUNS/$1.csv"
  ROS_MASTER_URI="http://localhost:$(free_port)" roslaunch --sigint-timeout=5 --sigterm-timeout=2 \
    networked_estimation bench_robot.launch rate:="$rate" duration:="$SECONDS_PER_RUN" result_file:="$res" \
    label:="$label" > "$RUNS/$label.log" 2>&1 < /dev/null &
  LAUNCH_PID=$!
  wait_result "$res" $((SECONDS_PER_RUN + 40))
  if [ ! -f "$res" ] || [ "$(wc -l < "$res")" -lt 2 ]; then
    echo "  $label: FAILED (no result; log $RUNS/$label.log)"
    return 0
  fi
  # imu every step, odom every 2nd, the fix every 20th: 1.55 inputs per step.
  tail -n 1 "$res" | awk -F, -v rate="$rate" -v s="$SECONDS_PER_RUN" 'BEGIN { OFS = "," }
    { steps = rate * s; want = steps + int((steps + 1) / 2) + int((steps + 19) / 20);
      print $1, rate, 1.55 * rate, $2, $3, $5, $7, $16, $17, $18, want }' | tee -a "$CSV" |
    awk -F, '{ printf "  %-14s step rate %5d Hz (inputs %6.0f Hz): latency median %7s us, p99 %8s us; estimates %s/%s, missed %s, late %s, accepted %s of %s\n", $1, $2, $3, $6, $7, $5, $4, $8, $9, $10, $11 }'
}

hop()  # label rate: the bare typed hop
{
  local label="$1" rate="$2" res="$RUNS/$1.csv"
  ROS_MASTER_URI="http://localhost:$(free_port)" roslaunch --sigint-timeout=5 --sigterm-timeout=2 \
    networked_estimation bench_estimator.launch mode:=passthrough rate:="$rate" duration:="$SECONDS_PER_RUN" \
    result_file:="$res" label:="$label" > "$RUNS/$label.log" 2>&1 < /dev/null &
  LAUNCH_PID=$!
  wait_result "$res" $((SECONDS_PER_RUN + 40))
  [ -f "$res" ] || { echo "  $label: FAILED (log $RUNS/$label.log)"; return 0; }
  tail -n 1 "$res" | awk -F, -v rate="$rate" 'BEGIN { OFS = "," } { print $1, rate, rate, $2, $3, $5, $7, $16, "", "", "" }' |
    tee -a "$CSV" | awk -F, '{ printf "  %-14s rate %5d Hz: latency median %7s us, p99 %8s us\n", $1, $2, $6, $7 }'
}

echo "== Robot graph benchmark (logs in $RUNS)"
echo "load before: $(uptime)"
if want 1; then
  echo "-- part 1: latency, Imu 200 Hz + Odometry 100 Hz + NavSatFix 10 Hz (n = 6), ${SECONDS_PER_RUN} s"
  hop bare_hop_200 200
  graph robot_200 200
fi
if want 2; then
  echo "-- part 2: highest total input rate with no missed step"
  for rate in $RATES; do
    graph "robot_$rate" "$rate"
  done
fi

if want 3; then
echo "-- part 3: a recorded bag (Odometry 10 Hz + Imu 30 Hz, ${BAG_SECONDS} s), rosbag play --clock -r 4"
MODEL="$RUNS/robot_odom_imu.yaml"
python3 - "$(rospack find networked_estimation)/config/models/planar_robot.yaml" "$MODEL" <<'PY'
import sys, yaml
m = yaml.safe_load(open(sys.argv[1]))
m["name"] = "planar_robot_odom_imu"
m["sensors"] = [s for s in m["sensors"] if s["name"] in ("odom", "imu")]
T = 1.0 / 30.0
for i in range(3):
    m["A"][i][i + 3] = T
m["period"] = T
yaml.safe_dump(m, open(sys.argv[2], "w"), default_flow_style=None)
PY
BAG="$RUNS/robot.bag"
export ROS_MASTER_URI="http://localhost:$(free_port)"
roslaunch networked_estimation bench_bag.launch phase:=record model:="$MODEL" bag:="$BAG" seconds:="$BAG_SECONDS" \
  > "$RUNS/record.log" 2>&1 < /dev/null &
LAUNCH_PID=$!
deadline=$((SECONDS + BAG_SECONDS / 10 + 60))
until grep -q "finished after" "$RUNS/record.log" || [ "$SECONDS" -ge "$deadline" ]; do sleep 0.5; done
sleep 1
stop_launch "$LAUNCH_PID"
LAUNCH_PID=""
[ -f "$BAG" ] || { echo "  no bag recorded (log $RUNS/record.log)"; exit 1; }
INPUTS="$(python3 -c "import rosbag, sys; b = rosbag.Bag(sys.argv[1]); print(b.get_message_count())" "$BAG")"
BAG_WALL="$(python3 -c "import rosbag, sys; b = rosbag.Bag(sys.argv[1]); print(b.get_end_time() - b.get_start_time())" "$BAG")"
roslaunch networked_estimation bench_bag.launch phase:=play model:="$MODEL" > "$RUNS/play.log" 2>&1 < /dev/null &
LAUNCH_PID=$!
pid=""
for i in $(seq 1 100); do
  pid="$(pgrep -n -f "__name:=estimator" || true)"  # the newest: this run's
  [ -n "$pid" ] && grep -q "Estimator kfio" "$RUNS/play.log" && break
  sleep 0.2
done
[ -n "$pid" ] || { echo "  the Estimator did not start (log $RUNS/play.log)"; exit 1; }
# cpu (bench_lib.sh): utime + stime and schedstat nanoseconds of the process, "ticks:ns".
HZ="$(getconf CLK_TCK)"
# Idle under sim time: the bag's clock runs, its messages go elsewhere.
c0="$(cpu "$pid")"; t0="$(date +%s.%N)"
rosbag play -q --clock -r 4 -u 20 "$BAG" /odom:=/unused/odom /imu/data:=/unused/imu > /dev/null 2>&1
c1="$(cpu "$pid")"; t1="$(date +%s.%N)"
# The playback (a time jump back resets the estimator first: it starts from the bag's first message).
sleep 1
python3 "$(dirname "${BASH_SOURCE[0]}")/latency_probe.py" --period 0.0333333333 \
  --seconds "$(python3 -c "print($BAG_WALL / 4 + 1)")" > "$RUNS/probe.txt" 2> "$RUNS/probe.log" &
PROBE=$!
sleep 2
c2="$(cpu "$pid")"
rosbag play -q --clock -r 4 -d 1 "$BAG" > /dev/null 2>&1
sleep 0.5
c3="$(cpu "$pid")"
wait "$PROBE" || true
stop_launch "$LAUNCH_PID"
LAUNCH_PID=""
python3 - "$c0" "$c1" "$t0" "$t1" "$c2" "$c3" "$HZ" "$INPUTS" "$(cat "$RUNS/probe.txt")" "$CSV" <<'PY'
import sys
def split(v):
    ticks, ns = v.split(":")
    return float(ticks), float(ns)
(k0, n0), (k1, n1) = split(sys.argv[1]), split(sys.argv[2])
t0, t1 = float(sys.argv[3]), float(sys.argv[4])
(k2, n2), (k3, n3) = split(sys.argv[5]), split(sys.argv[6])
hz, inputs = float(sys.argv[7]), float(sys.argv[8])
probe = dict(kv.split("=") for kv in sys.argv[9].split()) if "=" in sys.argv[9] else {}
idle_ticks = 1e3 * (k1 - k0) / hz / (t1 - t0)
idle_ns = 1e-6 * (n1 - n0) / (t1 - t0)
per_input_ticks = 1e6 * (k3 - k2) / hz / inputs
per_input_ns = 1e-3 * (n3 - n2) / inputs
print("  idle under sim time (clock at 4x, no input): %.2f ms CPU per second (utime + stime), %.2f ms (schedstat)"
      % (idle_ticks, idle_ns))
print("  playback: %d inputs, CPU per input message %.1f us (utime + stime, %d Hz ticks), %.1f us (schedstat)"
      % (inputs, per_input_ticks, hz, per_input_ns))
print("  input-to-output latency (another process): median %s us, p99 %s us (%s of %s estimates matched)"
      % (probe.get("median_us"), probe.get("p99_us"), probe.get("matched"), probe.get("estimates")))
with open(sys.argv[10], "a") as f:
    f.write("bag_playback,30,40,%d,%s,%s,%s,,,,\n" % (inputs, probe.get("estimates", ""), probe.get("median_us", ""),
                                                       probe.get("p99_us", "")))
    f.write("bag_cpu_us_per_input_ticks,,,,,%.1f,,,,,\n" % per_input_ticks)
    f.write("bag_cpu_us_per_input_schedstat,,,,,%.1f,,,,,\n" % per_input_ns)
    f.write("bag_idle_ms_cpu_per_s_ticks,,,,,%.2f,,,,,\n" % idle_ticks)
    f.write("bag_idle_ms_cpu_per_s_schedstat,,,,,%.2f,,,,,\n" % idle_ns)
PY
# The floor: the same playback into a receiver that drops every message (BenchNullReceiver): with
# one hand-off per message as the Estimator's inputs, and inline (in roscpp's receive thread, no
# hand-off at all): what roscpp alone costs per input here.
floor()  # label inline
{
  roslaunch networked_estimation bench_bag.launch phase:=null inline:="$2" > "$RUNS/null_$1.log" 2>&1 < /dev/null &
  LAUNCH_PID=$!
  local pid="" i c4 c5
  for i in $(seq 1 100); do
    pid="$(pgrep -n -f "__name:=null_receiver" || true)"
    [ -n "$pid" ] && grep -q "BenchNullReceiver on" "$RUNS/null_$1.log" && break
    sleep 0.2
  done
  [ -n "$pid" ] || { echo "  the null receiver did not start (log $RUNS/null_$1.log)"; exit 1; }
  sleep 1
  c4="$(cpu "$pid")"
  rosbag play -q --clock -r 4 -d 1 "$BAG" > /dev/null 2>&1
  sleep 0.5
  c5="$(cpu "$pid")"
  stop_launch "$LAUNCH_PID"
  LAUNCH_PID=""
  python3 - "$c4" "$c5" "$HZ" "$INPUTS" "$CSV" "$1" <<'PY'
import sys
(k0, n0), (k1, n1) = [tuple(float(x) for x in v.split(":")) for v in sys.argv[1:3]]
hz, inputs, label = float(sys.argv[3]), float(sys.argv[4]), sys.argv[6]
ticks, ns = 1e6 * (k1 - k0) / hz / inputs, 1e-3 * (n1 - n0) / inputs
what = {"queued": "one hand-off per message", "inline": "in roscpp's receive thread"}[label]
print("  floor, a receiver that drops every message (%s): CPU per input %.1f us (utime + stime), %.1f us (schedstat)"
      % (what, ticks, ns))
with open(sys.argv[5], "a") as f:
    f.write("bag_floor_%s_cpu_us_per_input_ticks,,,,,%.1f,,,,,\n" % (label, ticks))
    f.write("bag_floor_%s_cpu_us_per_input_schedstat,,,,,%.1f,,,,,\n" % (label, ns))
PY
}
floor queued false
floor inline true
fi

if want 4; then
  echo "-- part 4: idle after a bag ends, the Estimator (config/robot/jackal.yaml) beside the null receiver," \
       "$IDLE_RUNS runs: ${IDLE_BAG_SECONDS} s of test2.bag at -r 4, then ${IDLE_SECONDS} s with the clock stopped and" \
       "${IDLE_SECONDS} s with a /clock running at 4x, no input"
  idle_after_bag "$REPO/test/data/test2.bag" "$REPO/config/robot/jackal.yaml" "$IDLE_RUNS" "$IDLE_SECONDS" \
    "$IDLE_BAG_SECONDS" "$RUNS" "$CSV"
fi
echo "load after: $(uptime)"
echo "results: $CSV"
