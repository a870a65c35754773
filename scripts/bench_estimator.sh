#!/usr/bin/env bash
# Benchmark of the Estimator nodelet (launch/bench_estimator.launch), source, estimator and sink in
# ONE nodelet manager:
#  1. End-to-end latency, Measurement publish -> Estimate publish (median, p99) at NE_BENCH_BASE_RATE,
#     against a bare nodelet hop (BenchPassThrough), for n = 2 and n = 20 (kfio, 2-row sensor).
#  2. The highest plant rate at which no step is missed: every Estimate arrives and every step had
#     its measurement in hand (latency_budget NE_BENCH_BUDGET, default 5 ms), for rates NE_BENCH_RATES;
#     the bare hop at the same rates counts its messages later than the budget the same way (the
#     source stamps each message with its scheduled time, so a late wake-up of the source counts).
# Builds nothing (scripts/build.sh first). Results: $WS/bench/estimator.csv, logs in
# $WS/bench/estimator_runs/, a table on stdout.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
source "$(dirname "${BASH_SOURCE[0]}")/bench_lib.sh"

BASE_RATE="${NE_BENCH_BASE_RATE:-1000}"
BASE_SECONDS="${NE_BENCH_BASE_SECONDS:-5}"
RATES="${NE_BENCH_RATES:-2000 5000 10000 20000}"
SWEEP_SECONDS="${NE_BENCH_SWEEP_SECONDS:-3}"
BUDGET="${NE_BENCH_BUDGET:-0.005}"
OUT="$WS/bench"
RUNS="$OUT/estimator_runs"
CSV="$OUT/estimator.csv"
rm -rf "$RUNS"
mkdir -p "$RUNS" "$ROS_LOG_DIR"

# Bench models: A = 0.9 I (n x n), B = Q = I, a 2-row sensor C = [I_2 0], R = I.
python3 - "$RUNS" <<'PY'
import sys
for n in (2, 20):
    eye = lambda k: [[1.0 if i == j else 0.0 for j in range(k)] for i in range(k)]
    A = [[0.9 if i == j else 0.0 for j in range(n)] for i in range(n)]
    C = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(2)]
    with open("%s/n%d.yaml" % (sys.argv[1], n), "w") as f:
        f.write("name: bench_n%d\nperiod: 0.001\nA: %s\nQ: %s\nC: %s\nR: %s\nx0: %s\nP0: %s\n"
                % (n, A, eye(n), C, eye(2), [0.0] * n, eye(n)))
PY

echo "label,mode,n,target_hz,sent,received,rate_hz,median_us,p90_us,p99_us,max_us,cpu_us_per_msg,missed,source_max_lag_us" > "$CSV"
LAUNCH_PID=""
trap 'if [ -n "$LAUNCH_PID" ]; then stop_launch "$LAUNCH_PID"; fi' EXIT

run()  # phase mode n rate seconds
{
  local phase="$1" mode="$2" n="$3" rate="$4" seconds="$5"
  local label="${phase}_${mode}_n${n}_${rate}"
  local res="$RUNS/$label.csv" log="$RUNS/$label.log"
  ROS_MASTER_URI="http://localhost:$(free_port)" roslaunch --sigint-timeout=5 --sigterm-timeout=2 \
    networked_estimation bench_estimator.launch mode:="$mode" model:="$RUNS/n$n.yaml" rate:="$rate" \
    duration:="$seconds" latency_budget:="$BUDGET" result_file:="$res" label:="$label" > "$log" 2>&1 < /dev/null &
  LAUNCH_PID=$!
  local deadline=$((SECONDS + seconds + 35))
  while [ "$SECONDS" -lt "$deadline" ] && kill -0 "$LAUNCH_PID" 2>/dev/null; do
    if [ -f "$res" ] && [ "$(wc -l < "$res")" -ge 2 ]; then
      break
    fi
    sleep 0.2
  done
  stop_launch "$LAUNCH_PID"
  LAUNCH_PID=""
  if [ ! -f "$res" ] || [ "$(wc -l < "$res")" -lt 2 ]; then
    echo "  $label: FAILED (no result; log $log)"
    tail -n 15 "$log" | sed 's/^/    /'
    return 0
  fi
  local lag
  lag="$(grep -o 'max_lag_us=[0-9]*' "$log" | tail -n 1 | cut -d= -f2 || true)"
  tail -n 1 "$res" | awk -F, -v mode="$mode" -v n="$n" -v rate="$rate" -v lag="$lag" \
    'BEGIN { OFS = "," } { print $1, mode, n, rate, $2, $3, $4, $5, $6, $7, $8, $13, ($16 == "" ? 0 : $16), lag }' \
    | tee -a "$CSV" | awk -F, '{ printf "  %-28s sent %s received %s at %s Hz: latency median %s us, p99 %s us, missed %s, source max lag %s us\n", $1, $5, $6, $7, $8, $10, $13, $14 }'
}

echo "== Estimator benchmark (one nodelet manager; logs in $RUNS)"
echo "load before: $(uptime)"
echo "-- part 1: latency at ${BASE_RATE} Hz, ${BASE_SECONDS} s"
run base passthrough 2 "$BASE_RATE" "$BASE_SECONDS"
for n in 2 20; do
  run base estimator "$n" "$BASE_RATE" "$BASE_SECONDS"
done
echo "-- part 2: highest rate with no missed step, ${SWEEP_SECONDS} s per rate"
for rate in $RATES; do
  run sweep passthrough 2 "$rate" "$SWEEP_SECONDS"
  for n in 2 20; do
    run sweep estimator "$n" "$rate" "$SWEEP_SECONDS"
  done
done
echo "load after: $(uptime)"

python3 - "$CSV" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
base = {r["mode"] + r["n"]: r for r in rows if r.get("label", "").startswith("base")}
hop = base.get("passthrough2")
print()
for n, mode in (("2", "passthrough"), ("2", "estimator"), ("20", "estimator")):
    e = base.get("estimator" + n) if mode == "estimator" else None
    if e and hop:
        print("n = %-2s latency median %s us (bare hop %s us: %.2fx), p99 %s us" %
              (n, e["median_us"], hop["median_us"], float(e["median_us"]) / max(float(hop["median_us"]), 1e-9),
               e["p99_us"]))
    runs = sorted((r for r in rows if r["label"].startswith("sweep") and r["n"] == n and r["mode"] == mode),
                  key=lambda r: int(r["target_hz"]))
    clean = [int(r["target_hz"]) for r in runs
             if int(r["sent"]) > 0 and int(r["received"]) >= int(r["sent"]) and int(r["missed"]) == 0]
    missed = ", ".join("%s Hz: %s" % (r["target_hz"], r["missed"]) for r in runs if int(r["missed"]) > 0)
    what = "bare hop" if mode == "passthrough" else "estimator n = %s" % n
    print("%-16s highest rate with no missed step: %s%s" % (what, "%d Hz" % max(clean) if clean else "none",
          " (missed: %s; compare the bare hop at the same rate: a late wake-up of the source counts)" % missed if missed else ""))
PY
echo "results: $CSV"
