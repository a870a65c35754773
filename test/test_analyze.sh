#!/bin/bash
# Tests of the analyze tool. Usage: test_analyze.sh BIN_DIR PACKAGE_SOURCE_DIR
set -u
BIN="$1/analyze"
SRC="$2"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
fail=0
check() { # description, expected exit code, command...
  local desc="$1" want="$2"
  shift 2
  "$@" >"$TMP/out" 2>"$TMP/err"
  local got=$?
  if [ "$got" != "$want" ]; then
    echo "FAIL: $desc: exit $got, expected $want"; cat "$TMP/err"; fail=1
  fi
}

for m in "$SRC"/config/models/*.yaml; do
  check "$(basename "$m") without channel" 0 "$BIN" --model "$m"
  for c in "$SRC"/config/channels/*.yaml; do
    check "$(basename "$m") $(basename "$c")" 0 "$BIN" --model "$m" --channel "$c"
    check "$(basename "$m") $(basename "$c") json" 0 "$BIN" --model "$m" --channel "$c" --json
    python3 -c 'import json,sys; json.load(sys.stdin)' <"$TMP/out" || { echo "FAIL: invalid JSON for $m $c"; fail=1; }
  done
done

# aoe example: the Markov threshold 1 - rho^-2 = 0.400005 and a stable i.i.d. verdict at gamma-bar = 0.8.
"$BIN" --model "$SRC/config/models/aoe_example.yaml" --channel "$SRC/config/channels/bernoulli_0.2.yaml" --json >"$TMP/aoe.json"
python3 - "$TMP/aoe.json" <<'PY' || fail=1
import json, sys
d = json.load(open(sys.argv[1]))
s = d["all_sensors"]
ok = abs(s["recovery_exact"] - (1 - 1.291 ** -2)) < 1e-9 and abs(s["exact_rate"] - 0.400005) < 1e-6
ok = ok and s["verdict"]["kind"] == "stable" and abs(s["margin"] - (0.8 - (1 - 1.291 ** -2))) < 1e-9
ok = ok and s["aoe_theorem5"]["kind"] == "stable" and abs(d["spectral_radius"] - 1.291) < 1e-12
if not ok:
    print("FAIL: aoe example values", s)
    sys.exit(1)
PY
# zhou example: stable A, rseio checklist with the rseio estimator.
"$BIN" --model "$SRC/config/models/zhou_example.yaml" --channel "$SRC/config/channels/bernoulli_0.2.yaml" \
  --estimator "$SRC/config/estimators/rseio.yaml" --json >"$TMP/zhou.json"
python3 - "$TMP/zhou.json" <<'PY' || fail=1
import json, sys
d = json.load(open(sys.argv[1]))
if d["all_sensors"]["verdict"]["kind"] != "stable" or d["rseio"]["kind"] != "stable" or d["estimator"] != "rseio":
    print("FAIL: zhou example", d["all_sensors"]["verdict"], d["rseio"])
    sys.exit(1)
PY

# A link per sensor: A = diag(2, 3), sensor s1 sees the mode 2, s2 the mode 3 (stable iff
# lambda_1 > 3/4 and lambda_2 > 8/9), each with its own file.
cat >"$TMP/two.yaml" <<'YAML'
name: two_modes
period: 0.1
A: [[2, 0], [0, 3]]
Q: [[1, 0], [0, 1]]
sensors:
  - {name: s1, C: [[1, 0]], R: [[1]]}
  - {name: s2, C: [[0, 1]], R: [[1]]}
x0: [0, 0]
P0: [[1, 0], [0, 1]]
YAML
printf 'model: bernoulli\nloss: 0.2\n' >"$TMP/loss_0.2.yaml"
printf 'model: bernoulli\nloss: 0.1\n' >"$TMP/loss_0.1.yaml"
check "per-sensor channels" 0 "$BIN" --model "$TMP/two.yaml" --channel "s1=$TMP/loss_0.2.yaml" --channel "s2=$TMP/loss_0.1.yaml"
grep -q "^  s1: .*loss_0.2.yaml (--channel s1=" "$TMP/out" || { echo "FAIL: no link line for s1"; cat "$TMP/out"; fail=1; }
grep -q "^  s2: .*loss_0.1.yaml (--channel s2=" "$TMP/out" || { echo "FAIL: no link line for s2"; fail=1; }
grep -q "^  s1: arrival rate 0.8, needs 0.75" "$TMP/out" || { echo "FAIL: no margin line for s1"; cat "$TMP/out"; fail=1; }
grep -q "c_upper" "$TMP/out" || { echo "FAIL: no capacity line"; fail=1; }
check "per-sensor channels json" 0 "$BIN" --model "$TMP/two.yaml" --channel "s1=$TMP/loss_0.2.yaml" \
  --channel "s2=$TMP/loss_0.1.yaml" --json
python3 - "$TMP/out" <<'PY' || fail=1
import json, sys
d = json.load(open(sys.argv[1]))
l = d["links"]
ok = len(l) == 2 and [x["sensor"] for x in l] == ["s1", "s2"] and d["all_sensors"]["verdict"]["kind"] == "stable"
ok = ok and abs(l[0]["arrival_rate"] - 0.8) < 1e-12 and abs(l[1]["arrival_rate"] - 0.9) < 1e-12
ok = ok and abs(l[0]["margin"]["converges_at"] - 0.75) < 1e-6 and abs(l[1]["margin"]["converges_at"] - 8 / 9) < 1e-6
ok = ok and "s1=" in l[0]["origin"] and "no Gilbert-Elliott link" in l[0]["markov_threshold"]
ok = ok and d["channel"]["uniform"] is False and d["channel"]["capacity"] > d["channel"]["capacity_lower"]
if not ok:
    print("FAIL: per-sensor JSON", d["links"], d["all_sensors"]["verdict"])
    sys.exit(1)
PY
# One sensor on its own file, the other on the common one (and the other way round).
check "common and per-sensor channel" 0 "$BIN" --model "$TMP/two.yaml" --channel "$TMP/loss_0.1.yaml" --channel "s1=$TMP/loss_0.2.yaml"
grep -q "^  s2: .*loss_0.1.yaml" "$TMP/out" || { echo "FAIL: s2 does not get the common channel"; cat "$TMP/out"; fail=1; }
check "not a sensor" 2 "$BIN" --model "$TMP/two.yaml" --channel "gps=$TMP/loss_0.2.yaml"
grep -q "gps" "$TMP/err" || { echo "FAIL: the message does not name the unknown sensor"; cat "$TMP/err"; fail=1; }
check "sensor given twice" 2 "$BIN" --model "$TMP/two.yaml" --channel "s1=$TMP/loss_0.2.yaml" --channel "s1=$TMP/loss_0.1.yaml"

# Rotation by 90 degrees scaled by 1.2 on an on/off link with p = 0.5: stable for r in about
# (0.538, 0.962) only; the report gives the interval, never a single critical recovery rate.
cat >"$TMP/rot.yaml" <<'YAML'
name: rotation
period: 0.1
A: [[0, -1.2], [1.2, 0]]
Q: [[1, 0], [0, 1]]
C: [[1, 0]]
R: [[1]]
x0: [0, 0]
P0: [[1, 0], [0, 1]]
YAML
printf 'model: gilbert_elliott\np: 0.5\nr: 0.6\nloss_bad: 1.0\nloss_good: 0.0\n' >"$TMP/ge_0.6.yaml"
check "rotation" 0 "$BIN" --model "$TMP/rot.yaml" --channel "$TMP/ge_0.6.yaml"
grep -q "^  verdict  *stable" "$TMP/out" || { echo "FAIL: rotation verdict"; cat "$TMP/out"; fail=1; }
if grep -q "critical recovery rate  *inf" "$TMP/out"; then echo "FAIL: rotation reports a critical recovery rate inf"; fail=1; fi
check "rotation json" 0 "$BIN" --model "$TMP/rot.yaml" --channel "$TMP/ge_0.6.yaml" --json
python3 - "$TMP/out" <<'PY' || fail=1
import json, sys
d = json.load(open(sys.argv[1]))
m = d["links"][0]["margin"]
iv = m["stable_intervals"]
ok = m["quantity"] == "recovery rate" and m["half_line"] is False and len(iv) == 1
ok = ok and abs(iv[0][0] - 0.538451) < 1e-5 and abs(iv[0][1] - 0.961549) < 1e-5 and m["margin"] > 0
ok = ok and d["all_sensors"]["recovery_exact"] is None and len(d["all_sensors"]["recovery_stable_intervals"]) == 1
if not ok:
    print("FAIL: rotation JSON", d["links"][0], d["all_sensors"]["recovery_stable_intervals"])
    sys.exit(1)
PY

# Bad inputs: a model with a non-square A, a missing file, an unknown flag.
cat >"$TMP/bad.yaml" <<'YAML'
name: bad
period: 0.01
A: [[1, 0]]
Q: [[1]]
C: [[1]]
R: [[1]]
x0: [0]
P0: [[1]]
YAML
check "bad model" 2 "$BIN" --model "$TMP/bad.yaml"
grep -q "bad.yaml" "$TMP/err" || { echo "FAIL: the message does not name the file"; cat "$TMP/err"; fail=1; }
grep -q "A" "$TMP/err" || { echo "FAIL: the message does not name the key"; fail=1; }
check "missing model" 2 "$BIN" --model "$TMP/none.yaml"
check "unknown flag" 2 "$BIN" --model "$SRC/config/models/aoe_example.yaml" --bogus
check "help" 0 "$BIN" --help

# Link design: the README's commands, the answer on the cap, and its errors (exit 2, named).
check "design total_rate" 0 "$BIN" --model "$SRC/config/models/unstable_two_links.yaml" --design total_rate
grep -q "camera: arrival rate 0.6 " "$TMP/out" || { echo "FAIL: design: camera 0.6 (2.25 (1 - l) = 0.9)"; cat "$TMP/out"; fail=1; }
check "design capacity" 0 "$BIN" --model "$SRC/config/models/tracking_2d.yaml" --design capacity --growth-cap 0.5
check "design scheduled model" 0 "$BIN" --model "$SRC/config/models/scheduled_example.yaml" --design total_rate
grep -q "not applicable: a sensor schedule" "$TMP/out" || { echo "FAIL: design with a schedule"; fail=1; }
check "design bad cost" 2 "$BIN" --model "$SRC/config/models/tracking_2d.yaml" --design cheapest
grep -q "expected total_rate or capacity, found 'cheapest'" "$TMP/err" || { echo "FAIL: design cost message"; fail=1; }
check "design bad cap" 2 "$BIN" --model "$SRC/config/models/tracking_2d.yaml" --design capacity --growth-cap 1.5
grep -q "growth-cap: expected a number in (0, 1), found '1.5'" "$TMP/err" || { echo "FAIL: growth cap message"; fail=1; }
check "growth cap without design" 2 "$BIN" --model "$SRC/config/models/tracking_2d.yaml" --growth-cap 0.5

# Gan and Liu from a recorded arrival pattern (--trace): a rotation seen by c = [1 0] (R = 1) with
# the periodic pattern arrive, arrive, lost, lost, ... recorded as `rostopic echo -p` of ~events.
# With h = 4 every block sees both coordinates: excitation (1/2)/5 = 0.1 per block, lambda = 0.9,
# A3 holds for p = 1 and fails for p = 2 (norm 1). A replay input CSV gives every sensor's pattern.
cat >"$TMP/rot90.yaml" <<'YAML'
name: rot90
A: [[0, -1], [1, 0]]
Q: [[1, 0], [0, 1]]
C: [[1, 0]]
R: [[1]]
YAML
{
  echo "%time,field.header.seq,field.header.stamp,field.header.frame_id,field.seq,field.input_stamp,field.outcome,field.duplicated,field.state,field.delay,field.sampled_delay"
  for i in $(seq 0 399); do echo "$i,$i,$i,,$i,0,$(( i % 4 < 2 ? 0 : 1 )),False,0,0.0,0.0"; done
} >"$TMP/events.csv"
check "--trace NAME=events.csv" 0 "$BIN" --model "$TMP/rot90.yaml" --trace y="$TMP/events.csv" --block 4 --json
python3 - "$TMP/out" <<'PY' || fail=1
import json, sys
g = json.load(open(sys.argv[1]))["gan_liu"]
ok = len(g) == 1 and g[0]["sensor"] == "y" and g[0]["samples"] == 400 and g[0]["h"] == 4
ok = ok and abs(g[0]["lambda"] - 0.9) < 1e-12 and abs(g[0]["lambda_block_min"] - 0.1) < 1e-12
ok = ok and g[0]["a3"][0]["holds"] and not g[0]["a3"][1]["holds"] and g[0]["verdict"]["kind"] == "stable"
ok = ok and "conservative" in g[0]["caveat"]
if not ok:
    print("FAIL: Gan-Liu trace values", g)
    sys.exit(1)
PY
check "--trace text output" 0 "$BIN" --model "$TMP/rot90.yaml" --trace y="$TMP/events.csv" --block 4
grep -q "lambda = 0.9" "$TMP/out" || { echo "FAIL: the text output lacks lambda"; cat "$TMP/out"; fail=1; }
grep -q "very conservative" "$TMP/out" || { echo "FAIL: the text output lacks the caveat"; fail=1; }
printf 'k,gamma,y1\n1,1,0.5\n2,0,\n3,1,0.1\n4,1,0.2\n' >"$TMP/replay.csv"
check "--trace replay input" 0 "$BIN" --model "$TMP/rot90.yaml" --trace "$TMP/replay.csv" --json
python3 -c 'import json,sys; g=json.load(open(sys.argv[1]))["gan_liu"]; sys.exit(0 if g[0]["samples"] == 4 else 1)' "$TMP/out" \
  || { echo "FAIL: replay input trace"; fail=1; }
check "--trace with a NAME that is not a sensor" 2 "$BIN" --model "$TMP/rot90.yaml" --trace lidar="$TMP/events.csv"
grep -q "'lidar' is not a sensor of model 'rot90'" "$TMP/err" || { echo "FAIL: the message does not name lidar"; cat "$TMP/err"; fail=1; }
check "--trace events without field.outcome" 2 "$BIN" --model "$TMP/rot90.yaml" --trace y="$TMP/replay.csv"
grep -q "no column field.outcome" "$TMP/err" || { echo "FAIL: the message does not name the column"; cat "$TMP/err"; fail=1; }
check "--trace replay input with the wrong columns" 2 "$BIN" --model "$SRC/config/models/tracking_2d.yaml" --trace "$TMP/replay.csv"
grep -q "replay.csv" "$TMP/err" || { echo "FAIL: the message does not name the file"; cat "$TMP/err"; fail=1; }
check "--trace on a two-row sensor" 0 "$BIN" --model "$SRC/config/models/tracking_2d.yaml" --trace gnss="$TMP/events.csv"
grep -q "not applicable: Gan and Liu treat a scalar output" "$TMP/out" || { echo "FAIL: two-row sensor"; cat "$TMP/out"; fail=1; }

# Robot models (constant velocity, a Jordan block at 1 per axis): every model in config/models/ gets
# a decided verdict on every example channel (no "undecided"), and a constant-velocity model from
# make_model with a position and a velocity sensor says the position sensor needs any positive
# rate and the velocity sensor none; with the velocity sensor alone the positions are dead-reckoned.
for m in "$SRC"/config/models/*.yaml; do
  for c in "$SRC"/config/channels/*.yaml; do
    "$BIN" --model "$m" --channel "$c" --json 2>/dev/null | python3 -c '
import json, sys
d = json.load(sys.stdin)
for s in [d["all_sensors"]] + d["sensors"]:
    if s["verdict"]["kind"] == "undecided":
        print("FAIL: undecided verdict for", sys.argv[1], sys.argv[2], s["name"], s["verdict"]["reason"])
        sys.exit(1)
' "$(basename "$m")" "$(basename "$c")" || fail=1
  done
done
cat >"$TMP/cv.yaml" <<'YAML'
name: cv_1d
period: 0.1
A: [[1, 0.1], [0, 1]]
Q: [[0.01, 0], [0, 0.1]]
sensors:
  - {name: gnss, C: [[1, 0]], R: [[1]]}
  - {name: odom, C: [[0, 1]], R: [[0.01]]}
x0: [0, 0]
P0: [[1, 0], [0, 1]]
YAML
check "constant velocity, slow position link" 0 "$BIN" --model "$TMP/cv.yaml" --channel gnss="$SRC/config/channels/bernoulli_0.2.yaml" \
  --channel odom="$SRC/config/channels/gilbert_elliott_bursty.yaml" --json
python3 - "$TMP/out" <<'PY' || fail=1
import json, sys
d = json.load(open(sys.argv[1]))
gnss, odom = d["links"][0]["margin"], d["links"][1]["margin"]
ok = d["all_sensors"]["verdict"]["kind"] == "stable" and d["all_sensors"]["exact_rate"] == 0
ok = ok and gnss["any_positive"] and gnss["converges_at"] == 0 and gnss["diverges_at"] == 0
ok = ok and not odom["any_positive"] and odom["converges_at"] == 0 and d["dead_reckoned"] == ""
ok = ok and d["sensors"][1]["dead_reckoned"].startswith("1 mode(s) with |lambda| >= 1 (1) of state 0 ")
# the velocity sensor alone: the position grows regardless of its link (unstable at every rate)
ok = ok and d["sensors"][1]["verdict"]["kind"] == "unstable" and d["sensors"][1]["unbounded_at_every_rate"]
ok = ok and d["sensors"][1]["links_verdict"]["kind"] == "stable" and d["sensors"][1]["dead_states"] == "state 0"
ok = ok and d["sensors"][1]["observed"]["verdict"]["kind"] == "stable" and d["all_sensors"]["observed"] is None
if not ok:
    print("FAIL: constant velocity margins", d["links"], d["sensors"][1]["dead_reckoned"])
    sys.exit(1)
PY
check "constant velocity text" 0 "$BIN" --model "$TMP/cv.yaml" --channel gnss="$SRC/config/channels/bernoulli_0.2.yaml"
grep -q "gnss: arrival rate 0.8, needs > 0 (any positive rate; unbounded at 0)" "$TMP/out" || { echo "FAIL: needs > 0"; cat "$TMP/out"; fail=1; }
grep -q "odom: arrival rate 1, needs 0 (bounded even without it)" "$TMP/out" || { echo "FAIL: needs 0"; cat "$TMP/out"; fail=1; }
sed 's/  - {name: gnss, C: \[\[1, 0\]\], R: \[\[1\]\]}//' "$TMP/cv.yaml" >"$TMP/cv_vel.yaml"
check "velocity only: dead-reckoned position" 0 "$BIN" --model "$TMP/cv_vel.yaml" --channel "$SRC/config/channels/bernoulli_0.2.yaml"
# The position's variance grows linearly whatever the link does: E[P] is unbounded, so the verdict is
# unstable, the odometry's needed rate is none, and the links' verdict (the velocity) is stable.
grep -q "^dead-reckoned: 1 mode(s) with |lambda| >= 1 (1) of state 0 " "$TMP/out" || { echo "FAIL: dead-reckoned line"; cat "$TMP/out"; fail=1; }
grep -q "^  verdict                         unstable: state 0 grows regardless of the links" "$TMP/out" || { echo "FAIL: velocity-only verdict"; cat "$TMP/out"; fail=1; }
grep -q "^  links' verdict                  stable" "$TMP/out" || { echo "FAIL: velocity-only links' verdict"; cat "$TMP/out"; fail=1; }
grep -q "^  odom: arrival rate 0.8, needs: none (state 0 grows regardless of the links); the observed modes alone need 0" "$TMP/out" || { echo "FAIL: velocity-only needed rate"; cat "$TMP/out"; fail=1; }
check "velocity only: no link design" 0 "$BIN" --model "$TMP/cv_vel.yaml" --design total_rate
grep -q "not applicable: state 0 grows regardless of the links" "$TMP/out" || { echo "FAIL: velocity-only design"; cat "$TMP/out"; fail=1; }
grep -q "least-cost rates" "$TMP/out" && { echo "FAIL: velocity-only design prints rates"; cat "$TMP/out"; fail=1; }
check "velocity only: --verdict-only" 0 "$BIN" --model "$TMP/cv_vel.yaml" --channel "$SRC/config/channels/bernoulli_0.2.yaml" --verdict-only --json
python3 - "$TMP/out" <<'PY' || fail=1
import json, sys
d = json.load(open(sys.argv[1]))
m = d["links"][0]["margin"]
ok = d["verdict"]["kind"] == "unstable" and d["links_verdict"]["kind"] == "stable" and d["dead_states"] == "state 0"
ok = ok and m["converges_at"] is None and m["converges_at_observed"] == 0 and m["grows_regardless"] == "state 0"
if not ok:
    print("FAIL: --verdict-only velocity only", d)
    sys.exit(1)
PY
check "--verdict-only refuses --estimator" 2 "$BIN" --model "$TMP/cv_vel.yaml" --verdict-only \
  --estimator "$SRC/config/estimators/kfio.yaml"
grep -q "option '--estimator' is not for --verdict-only" "$TMP/err" || { echo "FAIL: --verdict-only --estimator"; cat "$TMP/err"; fail=1; }
check "--verdict-only refuses --design" 2 "$BIN" --model "$TMP/cv_vel.yaml" --verdict-only --design total_rate
grep -q "option '--verdict-only' is not for --design" "$TMP/err" || { echo "FAIL: --verdict-only --design"; cat "$TMP/err"; fail=1; }
# every example model and channel: --verdict-only gives the full report's verdict kinds and needed rates
for m in "$SRC"/config/models/*.yaml; do
  for c in "$SRC"/config/channels/bernoulli_0.2.yaml "$SRC"/config/channels/gilbert_elliott_bursty.yaml; do
    "$BIN" --model "$m" --channel "$c" --json >"$TMP/full.json" 2>/dev/null &&
      "$BIN" --model "$m" --channel "$c" --verdict-only --json >"$TMP/verdict.json" 2>/dev/null || { echo "FAIL: $m $c"; fail=1; continue; }
    python3 - "$TMP/full.json" "$TMP/verdict.json" "$(basename "$m") $(basename "$c")" <<'PY' || fail=1
import json, sys
full, v = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
ok = v["verdict"]["kind"] == full["all_sensors"]["verdict"]["kind"]
ok = ok and v["links_verdict"]["kind"] == full["all_sensors"]["links_verdict"]["kind"]
ok = ok and [l["margin"] for l in v["links"]] == [l["margin"] for l in full["links"]]
if not ok:
    print("FAIL: --verdict-only differs from the full report for", sys.argv[3])
    sys.exit(1)
PY
  done
done

if [ $fail = 0 ]; then echo "test_analyze: all passed"; fi
exit $fail
