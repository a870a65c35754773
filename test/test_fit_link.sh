#!/usr/bin/env bash
# fit_link and the measured links end to end (docs/ros_interface.md, "Measuring a link"): a trace
# CSV with a known loss pattern fitted (the counts it must find), its channel file read by analyze
# and simulate, the trace itself as a channel (model: trace) in simulate, montecarlo and analyze,
# robot_localization's bag (a link that lost nothing), analyze --bag on a lossy bag
# against analyze --channel on the fitted file, and the refusals: exit 2, the problem named,
# nothing on stdout, no file written.
#   usage: test_fit_link.sh TOOLS_DIR REPO_ROOT
# Prints "N passed, M failed" and exits non-zero when any check failed.
set -euo pipefail

: "${2:?usage: test_fit_link.sh TOOLS_DIR REPO_ROOT}"
BIN=$(cd "$1" && pwd) ROOT=$(cd "$2" && pwd) WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_fit_link.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/check_lib.sh"
BAG=$ROOT/test/data/test2.bag
F=$WORK/in
OUT=$WORK/out
mkdir -p "$F"

# --- fixtures -----------------------------------------------------------------------------------
# A 10 Hz sender over 2000 slots: slot k lost when k mod 10 is 3 or 4, or k mod 97 is 0 (a burst of
# two, and isolated losses); received 50 ms after its stamp, plus k mod 3 ms; seq k.
awk 'BEGIN { print "stamp,receipt,seq";
  for (k = 0; k < 2000; k++) { if (k % 10 == 3 || k % 10 == 4 || k % 97 == 0) continue;
    s = 100 + k / 10; printf "%.6f,%.6f,%d\n", s, s + 0.05 + (k % 3) / 1000, k } }' >"$F/trace.csv"
# What the slots must be: expected 1999 (slot 0 lost), received, the transitions (arrived -> lost
# n01 ...) and the longest run of losses.
read -r EXPECTED RECEIVED N01 N00 N10 N11 LONGEST < <(awk 'BEGIN {
  for (k = 1; k < 2000; k++) { a = !(k % 10 == 3 || k % 10 == 4 || k % 97 == 0); n++; r += a;
    run = a ? 0 : run + 1; if (run > longest) longest = run;
    if (k > 1) { if (prev && a) n00++; if (prev && !a) n01++; if (!prev && a) n10++; if (!prev && !a) n11++ } prev = a }
  print n, r, n01, n00, n10, n11, longest }')
head -n 41 "$F/trace.csv" >"$F/short.csv"
printf 'time,receipt\n1,2\n' >"$F/nostamp.csv"
awk 'BEGIN { print "stamp,receipt"; srand(3); for (k = 0; k < 300; k++) { s = 100 + rand() * 30; printf "%.6f,%.6f\n", s, s + 0.01 } }' >"$F/irregular.csv"
printf 'stamp,receipt\n1.0,1.1\n1.1,oops\n' >"$F/badcell.csv"
printf 'not a bag\n' >"$F/not.bag"

# refuse NAME PATTERN TOOL ARGS...: exit 2, PATTERN (a fixed string) on stderr, nothing on stdout,
# no file under $OUT; for fit_link and analyze with --json added, stderr is {"error": ...} with the
# same message (unless JSON=0: the row is about --json itself).
JSON=1
refuse() {
  local name=$1 pattern=$2 tool=$3
  shift 3
  rm -rf "$OUT"
  run_rc rc "$BIN/$tool" "$@"
  if [ "$rc" = 2 ] && grep -qF -- "$pattern" "$WORK/err.txt" && [ ! -s "$WORK/out.txt" ] && no_files "$OUT"; then
    pass "$tool $name"
  else
    fail "$tool $name (exit $rc, expected 2 and '$pattern'; stderr, stdout below)"
    cat "$WORK/err.txt" "$WORK/out.txt"
  fi
  [ "$JSON" = 1 ] && { [ "$tool" = fit_link ] || [ "$tool" = analyze ]; } || return 0
  run_rc rc "$BIN/$tool" "$@" --json
  if [ "$rc" = 2 ] && [ ! -s "$WORK/out.txt" ] && /usr/bin/python3 - "$WORK/err.txt" "$pattern" <<'PY'; then
import json, sys
d = json.load(open(sys.argv[1]))
sys.exit(0 if list(d) == ["error"] and sys.argv[2] in d["error"] else 1)
PY
    pass "$tool $name --json"
  else
    fail "$tool $name --json (exit $rc; stderr below)"
    cat "$WORK/err.txt"
  fi
}

# --- a trace CSV with a known pattern -----------------------------------------------------------
run_rc rc "$BIN/fit_link" --csv "$F/trace.csv" --json
check "fit_link --csv: exit 0" [ "$rc" = 0 ]
check "fit_link --csv: the slots and the maximum-likelihood p, r of the pattern" /usr/bin/python3 - "$WORK/out.txt" \
  "$EXPECTED" "$RECEIVED" "$N00" "$N01" "$N10" "$N11" "$LONGEST" <<'PY'
import json, sys
l = json.load(open(sys.argv[1]))["links"][0]
e, r, n00, n01, n10, n11, longest = map(int, sys.argv[2:])
ok = (l["expected"] == e and l["received"] == r and l["slots_from"] == "header.seq"
      and l["gilbert"]["p"]["value"] == n01 / (n00 + n01) and l["gilbert"]["r"]["value"] == n10 / (n10 + n11)
      and abs(l["rate"] - 10) < 1e-6 and abs(l["delay"]["min"] - 0.05) < 1e-6 and abs(l["delay"]["max"] - 0.052) < 1e-6
      and l["longest_burst"] == longest and l["duplicates"] == 0 and l["reordered"] == 0)
sys.exit(0 if ok else 1)
PY
run_rc rc "$BIN/fit_link" --csv "$F/trace.csv" --output "$WORK/link.yaml"
check "fit_link --output: a summary with the burst histogram" grep -q "burst lengths" "$WORK/out.txt"
check "fit_link --output: the channel file, its intervals as comments" grep -q "^# 95 % intervals" "$WORK/link.yaml"
run_rc rc "$BIN/analyze" --model "$ROOT/config/models/zhou_example.yaml" --channel "$WORK/link.yaml" --verdict-only
check "analyze reads the fitted channel file" [ "$rc" = 0 ]
run_rc rc "$BIN/simulate" --model "$ROOT/config/models/zhou_example.yaml" --channel "$WORK/link.yaml" --steps 50 \
  --seed 1 --out "$WORK/sim"
check "simulate reads the fitted channel file" [ "$rc" = 0 ]

# --- the trace as a channel (model: trace) in simulate, montecarlo and analyze ------------------
printf 'model: trace\ntrace: trace.csv\n' >"$F/trace_channel.yaml"  # relative to the channel file
Z=$ROOT/config/models/zhou_example.yaml
run_rc rc "$BIN/simulate" --model "$Z" --channel "$F/trace_channel.yaml" --steps 300 --seed 4 --out "$WORK/simtrace"
check "simulate with a trace channel: exit 0" [ "$rc" = 0 ]
check "simulate with a trace channel: its arrivals are the trace's, from the slot the seed chose" \
  /usr/bin/python3 - "$WORK/simtrace/input.csv" <<'PY'
import sys
gamma = [int(line.split(",")[1]) for line in open(sys.argv[1]).read().splitlines()[1:]]
slots = [0 if (k % 10 in (3, 4) or k % 97 == 0) else 1 for k in range(1, 2000)]  # slot 0 is k = 1
n = len(slots)
starts = [s for s in range(n) if all(gamma[i] == slots[(s + i) % n] for i in range(len(gamma)))]
sys.exit(0 if len(gamma) == 300 and starts else 1)
PY
run_rc rc "$BIN/montecarlo" --experiment custom --model "$Z" --channel "$F/trace_channel.yaml" \
  --settings "$ROOT/config/estimators/kfio.yaml" --runs 4 --steps 40 --threads 1 --out "$WORK/mctrace"
check "montecarlo custom with a trace channel: exit 0 and its results" [ "$rc" = 0 -a -s "$WORK/mctrace/custom.csv" ]
run_rc rc "$BIN/analyze" --model "$Z" --channel "$F/trace_channel.yaml" --verdict-only --json
cp "$WORK/out.txt" "$WORK/trace_verdict.json"
run_rc rc "$BIN/fit_link" --csv "$F/trace.csv" --json
check "analyze with a trace channel: the link is the trace's fitted one (fit_link's r)" \
  /usr/bin/python3 - "$WORK/trace_verdict.json" "$WORK/out.txt" <<'PY'
import json, sys
v, f = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))["links"][0]
link = v["links"][0]
sys.exit(0 if f["model"] == "gilbert" and link["recovery_rate"] == f["gilbert"]["r"]["value"] else 1)
PY
printf 'model: trace\ntrace: trace.csv\ndelay: 0.1\n' >"$F/trace_delay.yaml"
printf 'model: trace\ntrace: nowhere.csv\n' >"$F/trace_missing.yaml"
printf 'model: trace\n' >"$F/trace_none.yaml"
printf 'model: trace\ntrace: %s\n' "$BAG" >"$F/trace_bag_notopic.yaml"

# --- robot_localization's bag: nothing lost ----------------------------------------------------
run_rc rc "$BIN/fit_link" --bag "$BAG" --topic /imu/data --topic /jackal_velocity_controller/odom --json
check "fit_link --bag, two topics: Bernoulli with no loss, 50 Hz, the odometry's delays within 32 ms" \
  /usr/bin/python3 - "$WORK/out.txt" <<'PY'
import json, sys
imu, odom = json.load(open(sys.argv[1]))["links"]
sys.exit(0 if all(l["lost"] == 0 and l["model"] == "bernoulli" and abs(l["rate"] - 50) < 0.1 for l in (imu, odom))
         and odom["received"] == 3060 and imu["received"] == 3061 and odom["delay"]["max"] <= 0.0320001 else 1)
PY

# --- analyze --bag against analyze --channel on the fitted file --------------------------------
# A 10 Hz GNSS topic behind a Gilbert link (p 0.05, r 0.3), written by Python's rosbag; the model
# unstable_two_links is bounded iff 1.5^2 (1 - r_gnss) loss_camera < 1. The camera's Bernoulli loss
# is put between the thresholds of the fitted r and of its interval's low end: bounded at the fit,
# not at the worst end.
/usr/bin/python3 - "$F/gnss.bag" <<'PY'
import random, sys
import rosbag, rospy
from sensor_msgs.msg import NavSatFix
from std_msgs.msg import Float64
rng, lost = random.Random(7), False
with rosbag.Bag(sys.argv[1], "w") as bag:
    for k in range(100):  # a topic without a header: no stamps to fit
        bag.write("/level", Float64(k), rospy.Time.from_sec(500 + k / 10))
    for k in range(20000):
        lost = (rng.random() >= 0.3) if lost else (rng.random() < 0.05)
        if not lost:
            m = NavSatFix()
            m.header.seq, m.header.stamp = k, rospy.Time.from_sec(500 + k / 10)
            bag.write("/gps/fix", m, rospy.Time.from_sec(500 + k / 10 + 0.03))
PY
U=$ROOT/config/models/unstable_two_links.yaml
run_rc rc "$BIN/fit_link" --bag "$F/gnss.bag" --topic /gps/fix --output "$WORK/gnss.yaml" --json
cp "$WORK/out.txt" "$WORK/gnss.json"
/usr/bin/python3 - "$WORK/gnss.json" "$F/camera.yaml" <<'PY'
import json, sys
g = json.load(open(sys.argv[1]))["links"][0]["gilbert"]["r"]
fit, worst = 1 / (2.25 * (1 - g["value"])), 1 / (2.25 * (1 - g["lower"]))
open(sys.argv[2], "w").write("model: bernoulli\nloss: %.6f\n" % ((fit + worst) / 2))
PY
run_rc rc "$BIN/analyze" --model "$U" --bag "$F/gnss.bag" --bag-topic gnss=/gps/fix --channel "camera=$F/camera.yaml" --json
cp "$WORK/out.txt" "$WORK/bag.json"
run_rc rc "$BIN/analyze" --model "$U" --channel "gnss=$WORK/gnss.yaml" --channel "camera=$F/camera.yaml" --json
cp "$WORK/out.txt" "$WORK/file.json"
check "analyze --bag gives the analysis of --channel on fit_link's file (the links' origins aside)" \
  /usr/bin/python3 - "$WORK/bag.json" "$WORK/file.json" <<'PY'
import json, sys
b, f = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
m = b.pop("measured_links")
for d in (b, f):
    for l in d["links"]:
        l.pop("origin", None)
sys.exit(0 if b == f and b["all_sensors"]["links_verdict"]["kind"] == "stable" else 1)
PY
check "analyze --bag: bounded at the fit, not at its worst end" /usr/bin/python3 -c '
import json, sys
m = json.load(open(sys.argv[1]))["measured_links"]
sys.exit(0 if m["summary"].startswith("bounded at the fit, not at its worst end") and m["at_fit"]["kind"] == "stable"
         and m["at_worst_end"]["kind"] == "unstable" and not m["bounded_at_worst_end"] else 1)' "$WORK/bag.json"
run_rc rc "$BIN/analyze" --model "$U" --bag "$F/gnss.bag" --bag-topic gnss=/gps/fix --channel "camera=$F/camera.yaml" --verdict-only
check "analyze --bag --verdict-only: the measured links' verdict in words" \
  grep -q "measured: bounded at the fit, not at its worst end: record longer or improve the link" "$WORK/out.txt"

# The bag of the docs' example (test/data/gilbert_link.bag, recorded by link_fit_replay): the
# numbers docs/stability.md (7.5) and docs/ros_interface.md show.
run_rc rc "$BIN/fit_link" --bag "$ROOT/test/data/gilbert_link.bag" --topic /link_out --json
check "the docs' example bag: 2000 expected, 272 lost, gilbert as the docs print it, header.seq refused" \
  /usr/bin/python3 -c '
import json, sys
l = json.load(open(sys.argv[1]))["links"][0]
g = l["gilbert"]
ok = (l["expected"] == 2000 and l["lost"] == 272 and l["model"] == "gilbert"
      and "a relay that numbers what it forwards" in l["note"]
      and "%.4g %.4g %.4g %.4g" % (g["p"]["value"], g["p"]["lower"], g["r"]["value"], g["r"]["lower"])
      == "0.05617 0.04626 0.3566 0.3021")
sys.exit(0 if ok else 1)' "$WORK/out.txt"
run_rc rc "$BIN/analyze" --model "$U" --bag "$ROOT/test/data/gilbert_link.bag" --bag-topic gnss=/link_out \
  --channel "camera=$ROOT/config/channels/bernoulli_0.2.yaml" --verdict-only
check "the docs' example: analyze --bag, bounded at the fit and at the worst end" \
  grep -qF "measured: bounded at the fitted links and at the intervals' worst ends" "$WORK/out.txt"

# --- refusals ----------------------------------------------------------------------------------
refuse "no source" "give exactly one of --bag, --csv and --events (found 0)" fit_link
refuse "two sources" "give exactly one of --bag, --csv and --events (found 2)" fit_link --csv "$F/trace.csv" --bag "$BAG" --topic /imu/data
refuse "--bag without --topic" "--bag needs --topic" fit_link --bag "$BAG"
refuse "--topic without --bag" "--topic is for --bag" fit_link --csv "$F/trace.csv" --topic /x
refuse "--rate not a number" "--rate: expected a positive number of Hz, found 'fast'" fit_link --csv "$F/trace.csv" --rate fast
refuse "--rate 0" "--rate: expected a positive number of Hz, found '0'" fit_link --csv "$F/trace.csv" --rate 0
refuse "--rate the stamps contradict" "--rate 20 Hz contradicts the header.seq numbers and stamps: they step by 0.1 s (10 Hz)" fit_link --csv "$F/trace.csv" --rate 20
refuse "--clock unknown" "--clock: expected auto, same or different, found 'utc'" fit_link --csv "$F/trace.csv" --clock utc
JSON=0 refuse "--series without --json" "--series is for --json" fit_link --csv "$F/trace.csv" --series
refuse "--output with two topics" "--output writes one link: give one --topic" fit_link --bag "$BAG" --topic /imu/data --topic /jackal_velocity_controller/odom --output "$OUT/x.yaml"
refuse "fewer than 50 messages" "40 messages, fewer than the 50 a fit needs" fit_link --csv "$F/short.csv" --output "$OUT/x.yaml"
refuse "CSV without stamp" "stamp" fit_link --csv "$F/nostamp.csv"
refuse "CSV bad cell" "$F/badcell.csv:3: receipt" fit_link --csv "$F/badcell.csv"
refuse "stamps not periodic" "the stamps are not periodic" fit_link --csv "$F/irregular.csv"
refuse "not a bag" "not a ROS bag" fit_link --bag "$F/not.bag" --topic /x
refuse "no such topic" "no topic /gps in the bag (its topics: /imu/data, /jackal_velocity_controller/odom)" fit_link --bag "$BAG" --topic /gps
refuse "missing file" "$F/nowhere.csv" fit_link --csv "$F/nowhere.csv"
refuse "trace channel with delay" "$F/trace_delay.yaml:3: delay: key 'delay' does not apply to model trace" simulate --model "$Z" --channel "$F/trace_delay.yaml" --steps 5 --seed 1 --out "$OUT/sim"
refuse "trace channel, missing trace file" "$F/trace_missing.yaml:2: trace: $F/nowhere.csv: cannot open" simulate --model "$Z" --channel "$F/trace_missing.yaml" --steps 5 --seed 1 --out "$OUT/sim"
refuse "trace channel without trace" "model trace needs trace" montecarlo --experiment custom --model "$Z" --channel "$F/trace_none.yaml" --settings "$ROOT/config/estimators/kfio.yaml" --runs 2 --steps 5 --out "$OUT/mc"
refuse "trace channel, a bag without trace_topic" "trace_topic must name the topic" analyze --model "$Z" --channel "$F/trace_bag_notopic.yaml"

A=(--model "$ROOT/config/models/tracking_2d.yaml")
refuse "--topic without --bag" "option '--topic' is for --bag" analyze "${A[@]}" --topic /imu/data
refuse "--bag-topic without --bag" "option '--bag-topic' is for --bag" analyze "${A[@]}" --bag-topic gnss=/imu/data
refuse "--bag without a topic" "no sensor is given a topic" analyze "${A[@]}" --bag "$BAG"
refuse "--bag-topic not SENSOR=TOPIC" "--bag-topic 'gnss': expected SENSOR=TOPIC" analyze "${A[@]}" --bag "$BAG" --bag-topic gnss
refuse "--bag-topic unknown sensor" "'lidar' is not a sensor of model 'tracking_2d' (its sensors: gnss, camera)" analyze "${A[@]}" --bag "$BAG" --bag-topic lidar=/imu/data
refuse "--bag-topic sensor twice" "sensor 'gnss' has a topic already" analyze "${A[@]}" --bag "$BAG" --bag-topic gnss=/imu/data --bag-topic gnss=/imu/data
refuse "--bag-topic beside its --channel" "sensor 'gnss' has a --channel of its own already" analyze "${A[@]}" --bag "$BAG" --channel "gnss=$ROOT/config/channels/bernoulli_0.2.yaml" --bag-topic gnss=/imu/data
refuse "--topic beside a plain --channel" "--topic /imu/data and a plain --channel both give every sensor a link" analyze "${A[@]}" --bag "$BAG" --channel "$ROOT/config/channels/bernoulli_0.2.yaml" --topic /imu/data
refuse "--bag with --design" "option '--bag' is not for --design" analyze "${A[@]}" --bag "$BAG" --topic /imu/data --design total_rate
refuse "--bag, no such topic" "no topic /gps in the bag" analyze "${A[@]}" --bag "$BAG" --topic /gps
refuse "a bag topic without header stamps" "topic /level (std_msgs/Float64) has no header stamps" fit_link --bag "$F/gnss.bag" --topic /level
refuse "--rate the bag's stamps contradict" "--rate 20 Hz contradicts the header.seq numbers and stamps: they step by 0.1 s (10 Hz)" fit_link --bag "$F/gnss.bag" --topic /gps/fix --rate 20

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
