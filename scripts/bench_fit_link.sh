#!/usr/bin/env bash
# Benchmark of fit_link on a base station's bag (issue 34's target: a 1-hour bag of 10 topics, about
# 1.5 million messages, fitted in under 10 s with the bag reading). Writes the bag once with
# scripts/make_bench_bag.py (seeded: the same bag every time), then times fit_link on all ten topics
# (one reading of the bag), with one Baum-Welch start instead of five, and on single topics (the
# chunks holding a topic are read, and of each message only its record header and first 12 bytes).
# Builds nothing (scripts/build.sh first).
#   usage: scripts/bench_fit_link.sh [HOURS] [COMPRESSION]     (defaults 1, none; or bz2, lz4)
# Results: a table on stdout (wall and CPU seconds, peak memory); the bag in $WS/bench/.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/workspace.sh"
HOURS=${1:-1}
COMPRESSION=${2:-none}
WS=${NE_WS:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/.ws}
BIN=$WS/devel/lib/networked_estimation
[ -x "$BIN/fit_link" ] || { echo "no $BIN/fit_link: run scripts/build.sh first" >&2; exit 2; }
mkdir -p "$WS/bench"
BAG=$WS/bench/fit_link_${HOURS}h_${COMPRESSION}.bag
if [ ! -s "$BAG" ]; then
  echo "writing $BAG ..."
  /usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/make_bench_bag.py" "$BAG.tmp" --hours "$HOURS" --compression "$COMPRESSION"
  mv "$BAG.tmp" "$BAG"
fi
TOPICS=(/imu/data /odometry/wheel /joint_states /scan /wheel/odom /cmd_vel_stamped /camera/camera_info /gps/fix /pose
        /temperature)
ARGS=()
for t in "${TOPICS[@]}"; do ARGS+=(--topic "$t"); done
# run NAME ARGS...: wall, user+sys CPU and peak resident memory of one fit_link run
run() {
  local name=$1 file
  shift
  file=$WS/bench/fit_link_$(echo "$name" | tr -c 'A-Za-z0-9\n' _).json
  # (Python's getrusage of the child: no /usr/bin/time or bc, which a fresh Debian does not have)
  /usr/bin/python3 - "$file" "$BIN/fit_link" "$@" --json >"$WS/bench/fit_link_time.txt" <<'PY'
import resource, subprocess, sys, time
start = time.monotonic()
with open(sys.argv[1], "w") as out:
    subprocess.run(sys.argv[2:], stdout=out, check=True)
r = resource.getrusage(resource.RUSAGE_CHILDREN)
print("%.2f %.2f %d" % (time.monotonic() - start, r.ru_utime + r.ru_stime, r.ru_maxrss))
PY
  read -r wall cpu mem <"$WS/bench/fit_link_time.txt"
  printf '%-28s %8s s wall %8s s cpu %8d MB\n' "$name" "$wall" "$cpu" "$((mem / 1024))"
}
echo "$(du -h "$BAG" | cut -f1) $BAG ($(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg))"
cat "$BAG" >/dev/null  # in the page cache: the runs time fit_link, not the disk
run "10 topics" --bag "$BAG" "${ARGS[@]}"
run "10 topics, 1 GE start" --bag "$BAG" "${ARGS[@]}" --starts 1
run "1 topic (/imu/data)" --bag "$BAG" --topic /imu/data
run "1 topic (/temperature)" --bag "$BAG" --topic /temperature
/usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
n = sum(l["messages"] for l in d["links"])
print("messages fitted: %d in %d links" % (n, len(d["links"])))
for l in d["links"]:
    print("  %-60s %8d msgs  loss %.4f  %s" % (l["source"], l["messages"], l["loss_rate"], l["model"]))' "$WS/bench/fit_link_10_topics.json"
