#!/usr/bin/env bash
# End-to-end checks of the command-line tools simulate, replay and score.
#   usage: test_tools.sh TOOLS_DIR REPO_ROOT
# Prints "N passed, M failed" and exits non-zero when any check failed.
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 TOOLS_DIR REPO_ROOT" >&2
  exit 2
fi
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
for tool in simulate replay score; do
  if [ ! -x "$BIN/$tool" ]; then
    echo "missing tool $BIN/$tool" >&2
    exit 2
  fi
done

WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_tools.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

ZHOU=$ROOT/config/models/zhou_example.yaml
AOE=$ROOT/config/models/aoe_example.yaml
BERNOULLI=$ROOT/config/channels/bernoulli_0.2.yaml
BURSTY=$ROOT/config/channels/gilbert_elliott_bursty.yaml
EST=$ROOT/config/estimators

passed=0
failed=0
pass() { passed=$((passed + 1)); echo "ok   $1"; }
fail() { failed=$((failed + 1)); echo "FAIL $1"; }
# check NAME COMMAND...: passes when the command succeeds.
check() {
  local name=$1
  shift
  if "$@"; then pass "$name"; else fail "$name"; fi
}
# run_rc VAR COMMAND...: runs a command (stdout to $WORK/out.txt, stderr to $WORK/err.txt) and
# stores its exit code in VAR without tripping set -e.
run_rc() {
  local __var=$1
  shift
  local __rc=0
  "$@" >"$WORK/out.txt" 2>"$WORK/err.txt" || __rc=$?
  printf -v "$__var" '%s' "$__rc"
}
lines() { wc -l <"$1" | tr -d ' '; }
# rc_and_grep RC EXPECTED PATTERN FILE: the exit code is EXPECTED and FILE matches PATTERN.
rc_and_grep() { [ "$1" = "$2" ] && grep -Eq "$3" "$4"; }
differ() { ! cmp -s "$1" "$2"; }

# --- simulate + replay + score on the zhou example -------------------------------------------
Z=$WORK/zhou
run_rc rc "$BIN/simulate" --model "$ZHOU" --channel "$BERNOULLI" --steps 2000 --seed 11 --out "$Z"
check "simulate zhou_example exits 0" [ "$rc" = 0 ]
cat "$WORK/out.txt"
check "simulate prints a summary" grep -q "2000 steps, arrival rate" "$WORK/out.txt"
check "input.csv has header + 2000 rows" [ "$(lines "$Z/input.csv")" = 2001 ]
check "truth.csv has header + 2000 rows" [ "$(lines "$Z/truth.csv")" = 2001 ]
check "input.csv header" [ "$(head -1 "$Z/input.csv")" = "k,gamma,y1" ]
check "truth.csv header" [ "$(head -1 "$Z/truth.csv")" = "k,x1,x2,nu" ]
check "input.csv has losses" grep -q '^[0-9]*,0,' "$Z/input.csv"

for alg in kf kfio rseio; do
  run_rc rc "$BIN/replay" --model "$ZHOU" --settings "$EST/$alg.yaml" --input "$Z/input.csv" --output "$Z/$alg.csv"
  check "replay $alg exits 0" [ "$rc" = 0 ]
  check "replay $alg writes header + 2000 rows" [ "$(lines "$Z/$alg.csv")" = 2001 ]
done
check "replay output header" [ "$(head -1 "$Z/kf.csv")" = "k,gamma,x1,x2,P11,P12,P21,P22,trace" ]

run_rc rc "$BIN/score" --truth "$Z/truth.csv" --estimate kf="$Z/kf.csv" --estimate kfio="$Z/kfio.csv" \
  --estimate rseio="$Z/rseio.csv"
check "score exits 0" [ "$rc" = 0 ]
cat "$WORK/out.txt"
for alg in kf kfio rseio; do
  check "score prints a row for $alg" grep -Eq "^$alg +2000 " "$WORK/out.txt"
done
run_rc rc "$BIN/score" --truth "$Z/truth.csv" --estimate kfio="$Z/kfio.csv" --from 101 --csv
check "score --csv --from 101" grep -q '^kfio,1900,' "$WORK/out.txt"

# --- reproducibility ----------------------------------------------------------------------------
run_rc rc "$BIN/simulate" --model "$ZHOU" --channel "$BERNOULLI" --steps 2000 --seed 11 --out "$WORK/zhou2"
check "same seed: byte-identical input.csv" cmp -s "$Z/input.csv" "$WORK/zhou2/input.csv"
check "same seed: byte-identical truth.csv" cmp -s "$Z/truth.csv" "$WORK/zhou2/truth.csv"
run_rc rc "$BIN/simulate" --model "$ZHOU" --channel "$BERNOULLI" --steps 2000 --seed 12 --out "$WORK/zhou3"
check "other seed: different input.csv" differ "$Z/input.csv" "$WORK/zhou3/input.csv"

# --- bad input: exit 2, the line named, no output file and no temporary file ---------------------
B=$WORK/bad
mkdir -p "$B"
awk -F, -v OFS=, 'NR == 7 { $3 = "abc" } { print }' "$Z/input.csv" >"$B/corrupt.csv"
run_rc rc "$BIN/replay" --model "$ZHOU" --settings "$EST/kfio.yaml" --input "$B/corrupt.csv" --output "$B/out.csv"
cat "$WORK/err.txt"
check "corrupted CSV: exit code 2" [ "$rc" = 2 ]
check "corrupted CSV: error names line 7" grep -q "corrupt.csv:7: y1: " "$WORK/err.txt"
check "corrupted CSV: no output file" [ ! -e "$B/out.csv" ]
check "corrupted CSV: no temporary file" [ -z "$(find "$B" -name 'out.csv*')" ]

printf 'name: bad\nA: [[1, 0]]\nC: [[1, 0]]\nR: [[1]]\nQ: [[1, 0], [0, 1]]\nx0: [0, 0]\nP0: [[1, 0], [0, 1]]\n' \
  >"$B/bad_model.yaml"
run_rc rc "$BIN/replay" --model "$B/bad_model.yaml" --settings "$EST/kfio.yaml" --input "$Z/input.csv" \
  --output "$B/out2.csv"
cat "$WORK/err.txt"
check "bad model file: exit code 2" [ "$rc" = 2 ]
check "bad model file: error names the file and the key" grep -q "bad_model.yaml:2: A: " "$WORK/err.txt"
check "bad model file: no output file" [ -z "$(find "$B" -name 'out2.csv*')" ]
run_rc rc "$BIN/simulate" --model "$B/bad_model.yaml" --channel "$BERNOULLI" --steps 10 --seed 1 --out "$B/sim"
check "simulate with a bad model file: exit code 2" [ "$rc" = 2 ]
run_rc rc "$BIN/simulate" --model "$B/missing.yaml" --channel "$BERNOULLI" --steps 10 --seed 1 --out "$B/sim"
check "simulate with a missing model file: exit code 2" [ "$rc" = 2 ]

# divergence: a plant whose covariance overflows within a few lost samples
printf 'name: blowup\nA: [[1e60]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nx0: [0]\nP0: [[1]]\n' >"$B/blowup.yaml"
printf 'k,gamma,y1\n1,1,0\n2,0,\n3,0,\n4,0,\n5,0,\n6,0,\n7,0,\n' >"$B/blowup.csv"
run_rc rc "$BIN/replay" --model "$B/blowup.yaml" --settings "$EST/kfio.yaml" --input "$B/blowup.csv" \
  --output "$B/blowup_out.csv"
cat "$WORK/err.txt"
check "divergence: exit code 3 and the step named" rc_and_grep "$rc" 3 "diverged at step k = [0-9]+" "$WORK/err.txt"
check "divergence: no output file" [ -z "$(find "$B" -name 'blowup_out.csv*')" ]

run_rc rc "$BIN/replay" --model "$ZHOU" --settings "$EST/kfio.yaml" --input "$Z/input.csv" --output "$B/o.csv" --bogus 1
check "unknown option: exit code 2" [ "$rc" = 2 ]
check "unknown option: usage printed" grep -q "usage: replay" "$WORK/err.txt"
run_rc rc "$BIN/simulate" --model "$ZHOU" --channel "$BERNOULLI" --steps ten --seed 1 --out "$B/sim"
check "non-numeric --steps: exit code 2" [ "$rc" = 2 ]
run_rc rc "$BIN/score" --help
check "--help: exit code 0 and usage" rc_and_grep "$rc" 0 "usage: score" "$WORK/out.txt"

# --- the aoe example: bursty sensor link, lossy actuator link, aoe and ack_kf -------------------
# (the plant is open-loop unstable, so keep the horizon short enough not to overflow)
A=$WORK/aoe
run_rc rc "$BIN/simulate" --model "$AOE" --channel "$BURSTY" --actuator-channel "$BURSTY" --steps 500 --seed 5 \
  --out "$A"
cat "$WORK/out.txt"
check "simulate aoe_example with an actuator channel exits 0" [ "$rc" = 0 ]
check "aoe input.csv has u1 and no nu column" [ "$(head -1 "$A/input.csv")" = "k,gamma,y1,y2,u1" ]
check "aoe truth.csv has lost commands" grep -q ',0$' "$A/truth.csv"
run_rc rc "$BIN/replay" --model "$AOE" --settings "$EST/aoe.yaml" --input "$A/input.csv" --output "$A/aoe.csv"
check "replay aoe exits 0" [ "$rc" = 0 ]
printf 'algorithm: ack_kf\n' >"$A/ack_kf.yaml"
run_rc rc "$BIN/replay" --model "$AOE" --settings "$A/ack_kf.yaml" --input "$A/input.csv" --output "$A/ack.csv" \
  --truth "$A/truth.csv"
check "replay ack_kf with --truth exits 0" [ "$rc" = 0 ]
run_rc rc "$BIN/replay" --model "$AOE" --settings "$A/ack_kf.yaml" --input "$A/input.csv" --output "$A/ack2.csv"
check "replay ack_kf without nu: exit code 2 and message" rc_and_grep "$rc" 2 "ack_kf needs nu" "$WORK/err.txt"
check "replay ack_kf without nu: no output file" [ ! -e "$A/ack2.csv" ]
run_rc rc "$BIN/score" --truth "$A/truth.csv" --estimate aoe="$A/aoe.csv" --estimate ack_kf="$A/ack.csv"
cat "$WORK/out.txt"
check "score prints a row for aoe" rc_and_grep "$rc" 0 "^aoe +500 " "$WORK/out.txt"
check "score prints a row for ack_kf" rc_and_grep "$rc" 0 "^ack_kf +500 " "$WORK/out.txt"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
