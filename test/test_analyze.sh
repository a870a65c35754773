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

if [ $fail = 0 ]; then echo "test_analyze: all passed"; fi
exit $fail
