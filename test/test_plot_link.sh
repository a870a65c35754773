#!/usr/bin/env bash
# Checks scripts/plot_link.py on fit_link's JSON: a generated trace CSV (a Gilbert link with delays)
# fitted with --json --series and drawn; two links of robot_localization's bag drawn into two files;
# and bad inputs (exit 2 naming the problem, no PNG written).
#   usage: test_plot_link.sh TOOLS_DIR REPO_ROOT
# Needs Debian's python3 with python3-matplotlib (run with /usr/bin/python3: a pyenv python lacks
# Debian's modules). Prints "N passed, M failed" and exits non-zero when any check failed.
set -euo pipefail

: "${2:?usage: test_plot_link.sh TOOLS_DIR REPO_ROOT}"
BIN=$(cd "$1" && pwd) ROOT=$(cd "$2" && pwd)
SCRIPT=$ROOT/scripts/plot_link.py
PY=/usr/bin/python3
[ -x "$PY" ] || PY=python3
if [ ! -f "$SCRIPT" ]; then
  echo "missing $SCRIPT" >&2
  exit 2
fi
WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_plot_link.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/check_lib.sh"
is_png() {
  [ -s "$1" ] && [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ]
}
no_traceback() { ! grep -q Traceback "$WORK/err.txt"; }

# A 50 Hz sender over 3000 slots behind a Gilbert link (p 0.05, r 0.3, seeded), each message received
# 20 ms plus an exponential delay of mean 5 ms after its stamp; seq k.
"$PY" - "$WORK/trace.csv" <<'PY'
import random, sys
rng, lost = random.Random(5), False
with open(sys.argv[1], "w") as f:
    f.write("stamp,receipt,seq\n")
    for k in range(3000):
        lost = (rng.random() >= 0.3) if lost else (rng.random() < 0.05)
        if not lost:
            s = 100 + k / 50.0
            f.write("%.6f,%.6f,%d\n" % (s, s + 0.02 + rng.expovariate(200.0), k))
PY
run_rc rc "$BIN/fit_link" --csv "$WORK/trace.csv" --json --series
check "fit_link --json --series on the trace" [ "$rc" = 0 ]
cp "$WORK/out.txt" "$WORK/fit.json"

run_rc rc "$PY" "$SCRIPT" "$WORK/fit.json" --out "$WORK/link.png"
check "plot_link exit 0" [ "$rc" = 0 ]
cat "$WORK/err.txt"
check "nothing on stderr" [ ! -s "$WORK/err.txt" ]
check "link.png is a PNG" is_png "$WORK/link.png"
check "stdout lists link.png" grep -qxF "$WORK/link.png" "$WORK/out.txt"

run_rc rc "$PY" "$SCRIPT" - --out "$WORK/stdin.png" <"$WORK/fit.json"
check "the fit read from stdin (-)" is_png "$WORK/stdin.png"

# Two links: one file each, _N before the extension; --link N draws one.
run_rc rc "$BIN/fit_link" --bag "$ROOT/test/data/test2.bag" --topic /imu/data --topic /jackal_velocity_controller/odom \
  --json --series
cp "$WORK/out.txt" "$WORK/two.json"
run_rc rc "$PY" "$SCRIPT" "$WORK/two.json" --out "$WORK/two.png"
check "two links: exit 0" [ "$rc" = 0 ]
check "two links: two_0.png" is_png "$WORK/two_0.png"
check "two links: two_1.png" is_png "$WORK/two_1.png"
check "two links: two files listed" [ "$(wc -l <"$WORK/out.txt" | tr -d ' ')" = 2 ]
run_rc rc "$PY" "$SCRIPT" "$WORK/two.json" --out "$WORK/one.png" --link 1
check "--link 1 draws one file" is_png "$WORK/one.png"

# --- bad input: exit 2, the problem named, no traceback, no PNG ---------------------------------
refuse() {
  local name=$1 pattern=$2
  shift 2
  rm -f "$WORK/bad.png"
  run_rc rc "$PY" "$SCRIPT" "$@" --out "$WORK/bad.png"
  if [ "$rc" = 2 ] && grep -qF -- "$pattern" "$WORK/err.txt" && no_traceback && [ ! -e "$WORK/bad.png" ]; then
    pass "$name"
  else
    fail "$name (exit $rc, expected 2 and '$pattern'; stderr below)"
    cat "$WORK/err.txt"
  fi
}
"$BIN/fit_link" --csv "$WORK/trace.csv" --json >"$WORK/noseries.json"
printf 'not json\n' >"$WORK/not.json"
printf '{"links": []}\n' >"$WORK/empty.json"
refuse "a fit without --series" "link 0 ($WORK/trace.csv) has no \"series\": run fit_link with --json --series" "$WORK/noseries.json"
refuse "not JSON" "$WORK/not.json: not JSON" "$WORK/not.json"
refuse "no links" "$WORK/empty.json: expected fit_link --json output" "$WORK/empty.json"
refuse "missing file" "$WORK/nowhere.json: " "$WORK/nowhere.json"
refuse "--link out of range" "--link 2: $WORK/two.json holds 2 link(s)" "$WORK/two.json" --link 2

echo "$passed passed, $failed failed"
[ "$failed" = 0 ]
