#!/usr/bin/env bash
# Benchmark of the LossyChannel nodelet (launch/bench_channel.launch): source, element under test and
# sink in ONE nodelet manager (intra-process shared_ptr hand-overs).
#  1. Added latency at delay 0 / loss 0: direct (source -> sink), passthrough (source ->
#     BenchPassThrough -> sink) and channel (source -> LossyChannel -> sink) at a moderate rate.
#  2. Highest rate forwarded without falling behind: the same graphs at increasing rates.
# Builds nothing (scripts/build.sh first). Each run gets a fresh master on a free port (roslaunch
# starts it); the run stops when the sink has written its result, or at a timeout.
# Results: $WS/bench/channel.csv (one row per run), logs in $WS/bench/channel_runs/; a table on stdout.
#
# Environment (all optional):
#   NE_BENCH_BASE_RATE=1000  NE_BENCH_BASE_SECONDS=5        part 1
#   NE_BENCH_RATES="5000 10000 20000 40000 80000"  NE_BENCH_SWEEP_SECONDS=3
#   NE_BENCH_SWEEP_MODES="passthrough channel direct"       part 2 (direct shows the source/sink limit)
#   NE_BENCH_REPEAT=1        runs per rate of part 2 (a rate is kept up with when one of them keeps up:
#                            other load on the machine only makes a run worse)
#   NE_BENCH_START_DELAY=2   NE_BENCH_WORKERS=0 (manager worker threads, 0: one per core)
# cpu us/msg: CPU time of the whole manager process (all threads) per message received, measured by
# the sink; cores: that CPU time over the wall time (2 cores here: near 2, the process is CPU-bound);
# other: cores used meanwhile by the rest of the machine (other processes, steal): noise when above
# about 0.1. load1 (CSV only): the 1-minute load average at the end of the run, the benchmark included.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
source "$(dirname "${BASH_SOURCE[0]}")/bench_lib.sh"

BASE_RATE="${NE_BENCH_BASE_RATE:-1000}"
BASE_SECONDS="${NE_BENCH_BASE_SECONDS:-5}"
RATES="${NE_BENCH_RATES:-5000 10000 20000 40000 80000}"
SWEEP_SECONDS="${NE_BENCH_SWEEP_SECONDS:-3}"
SWEEP_MODES="${NE_BENCH_SWEEP_MODES:-passthrough channel direct}"
START_DELAY="${NE_BENCH_START_DELAY:-2}"
WORKERS="${NE_BENCH_WORKERS:-0}"
REPEAT="${NE_BENCH_REPEAT:-1}"

OUT="$WS/bench"
RUNS="$OUT/channel_runs"
CSV="$OUT/channel.csv"
rm -rf "$RUNS"
mkdir -p "$RUNS" "$ROS_LOG_DIR"
echo "phase,mode,target_hz,duration_s,sent,received,delivered_pct,rate_hz,median_us,p90_us,p99_us,max_us,p99_first_half_us,p99_second_half_us,median_first_tenth_us,median_last_tenth_us,cpu_us_per_msg,cpu_cores,other_cores,source_hz,source_max_lag_us,load1" > "$CSV"

LAUNCH_PID=""
trap 'if [ -n "$LAUNCH_PID" ]; then stop_launch "$LAUNCH_PID"; fi' EXIT

run()  # phase mode rate seconds repetition
{
  local phase="$1" mode="$2" rate="$3" seconds="$4" rep="$5"
  local label="${phase}_${mode}_${rate}_${rep}"
  local res="$RUNS/$label.csv" log="$RUNS/$label.log"
  printf '  %-5s %-11s %6s Hz %2s s: ' "$phase" "$mode" "$rate" "$seconds"
  ROS_MASTER_URI="http://localhost:$(free_port)" roslaunch --sigint-timeout=5 --sigterm-timeout=2 \
    networked_estimation bench_channel.launch mode:="$mode" rate:="$rate" duration:="$seconds" \
    start_delay:="$START_DELAY" workers:="$WORKERS" result_file:="$res" label:="$label" > "$log" 2>&1 < /dev/null &
  LAUNCH_PID=$!
  # Master, manager and loading take a few seconds; the sink reports 1 s after its first message
  # plus the duration.
  local deadline=$((SECONDS + START_DELAY + seconds + 30))
  while [ "$SECONDS" -lt "$deadline" ] && kill -0 "$LAUNCH_PID" 2>/dev/null; do
    if [ -f "$res" ] && [ "$(wc -l < "$res")" -ge 2 ]; then
      break
    fi
    sleep 0.2
  done
  stop_launch "$LAUNCH_PID"
  LAUNCH_PID=""
  if [ ! -f "$res" ] || [ "$(wc -l < "$res")" -lt 2 ]; then
    echo "FAILED (no result; log $log):"
    tail -n 15 "$log" | sed 's/^/    /'
    return 0
  fi
  local src load1
  src="$(grep -o 'bench_source: .*' "$log" | tail -n 1 || true)"
  load1="$(cut -d' ' -f1 /proc/loadavg)"
  tail -n 1 "$res" | python3 -c '
import re, sys
phase, mode, target, seconds, src, load1 = sys.argv[1:7]
f = sys.stdin.read().strip().split(",")
sent, received = int(f[1]), int(f[2])
pct = 100.0 * received / sent if sent else 0.0
src = re.sub(r"\x1b\[[0-9;]*m", "", src)  # colour codes of the console output
fields = dict(kv.split("=", 1) for kv in src.split() if "=" in kv)
src_hz = src.split("(")[1].split(" Hz")[0] if "(" in src else ""
print(",".join([phase, mode, target, seconds, str(sent), str(received), "%.2f" % pct] + f[3:15]
               + [src_hz, fields.get("max_lag_us", ""), load1]))
' "$phase" "$mode" "$rate" "$seconds" "$src" "$load1" | tee -a "$CSV" \
    | awk -F, '{printf "sent %s received %s (%s %%) at %s Hz, latency median %s us p99 %s us, cpu %s us/msg\n", $5, $6, $7, $8, $9, $11, $17}'
}

echo "== LossyChannel benchmark (one nodelet manager; logs in $RUNS)"
echo "load before: $(uptime)"
echo "-- part 1: latency at ${BASE_RATE} Hz, ${BASE_SECONDS} s"
for mode in direct passthrough channel; do
  run base "$mode" "$BASE_RATE" "$BASE_SECONDS" 1
done
echo "-- part 2: throughput, ${SWEEP_SECONDS} s per rate"
for rate in $RATES; do
  for i in $(seq 1 "$REPEAT"); do
    for mode in $SWEEP_MODES; do
      run sweep "$mode" "$rate" "$SWEEP_SECONDS" "$i"
    done
  done
done
echo "load after: $(uptime)"

python3 - "$CSV" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
median = {}  # (phase, mode, rate) -> lowest median over the repeats
for r in rows:
    k = (r["phase"], r["mode"], r["target_hz"])
    median[k] = min(median.get(k, float("inf")), float(r["median_us"]))

def added(r, base):
    b = median.get((r["phase"], base, r["target_hz"]))
    return "%+.1f" % (float(r["median_us"]) - b) if r["mode"] == "channel" and b is not None else "-"

def verdict(r):
    # Keeps up: delivered within 1 % of sent, and no backlog building up during the run: the median
    # latency of the last tenth of the messages within 1 ms of that of the first tenth (a growing
    # backlog raises it; one stall of the machine does not, it shows in p99 and max only).
    # "p99 spike": p99 of the second half above twice that of the first half + 1 ms.
    sent, rec = int(r["sent"]), int(r["received"])
    m1, m2 = float(r["median_first_tenth_us"]), float(r["median_last_tenth_us"])
    p1, p2 = float(r["p99_first_half_us"]), float(r["p99_second_half_us"])
    if sent == 0 or rec < 0.99 * sent:
        return "BEHIND (lost)"
    if m2 > m1 + 1000.0:
        return "BEHIND (grows)"
    return "ok (p99 spike)" if p2 > 2.0 * p1 + 1000.0 else "ok"

head = ("phase", "mode", "rate Hz", "sent", "received", "deliv %", "achieved Hz", "median us", "p90 us",
        "p99 us", "max us", "p99 1st/2nd half", "median 1st/last tenth", "+median vs pass", "+median vs direct", "cpu us/msg", "cores", "other", "source Hz", "verdict")
table = [head]
for r in rows:
    table.append((r["phase"], r["mode"], r["target_hz"], r["sent"], r["received"], r["delivered_pct"],
                  "%.0f" % float(r["rate_hz"]), r["median_us"], r["p90_us"], r["p99_us"], r["max_us"],
                  "%s/%s" % (r["p99_first_half_us"], r["p99_second_half_us"]),
                  "%s/%s" % (r["median_first_tenth_us"], r["median_last_tenth_us"]), added(r, "passthrough"),
                  added(r, "direct"), r["cpu_us_per_msg"], r["cpu_cores"], r["other_cores"],
                  r["source_hz"], verdict(r)))
widths = [max(len(str(t[i])) for t in table) for i in range(len(head))]
print()
for i, t in enumerate(table):
    print("  ".join(str(c).rjust(w) for c, w in zip(t, widths)))
    if i == 0:
        print("  ".join("-" * w for w in widths))
print()
for mode in ("channel", "passthrough", "direct"):
    kept = {}  # rate -> one of its runs kept up
    for r in rows:
        if r["phase"] == "sweep" and r["mode"] == mode:
            kept[int(r["target_hz"])] = kept.get(int(r["target_hz"]), False) or verdict(r).startswith("ok")
    if not kept:
        continue
    best = None
    for rate in sorted(kept):  # the highest rate up to which every rate of the sweep was kept up with
        if not kept[rate]:
            break
        best = rate
    print("kept up with every rate up to, %-11s: %s" % (mode, "%d Hz" % best if best else "none"))
EOF
echo "results: $CSV"
