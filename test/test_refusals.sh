#!/usr/bin/env bash
# Table-driven refusals of the options and file formats added since the first release: per-sensor
# --channel NAME=FILE, --actuator-channel, the model's schedule, analyze --design / --growth-cap /
# --trace, montecarlo --shard / merge / --axis, make_model's options, analyze --at and a built-in
# motion's period. Each row is one malformed value (empty, repeated, out of range, wrong type,
# unknown name, conflicting options): the tool must exit 2, name the option or key as the user
# wrote it (the row's fixed string), print nothing on stdout and write no file, and print no inf or
# nan. analyze's rows run again with --json: stderr is then one JSON object {"error": ...} holding
# the same message, stdout still empty.
#   usage: test_refusals.sh TOOLS_DIR REPO_ROOT
# Prints "N passed, M failed" and exits non-zero when any check failed.
set -euo pipefail

: "${2:?usage: test_refusals.sh TOOLS_DIR REPO_ROOT}"
BIN=$(cd "$1" && pwd) ROOT=$(cd "$2" && pwd) WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_refusals.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
# shared helpers: check, run_rc, passed / failed
source "$(dirname "${BASH_SOURCE[0]}")/check_lib.sh"

# --- fixtures -----------------------------------------------------------------------------------
F=$WORK/in
mkdir -p "$F"
cp "$ROOT/config/models/tracking_2d.yaml" "$F/two.yaml"                 # sensors gnss, camera; 2 inputs
cp "$ROOT/config/models/scheduled_example.yaml" "$F/sched.yaml"         # sensors s1, s2
cp "$ROOT/config/channels/bernoulli_0.2.yaml" "$F/b.yaml"
cp "$ROOT/config/channels/gilbert_elliott_bursty.yaml" "$F/ge.yaml"
cp "$ROOT/config/channels/actuator_q1_0.3_q2_0.4.yaml" "$F/act.yaml"
cp "$ROOT/config/estimators/kfio.yaml" "$F/kfio.yaml"
printf 'not: [a, channel\n' >"$F/broken.yaml"
printf 'model: bernoulli\nloss: 1.5\n' >"$F/loss_range.yaml"
printf 'model: bernoulli\nloss: many\n' >"$F/loss_type.yaml"
# a model with a schedule: the scheduled example with its schedule block replaced
sched() {  # NAME BLOCK: $F/NAME.yaml
  sed '/^schedule:/,$d' "$F/sched.yaml" >"$F/$1.yaml"
  printf 'schedule:\n%s\n' "$2" >>"$F/$1.yaml"
}
sched s_empty '  pattern: []'
sched s_none '  pattern: [[], []]'
sched s_unknown '  pattern: [[s1], [lidar]]'
sched s_twice '  pattern: [[s1, s1]]'
sched s_type '  pattern: 3'
sched s_noprob '  subsets: [[s1], [s2]]'
sched s_sum '  subsets: [[s1], [s2]]
  probabilities: [0.5, 0.6]'
sched s_both '  pattern: [[s1]]
  subsets: [[s1]]'
sched s_subnone '  subsets: [[], []]
  probabilities: [0.5, 0.5]'
# a recorded arrival pattern of sensor s1 (`rostopic echo -p` of ~events) and a file that is not one
printf '%%time,field.header.seq,field.outcome\n1,1,0\n2,2,1\n3,3,0\n4,4,0\n' >"$F/events.csv"
printf 'a,b\n1,2\n' >"$F/notevents.csv"

OUT=$WORK/out  # every row's --out / --output goes here: it must stay empty
# refuse NAME PATTERN TOOL ARGS...: exit 2, PATTERN (a fixed string) on stderr, nothing on stdout,
# no file under $OUT, no inf or nan anywhere.
refuse() {
  local name=$1 pattern=$2 tool=$3
  shift 3
  rm -rf "$OUT"
  run_rc rc "$BIN/$tool" "$@"
  local ok=1
  [ "$rc" = 2 ] || ok=0
  grep -qF -- "$pattern" "$WORK/err.txt" || ok=0
  [ ! -s "$WORK/out.txt" ] || ok=0
  no_files "$OUT" || ok=0
  if grep -qwE 'inf|nan' "$WORK/out.txt"; then ok=0; fi
  if [ "$ok" = 1 ]; then pass "$tool $name"; else
    fail "$tool $name (exit $rc, expected 2 and '$pattern'; stderr, stdout below)"
    cat "$WORK/err.txt" "$WORK/out.txt"
  fi
  if [ "$tool" = analyze ]; then
    run_rc rc "$BIN/$tool" "$@" --json
    if [ "$rc" = 2 ] && [ ! -s "$WORK/out.txt" ] && /usr/bin/python3 - "$WORK/err.txt" "$pattern" <<'PY'; then
import json, sys
d = json.load(open(sys.argv[1]))
sys.exit(0 if list(d) == ["error"] and sys.argv[2] in d["error"] else 1)
PY
      pass "$tool $name --json: {\"error\": ...} on stderr"
    else
      fail "$tool $name --json (exit $rc; stderr below)"
      cat "$WORK/err.txt"
    fi
  fi
}

A=(--model "$F/two.yaml")
# --- analyze: per-sensor --channel NAME=FILE -----------------------------------------------------
refuse "--channel empty" "--channel '': expected FILE or NAME=FILE, found nothing" analyze "${A[@]}" --channel ""
refuse "--channel NAME= (no file)" "--channel gnss=: no file after 'gnss='" analyze "${A[@]}" --channel gnss=
refuse "--channel =FILE (no name)" "--channel '=$F/b.yaml': expected FILE or NAME=FILE" analyze "${A[@]}" --channel "=$F/b.yaml"
refuse "--channel unknown sensor" "'lidar' is not a sensor" analyze "${A[@]}" --channel "lidar=$F/b.yaml"
refuse "--channel NAME twice" "gnss" analyze "${A[@]}" --channel "gnss=$F/b.yaml" --channel "gnss=$F/ge.yaml"
refuse "--channel FILE twice" "--channel" analyze "${A[@]}" --channel "$F/b.yaml" --channel "$F/ge.yaml"
refuse "--model empty" "option '--model': expected a file name, found ''" analyze --model ""
refuse "--channel missing file" "$F/nowhere.yaml" analyze "${A[@]}" --channel "gnss=$F/nowhere.yaml"
refuse "--channel broken YAML" "$F/broken.yaml" analyze "${A[@]}" --channel "gnss=$F/broken.yaml"
refuse "--channel loss out of range" "loss" analyze "${A[@]}" --channel "gnss=$F/loss_range.yaml"
refuse "--channel loss of the wrong type" "loss" analyze "${A[@]}" --channel "gnss=$F/loss_type.yaml"
refuse "--channel a model file" "$F/two.yaml" analyze "${A[@]}" --channel "gnss=$F/two.yaml"

# --- analyze: the model's schedule ---------------------------------------------------------------
refuse "schedule.pattern empty" "schedule.pattern" analyze --model "$F/s_empty.yaml"
refuse "schedule.pattern without a sensor" "schedule.pattern: no step schedules a sensor" analyze --model "$F/s_none.yaml"
refuse "schedule.pattern unknown sensor" "schedule.pattern[1][0]" analyze --model "$F/s_unknown.yaml"
refuse "schedule.pattern sensor twice" "sensor 's1' listed twice" analyze --model "$F/s_twice.yaml"
refuse "schedule.pattern wrong type" "schedule.pattern" analyze --model "$F/s_type.yaml"
refuse "schedule.subsets without probabilities" "schedule" analyze --model "$F/s_noprob.yaml"
refuse "schedule.probabilities not summing to 1" "schedule.probabilities" analyze --model "$F/s_sum.yaml"
refuse "schedule.pattern with subsets" "schedule.subsets" analyze --model "$F/s_both.yaml"
refuse "schedule.subsets without a sensor" "schedule.subsets: every subset is []" analyze --model "$F/s_subnone.yaml"

# --- analyze --design / --growth-cap ---------------------------------------------------------------
refuse "--design empty" "--design: expected total_rate or capacity, found ''" analyze "${A[@]}" --design ""
refuse "--design unknown cost" "found 'cheapest'" analyze "${A[@]}" --design cheapest
refuse "--design twice" "option '--design' given more than once" analyze "${A[@]}" --design total_rate --design capacity
refuse "--design with --channel" "option '--channel' is not for --design" analyze "${A[@]}" --design total_rate \
  --channel "$F/b.yaml"
refuse "--design with --trace" "option '--trace' is not for --design" analyze --model "$F/sched.yaml" \
  --design total_rate --trace "s1=$F/events.csv"
for g in "" 0 1 -0.5 1.5 nan inf x 0.5x; do
  refuse "--growth-cap '$g'" "--growth-cap: expected a number in (0, 1), found '$g'" analyze "${A[@]}" \
    --design capacity --growth-cap "$g"
done
refuse "--growth-cap twice" "option '--growth-cap' given more than once" analyze "${A[@]}" --design capacity \
  --growth-cap 0.5 --growth-cap 0.6
refuse "--growth-cap without --design" "--growth-cap is only for --design" analyze "${A[@]}" --growth-cap 0.5

# --- analyze --trace ------------------------------------------------------------------------------
T=(--model "$F/sched.yaml")
refuse "--trace empty" "--trace '': expected FILE or NAME=FILE, found nothing" analyze "${T[@]}" --trace ""
refuse "--trace NAME= (no file)" "--trace s1=: no file after 's1='" analyze "${T[@]}" --trace s1=
refuse "--trace unknown sensor" "'lidar' is not a sensor" analyze "${T[@]}" --trace "lidar=$F/events.csv"
refuse "--trace NAME twice" "sensor 's1' has two traces" analyze "${T[@]}" --trace "s1=$F/events.csv" \
  --trace "s1=$F/events.csv"
refuse "--trace missing file" "$F/nowhere.csv" analyze "${T[@]}" --trace "s1=$F/nowhere.csv"
refuse "--trace not an events file" "$F/notevents.csv" analyze "${T[@]}" --trace "s1=$F/notevents.csv"
refuse "--block 0" "option '--block'" analyze "${T[@]}" --trace "s1=$F/events.csv" --block 0

# --- simulate / montecarlo: --actuator-channel, per-sensor --channel ----------------------------------
cp "$ROOT/config/models/zhou_actuated.yaml" "$F/act_model.yaml"  # one sensor, a control input
S=(--model "$F/two.yaml" --steps 20 --seed 1)
SA=(--model "$F/act_model.yaml" --steps 20 --seed 1)
refuse "--actuator-channel empty" "option '--actuator-channel': expected a file name, found ''" simulate "${SA[@]}" --actuator-channel "" --out "$OUT"
refuse "--actuator-channel twice" "option '--actuator-channel' given more than once" simulate "${SA[@]}" \
  --actuator-channel "$F/act.yaml" --actuator-channel "$F/act.yaml" --out "$OUT"
refuse "--actuator-channel missing file" "$F/nowhere.yaml" simulate "${SA[@]}" --actuator-channel "$F/nowhere.yaml" \
  --out "$OUT"
refuse "--actuator-channel broken YAML" "$F/broken.yaml" simulate "${SA[@]}" --actuator-channel "$F/broken.yaml" \
  --out "$OUT"
refuse "--channel unknown sensor" "'lidar' is not a sensor" simulate "${S[@]}" --channel "lidar=$F/b.yaml" --out "$OUT"
refuse "--channel NAME twice" "gnss" simulate "${S[@]}" --channel "gnss=$F/b.yaml" --channel "gnss=$F/b.yaml" \
  --out "$OUT"
C=(--experiment custom --model "$F/two.yaml" --settings "$F/kfio.yaml" --runs 4 --steps 10 --out "$OUT")
refuse "custom --channel unknown sensor" "'lidar' is not a sensor" montecarlo "${C[@]}" --channel "lidar=$F/b.yaml"
refuse "custom --actuator-channel on a model without control" \
  "--actuator-channel: model 'tracking_2d' has no control input" montecarlo "${C[@]}" --actuator-channel "$F/act.yaml"
refuse "custom --actuator-channel missing file" "$F/nowhere.yaml" montecarlo --experiment custom \
  --model "$F/act_model.yaml" --settings "$F/kfio.yaml" --runs 4 --steps 10 --out "$OUT" \
  --actuator-channel "$F/nowhere.yaml"

# --- algorithm names where a settings file is expected -------------------------------------------------
refuse "--settings neither a file nor an algorithm" "kalman: cannot open file (nor is 'kalman' an algorithm: kf," \
  replay --model "$F/two.yaml" --settings kalman --input "$F/events.csv" --output "$OUT/x.csv"
refuse "custom --settings neither a file nor an algorithm" "nor is 'kalman' an algorithm" montecarlo \
  --experiment custom --model "$F/two.yaml" --settings kfio,kalman --runs 4 --steps 10 --out "$OUT"
refuse "custom --settings the same name twice" "two estimators named 'kfio'" montecarlo \
  --experiment custom --model "$F/two.yaml" --settings "kfio,$F/kfio.yaml" --runs 4 --steps 10 --out "$OUT"

# --- montecarlo --covariance-only ---------------------------------------------------------------------
cp "$ROOT/config/estimators/aoe.yaml" "$F/aoe.yaml"
refuse "--covariance-only on a paper experiment" \
  "option '--covariance-only' is only for --experiment custom, covariance or sweep" montecarlo \
  --experiment zhou_fig1 --covariance-only --runs 4 --steps 10 --out "$OUT"
refuse "--covariance-only with a value" "option '--covariance-only' takes no value" montecarlo "${C[@]}" \
  --covariance-only=yes
refuse "covariance with an estimator whose P depends on the data" "estimator 'aoe' (aoe)" montecarlo \
  --experiment covariance --model "$F/two.yaml" --settings "$F/kfio.yaml,$F/aoe.yaml" --runs 4 --steps 10 --out "$OUT"
refuse "covariance without --settings" "experiment covariance needs --settings" montecarlo \
  --experiment covariance --model "$F/two.yaml" --runs 4 --steps 10 --out "$OUT"

# --- montecarlo --axis ------------------------------------------------------------------------------
W=(--experiment sweep --model "$F/two.yaml" --settings "$F/kfio.yaml" --runs 4 --steps 10 --out "$OUT")
refuse "--axis empty" "--axis" montecarlo "${W[@]}" --axis ""
refuse "--axis without =" "--axis" montecarlo "${W[@]}" --axis gnss.arrival_rate
refuse "--axis unknown sensor" "lidar" montecarlo "${W[@]}" --axis lidar.arrival_rate=0.2:0.8:3
refuse "--axis unknown parameter" "loss_rate" montecarlo "${W[@]}" --axis gnss.loss_rate=0.2:0.8:3
refuse "--axis value out of [0, 1]" "--axis" montecarlo "${W[@]}" --axis gnss.arrival_rate=0.2:1.5:3
refuse "--axis count 0" "--axis" montecarlo "${W[@]}" --axis gnss.arrival_rate=0.2:0.8:0
refuse "--axis count not a number" "--axis" montecarlo "${W[@]}" --axis gnss.arrival_rate=0.2:0.8:x
refuse "--axis LO not a number" "--axis" montecarlo "${W[@]}" --axis gnss.arrival_rate=low:0.8:3
refuse "--axis the same axis twice" "gnss.arrival_rate" montecarlo "${W[@]}" --axis gnss.arrival_rate=0.2:0.8:3 \
  --axis gnss.arrival_rate=0.1:0.9:3
refuse "--axis three times" "--axis" montecarlo "${W[@]}" --axis gnss.arrival_rate=0.2:0.8:2 \
  --axis camera.arrival_rate=0.2:0.8:2 --axis camera.recovery_rate=0.2:0.8:2
refuse "--axis recovery_rate of an i.i.d. link" "recovery_rate" montecarlo "${W[@]}" \
  --axis gnss.recovery_rate=0.2:0.8:3
refuse "--axis on another experiment" "option '--axis' is only for --experiment sweep" montecarlo "${C[@]}" \
  --axis gnss.arrival_rate=0.2:0.8:3
refuse "sweep without --axis" "experiment sweep needs --axis" montecarlo "${W[@]}"

# --- montecarlo --shard / merge -----------------------------------------------------------------------
Z=(--experiment zhou_fig1 --runs 4 --steps 10 --out "$OUT")
refuse "--shard empty" "option '--shard': expected K/N" montecarlo "${Z[@]}" --shard ""
refuse "--shard twice" "option '--shard' given more than once" montecarlo "${Z[@]}" --shard 1/2 --shard 2/2
refuse "--shard 3/2" "option '--shard': expected K/N" montecarlo "${Z[@]}" --shard 3/2
refuse "merge empty directory name" "no such directory" montecarlo merge "" --out "$OUT"
refuse "merge --out twice" "option '--out' given more than once" montecarlo merge "$F" --out "$OUT" --out "$OUT"

# --- make_model ------------------------------------------------------------------------------------
M=(--motion constant_velocity --rate 20 --accel-density 0.25 --output "$OUT/m.yaml")
refuse "--dims empty" "option '--dims'" make_model "${M[@]}" --dims "" --sensor gps:position:1
refuse "--dims 0" "--dims: expected 1, 2 or 3, found 0" make_model "${M[@]}" --dims 0 --sensor gps:position:1
refuse "--dims x" "option '--dims'" make_model "${M[@]}" --dims x --sensor gps:position:1
refuse "--dims twice" "option '--dims' given more than once" make_model "${M[@]}" --dims 2 --dims 3 \
  --sensor gps:position:1
refuse "--rate empty" "option '--rate'" make_model --motion constant_velocity --accel-density 0.25 --dims 2 \
  --rate "" --sensor gps:position:1 --output "$OUT/m.yaml"
refuse "--rate -1" "--rate: expected a finite number of Hz > 0, found -1" make_model --motion constant_velocity \
  --accel-density 0.25 --dims 2 --rate -1 --sensor gps:position:1 --output "$OUT/m.yaml"
refuse "--rate nan" "--rate: expected a finite number of Hz > 0" make_model --motion constant_velocity \
  --accel-density 0.25 --dims 2 --rate nan --sensor gps:position:1 --output "$OUT/m.yaml"
refuse "--accel-density 0" "--accel-density: expected a finite spectral density > 0" make_model \
  --motion constant_velocity --rate 20 --accel-density 0 --dims 2 --sensor gps:position:1 --output "$OUT/m.yaml"
refuse "--sensor empty" "option '--sensor': expected NAME:QUANTITY:SIGMA, found ''" make_model "${M[@]}" --dims 2 \
  --sensor ""
refuse "--sensor empty name" "--sensor ':position:1' name: expected a non-empty name" make_model "${M[@]}" --dims 2 \
  --sensor :position:1
refuse "--sensor name twice" "--sensor 'gps:velocity:1' name: duplicate sensor name 'gps' (also --sensor 'gps:position:1' name)" \
  make_model "${M[@]}" --dims 2 --sensor gps:position:1 --sensor gps:velocity:1
refuse "--sensor unknown quantity" "--sensor 'gps:speed:1' quantity: expected position or velocity" make_model \
  "${M[@]}" --dims 2 --sensor gps:speed:1
refuse "--sensor acceleration on constant_velocity" "--sensor 'imu:acceleration:1' quantity" make_model "${M[@]}" \
  --dims 2 --sensor imu:acceleration:1
refuse "--sensor sigma 0" "--sensor 'gps:position:0' sigma: expected a finite standard deviation > 0" make_model \
  "${M[@]}" --dims 2 --sensor gps:position:0
refuse "--sensor sigma inf" "--sensor 'gps:position:inf' sigma" make_model "${M[@]}" --dims 2 --sensor gps:position:inf
refuse "--sensor sigma x" "option '--sensor' 'gps:position:x': SIGMA: expected a number, found 'x'" make_model \
  "${M[@]}" --dims 2 --sensor gps:position:x
refuse "--x0 wrong count" "--x0: expected 4 entries" make_model "${M[@]}" --dims 2 --sensor gps:position:1 --x0 1,2
refuse "--x0 empty entry" "option '--x0': entry 1: expected a number, found ''" make_model "${M[@]}" --dims 2 \
  --sensor gps:position:1 --x0 1,,2,3
refuse "--p0-position -1" "--p0-position: expected a finite variance >= 0" make_model "${M[@]}" --dims 2 \
  --sensor gps:position:1 --p0-position -1
refuse "--p0-acceleration on constant_velocity" "option '--p0-acceleration' is only for a constant_acceleration model" \
  make_model "${M[@]}" --dims 2 --sensor gps:position:1 --p0-acceleration 1
refuse "--accel-density on constant_acceleration" "option '--accel-density' is not for a constant_acceleration model" \
  make_model --motion constant_acceleration --rate 20 --jerk-density 1 --accel-density 1 --dims 2 \
  --sensor gps:position:1 --output "$OUT/m.yaml"

# --- make_model --motion omni_2d: errors name the option as typed, not sensors[0].states --------------
O=(--motion omni_2d --rate 20 --process-noise 0.01 --output "$OUT/m.yaml")
refuse "omni --sensor without states" \
  "omni model 'robot': --sensor 'odom::0.05' states: expected names of states of omni_2d (x, y, yaw, vx, vy, vyaw, ax, ay) separated by commas, found none" \
  make_model "${O[@]}" --sensor odom::0.05
refuse "omni --sensor with an empty state" "--sensor 'odom:vx,,vy:0.05' states: expected names of states of omni_2d" \
  make_model "${O[@]}" --sensor odom:vx,,vy:0.05
refuse "omni --sensor sigma 0" "--sensor 'odom:vx:0' sigma: expected finite standard deviations > 0, found 0" \
  make_model "${O[@]}" --sensor odom:vx:0
refuse "omni --sensor name twice" "--sensor 'odom:vy:1' name: duplicate sensor name 'odom' (also --sensor 'odom:vx:1' name)" \
  make_model "${O[@]}" --sensor odom:vx:1 --sensor odom:vy:1
refuse "omni --x0 wrong count" "omni model 'robot': --x0: expected 8 entries" make_model "${O[@]}" --sensor odom:vx:1 \
  --x0 1,2

# --- a built-in motion's period: one step of it must be finite (named, not A(i,j) = nan) -----------
"$BIN/make_model" --motion omni_2d --rate 20 --process-noise 0.01 --sensor odom:vx,vy,vyaw:0.05 \
  --sensor gps:x,y:0.5 --name rover --output "$F/rover.yaml" >/dev/null
sed 's/^period: .*/period: 1e300/' "$F/rover.yaml" >"$F/rover_1e300.yaml"
P=$(grep -n '^period:' "$F/rover.yaml" | cut -d: -f1)
refuse "a motion's period over which a step is not finite" \
  "$F/rover_1e300.yaml:$P: period: expected a number of seconds over which one step of omni_2d is finite, found 1e+300 (its Jacobian F has period^2 / 2 terms: F(0,6) = inf)" \
  analyze --model "$F/rover_1e300.yaml"
refuse "a motion's period over which a step is not finite" "$F/rover_1e300.yaml:$P: period: expected a number of seconds" \
  simulate --model "$F/rover_1e300.yaml" --steps 10 --seed 1 --out "$OUT"
refuse "omni --rate at which a step is not finite" \
  "omni model 'robot': --rate: its period 1 / rate: expected a number of seconds over which one step of omni_2d is finite" \
  make_model --motion omni_2d --rate 1e-300 --process-noise 0.01 --sensor odom:vx:1 --output "$OUT/m.yaml"
refuse "omni --rate at which the noise of a step is not finite" \
  "omni model 'robot': --rate: its period 1 / rate: expected a number of seconds over which the process noise of a step, Q period, is finite, found 999999999.9999999 (Q(0,0) = 1e+300 per second)" \
  make_model --motion omni_2d --rate 1e-9 --process-noise 1e300 --sensor odom:vx:1 --output "$OUT/m.yaml"

# --- analyze --at: the option and what it holds, not "linearisation of model ..." ---------------------
sed 's/^period: .*/period: 10/' "$F/rover.yaml" >"$F/rover_slow.yaml"
refuse "--at of the wrong size" \
  "option '--at': expected a finite state of 8 values (omni_2d: x, y, yaw, vx, vy, vyaw, ax, ay), found 3 (1, 2, 3)" \
  analyze --model "$F/rover.yaml" --at 1,2,3
refuse "--at whose Jacobian overflows (1e308 m/s over 10 s)" \
  "option '--at': the Jacobian of omni_2d there over 10 s is not finite (F(1,2) = inf): expected a state of smaller values, found [0, 0, 0, 1e+308, 0, 0, 0, 0]" \
  analyze --model "$F/rover_slow.yaml" --at 0,0,0,1e308,0,0,0,0

# --- what replaced an inf or a text answer -------------------------------------------------------------
# the scheduled example with s1's link too poor: s2 sees none of s1's modes, so no rate of s2's link
# keeps E[P] bounded (its needed rate is +infinity), and each sensor alone leaves the other's modes
# dead-reckoned
cp "$ROOT/config/channels/bernoulli_0.7.yaml" "$F/b07.yaml"
run_rc rc "$BIN/analyze" --model "$F/sched.yaml" --channel "s1=$F/b07.yaml" --channel "s2=$F/b.yaml"
check "analyze: a per-sensor needed rate of +infinity is written in words, never inf" \
  bash -c "[ $rc = 0 ] && grep -qF 's2: arrival rate 0.8, no stable rate: others fixed; unstable even at rate 1' '$WORK/out.txt' &&
    ! grep -qwE 'inf|nan' '$WORK/out.txt'"
run_rc rc "$BIN/analyze" --model "$F/sched.yaml" --channel "s1=$F/b07.yaml" --channel "s2=$F/b.yaml" --json
check "analyze --json: that rate is null, no stable interval; each sensor alone leaves modes dead-reckoned: unbounded at every rate" \
  /usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
m = {l["sensor"]: l["margin"] for l in d["links"]}
s = d["sensors"]
sys.exit(0 if m["s2"]["converges_at"] is None and m["s2"]["margin"] is None and m["s2"]["stable_intervals"] == []
         and m["s1"]["converges_at"] is not None and m["s1"]["margin"] < 0
         and all(x["dead_reckoned"] and x["unbounded_at_every_rate"] and x["verdict"]["kind"] == "unstable"
                 and x["observed"]["verdict"]["kind"] == x["links_verdict"]["kind"] for x in s)
         and not d["all_sensors"]["dead_reckoned"] else 1)' "$WORK/out.txt"
run_rc rc "$BIN/analyze" --model "$ROOT/config/models/unstable_two_links.yaml" --design total_rate --json
check "analyze --design --json prints JSON: the design's rates per sensor" /usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))["design"]
r = {s["name"]: s["arrival_rate"] for s in d["sensors"]}
sys.exit(0 if d["cost"] == "total_rate" and d["applicable"] and abs(r["camera"] - 0.6) < 1e-6 else 1)' "$WORK/out.txt"
run_rc rc "$BIN/analyze" --model "$F/sched.yaml" --design total_rate --json
check "analyze --design --json where the design does not apply: JSON with the reason" /usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))["design"]
sys.exit(0 if not d["applicable"] and "sensor schedule" in d["note"] else 1)' "$WORK/out.txt"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
