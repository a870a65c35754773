#!/usr/bin/env bash
# End-to-end checks of sharded Monte Carlo runs: `montecarlo ... --shard K/N` in separate processes,
# then `montecarlo merge`, against the unsharded run (the CSV files byte for byte, the JSON but for
# its threads and wall_seconds lines), for N = 1, 3, 7; and every refusal of the merge and of
# --shard with its exit code and the name in its message.
#   usage: test_shards.sh TOOLS_DIR REPO_ROOT
# Prints "N passed, M failed" and exits non-zero when any check failed.
set -euo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 TOOLS_DIR REPO_ROOT" >&2
  exit 2
fi
BIN=$(cd "$1" && pwd)
ROOT=$(cd "$2" && pwd)
MC=$BIN/montecarlo
if [ ! -x "$MC" ]; then
  echo "missing tool $MC" >&2
  exit 2
fi

WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_shards.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

# shared helpers: check, run_rc, differ, no_files, passed / failed
source "$(dirname "${BASH_SOURCE[0]}")/check_lib.sh"
# The JSON without the lines that may differ between a merge and an unsharded run.
untimed() { grep -vE '^  "(threads|wall_seconds)": ' "$1"; }
# same_json A B: identical but for threads and wall_seconds, and those are the only lines dropped.
same_json() {
  cmp -s <(untimed "$1") <(untimed "$2") &&
    [ "$(($(wc -l <"$1") - $(untimed "$1" | wc -l)))" = 2 ]
}
# refused NAME EXPECTED_RC PATTERN... : the last command (run_rc) exited with EXPECTED_RC and its
# stderr matches every pattern (fixed strings).
refused() {
  local name=$1 want=$2
  shift 2
  local ok=1 p
  [ "$rc" = "$want" ] || ok=0
  for p in "$@"; do grep -qF -- "$p" "$WORK/err.txt" || ok=0; done
  if [ "$ok" = 1 ]; then pass "$name"; else
    fail "$name (exit $rc, expected $want; stderr below)"
    cat "$WORK/err.txt"
  fi
}

# shards EXP_DIR N THREADS ARGS...: runs shards 1..N of the experiment in separate processes into
# EXP_DIR/nN; all must exit 0 and write only their shard file.
shards() {
  local dir=$1 n=$2 threads=$3 k ok=1
  shift 3
  for k in $(seq "$n"); do
    "$MC" "$@" --threads "$threads" --shard "$k/$n" --out "$dir/n$n" 2>"$WORK/err.txt" || ok=0
    [ -f "$dir/n$n/$EXP.shard-$k-of-$n.json" ] || ok=0
  done
  [ "$(find "$dir/n$n" -type f | wc -l)" = "$n" ] || ok=0
  [ "$ok" = 1 ]
}

# --- sharded runs equal the unsharded one ---------------------------------------------------------
# zhou_fig1: two Monte Carlo calls over one data set, 300 runs = 5 blocks (the last of 44 runs), so
# 2 of 7 shards are empty. zhou_fig2: four calls with per-run samples, 130 runs = 3 blocks.
# custom: a model and per-sensor links given as relative paths (the merge runs where the shards did).
# sweep: a 3 x 4 stability map (one Monte Carlo call of 150 runs = 3 blocks, the values of all 12 points) with
# a gilbert_elliott link's recovery rate on one axis. covariance (given as custom --covariance-only) and
# sweep_cov (sweep --covariance-only): the same without the plant.
mkdir -p "$WORK/in"
cp "$ROOT/config/models/tracking_2d.yaml" "$ROOT/config/channels/wifi_bursty.yaml" \
  "$ROOT/config/channels/bernoulli_0.2.yaml" "$ROOT/config/estimators/kf.yaml" "$ROOT/config/estimators/kfio.yaml" \
  "$ROOT/config/models/unstable_two_links.yaml" "$ROOT/config/channels/gilbert_elliott_bursty.yaml" "$WORK/in/"
CUSTOM=(--experiment custom --model in/tracking_2d.yaml --channel gnss=in/wifi_bursty.yaml
  --channel camera=in/bernoulli_0.2.yaml --settings in/kf.yaml,in/kfio.yaml --runs 200 --steps 60)
SWEEP=(--experiment sweep --model in/unstable_two_links.yaml --channel camera=in/gilbert_elliott_bursty.yaml
  --settings in/kfio.yaml,in/kf.yaml --axis gnss.arrival_rate=0.2:0.8:3 --axis camera.recovery_rate=0.1:0.7:4
  --runs 150 --steps 30)
cd "$WORK"
for LABEL in zhou_fig1 zhou_fig2 custom sweep covariance sweep_cov; do
  EXP=${LABEL%_cov}
  case $LABEL in
    zhou_fig1) ARGS=(--experiment zhou_fig1 --runs 300 --steps 50) ;;
    zhou_fig2) ARGS=(--experiment zhou_fig2 --runs 130 --steps 50 --seed 7) ;;
    custom) ARGS=("${CUSTOM[@]}") ;;
    sweep) ARGS=("${SWEEP[@]}") ;;
    covariance) ARGS=("${CUSTOM[@]}" --covariance-only) ;;
    sweep_cov) ARGS=("${SWEEP[@]}" --covariance-only) ;;
  esac
  D=$WORK/$LABEL
  run_rc rc "$MC" "${ARGS[@]}" --out "$D/full"
  check "$EXP: unsharded run exits 0" [ "$rc" = 0 ]
  for N in 1 3 7; do
    # threads differ between the shards and the unsharded run: the results must not
    check "$EXP: $N shards in $N processes exit 0, each writing only DIR/$EXP.shard-K-of-$N.json" \
      shards "$D" "$N" $((N % 2 + 1)) "${ARGS[@]}"
    run_rc rc "$MC" merge "$D/n$N" --out "$D/m$N"
    check "$EXP: merge of $N shards exits 0" [ "$rc" = 0 ]
    check "$EXP: merged CSV of $N shards is byte-identical to the unsharded one" cmp "$D/full/$EXP.csv" "$D/m$N/$EXP.csv"
    check "$EXP: merged JSON of $N shards equals the unsharded one but for threads and wall_seconds" \
      same_json "$D/full/$EXP.json" "$D/m$N/$EXP.json"
    if [ "$EXP" = zhou_fig2 ]; then
      check "$EXP: merged samples of $N shards are byte-identical" \
        cmp "$D/full/zhou_fig2_samples.csv" "$D/m$N/zhou_fig2_samples.csv"
    fi
  done
done
check "the unsharded sweep is not trivial (3 x 4 points x 2 estimators, every cell with a mean)" \
  [ "$(grep -cE '^[0-9]+,[0-9]+,[0-9]+,[0-9.]+,[0-9.]+,kfi?o?,150,0,0,[0-9]' "$WORK/sweep/full/sweep.csv")" = 24 ]
"$MC" "${SWEEP[@]/0.1:0.7:4/0.1:0.7:3}" --shard 2/3 --out "$WORK/sweep_axes" 2>/dev/null
cp "$WORK/sweep/n3/sweep.shard-1-of-3.json" "$WORK/sweep/n3/sweep.shard-3-of-3.json" "$WORK/sweep_axes/"
run_rc rc "$MC" merge "$WORK/sweep_axes" --out "$WORK/out_axes"
refused "a sweep shard of other axes is refused, naming the axes" 2 \
  "foreign shard: axes is [gnss.arrival_rate=0.2:0.8:3, camera.recovery_rate=0.1:0.7:3]"
check "the refused sweep merge writes nothing" no_files "$WORK/out_axes"
mkdir -p "$WORK/sweep_mixed"
cp "$WORK/sweep/n3/sweep.shard-1-of-3.json" "$WORK/sweep/n3/sweep.shard-2-of-3.json" \
  "$WORK/sweep_cov/n3/sweep.shard-3-of-3.json" "$WORK/sweep_mixed/"
run_rc rc "$MC" merge "$WORK/sweep_mixed" --out "$WORK/out_mixed"
refused "a covariance-only sweep shard among plain ones is refused, naming the option" 2 \
  "sweep.shard-3-of-3.json: foreign shard: covariance_only is true, but false in"
check "the refused mixed merge writes nothing" no_files "$WORK/out_mixed"
check "the covariance-only sweep has tr P and no errors (3 x 4 points x 2 estimators)" \
  [ "$(grep -cE '^[0-9]+,[0-9]+,[0-9]+,[0-9.]+,[0-9.]+,kfi?o?,150,0,0,[0-9.e+-]+,[0-9.e+-]+,,,' "$WORK/sweep_cov/full/sweep.csv")" = 24 ]
check "custom --covariance-only writes the experiment covariance (tr P per step)" \
  grep -q '^tracking_2d,kfio,60,' "$WORK/covariance/full/covariance.csv"
check "the unsharded outputs are not trivial (zhou_fig2: 4 cases x 130 samples)" \
  [ "$(wc -l <"$WORK/zhou_fig2/full/zhou_fig2_samples.csv")" = 521 ]
check "an empty shard (zhou_fig1 shard 7 of 7: 5 blocks) holds no block" \
  grep -q '"blocks": \[\]' "$WORK/zhou_fig1/n7/zhou_fig1.shard-7-of-7.json"
"$MC" --experiment zhou_fig2 --runs 130 --steps 50 --seed 8 --out "$WORK/seed8" 2>/dev/null
check "a different seed gives different data (the comparisons can fail)" \
  differ "$WORK/seed8/zhou_fig2.csv" "$WORK/zhou_fig2/full/zhou_fig2.csv"
run_rc rc "$MC" merge "$WORK/zhou_fig1/n3"
check "merge without --out writes into the first DIR" cmp "$WORK/zhou_fig1/full/zhou_fig1.csv" "$WORK/zhou_fig1/n3/zhou_fig1.csv"
run_rc rc "$MC" merge "$WORK/zhou_fig1/n7/" "$WORK/zhou_fig1/n7" "$WORK/zhou_fig1/../zhou_fig1/n7" --out "$WORK/twice"
check "a directory given twice is read once" cmp "$WORK/zhou_fig1/full/zhou_fig1.csv" "$WORK/twice/zhou_fig1.csv"

# --- refusals ----------------------------------------------------------------------------------
# Shards of zhou_fig2 (130 runs, 20 steps, seed 1) and variants, copied into a fresh directory per case.
S=$WORK/ref
EXP=zhou_fig2
base=(--experiment zhou_fig2 --runs 130 --steps 20)
for k in 1 2 3; do "$MC" "${base[@]}" --shard "$k/3" --out "$S/good" 2>/dev/null; done
"$MC" --experiment zhou_fig2 --runs 129 --steps 20 --shard 2/3 --out "$S/runs" 2>/dev/null
"$MC" --experiment zhou_fig2 --runs 130 --steps 21 --shard 2/3 --out "$S/steps" 2>/dev/null
"$MC" "${base[@]}" --seed 2 --shard 2/3 --out "$S/seed" 2>/dev/null
"$MC" "${base[@]}" --shard 2/4 --out "$S/n4" 2>/dev/null
"$MC" --experiment zhou_fig1 --runs 130 --steps 20 --shard 2/3 --out "$S/exp" 2>/dev/null
G=$S/good/zhou_fig2.shard
# case NAME: a directory with the good shards 1 and 3 only
case_dir() {
  rm -rf "$S/case_$1"
  mkdir -p "$S/case_$1"
  cp "$G-1-of-3.json" "$G-3-of-3.json" "$S/case_$1/"
  echo "$S/case_$1"
}

C=$(case_dir missing)
run_rc rc "$MC" merge "$C" --out "$WORK/out_missing"
refused "missing shard: exit 2, names K of N" 2 "missing shard 2 of 3" "zhou_fig2"
check "missing shard: no output" no_files "$WORK/out_missing"
"$MC" --experiment zhou_fig1 --runs 300 --steps 50 --shard 1/7 --out "$S/few" 2>/dev/null
"$MC" --experiment zhou_fig1 --runs 300 --steps 50 --shard 5/7 --out "$S/few" 2>/dev/null
run_rc rc "$MC" merge "$S/few" --out "$WORK/out_missing"
refused "missing shards: every missing K is listed" 2 "missing shards 2, 3, 4, 6, 7 of 7"

C=$(case_dir dup)
cp "$G-2-of-3.json" "$C/"
mkdir -p "$S/dup2"
cp "$G-2-of-3.json" "$S/dup2/"
run_rc rc "$MC" merge "$C" "$S/dup2" --out "$WORK/out_dup"
refused "duplicate shard: exit 2, names both files" 2 "duplicate shard 2 of 3" "$C/zhou_fig2.shard-2-of-3.json" \
  "$S/dup2/zhou_fig2.shard-2-of-3.json"
check "duplicate shard: no output" no_files "$WORK/out_dup"

for variant in runs steps seed n4 exp; do
  C=$(case_dir "$variant")
  cp "$S/$variant/"*.json "$C/"
  f=$(basename "$S/$variant/"*.json)
  case $variant in
    runs) field="runs is 129, but 130" ;;
    steps) field="steps is 21, but 20" ;;
    seed) field="seed is 2, but 1" ;;
    n4) field="shards (N) is 4, but 3" ;;
    exp) field="experiment is zhou_fig1, but zhou_fig2" ;;
  esac
  run_rc rc "$MC" merge "$C" --out "$WORK/out_$variant"
  refused "foreign shard ($variant): exit 2, names the file and the field" 2 "$C/$f: foreign shard" "$field"
  check "foreign shard ($variant): no output" no_files "$WORK/out_$variant"
done

# custom: an input file edited between the shards, or after them
M=$WORK/in/tracking_2d.yaml
cp "$M" "$WORK/model.orig"
for k in 1 2; do "$MC" "${CUSTOM[@]}" --shard "$k/3" --out "$S/edited" 2>/dev/null; done
echo "# edited" >>"$M"
"$MC" "${CUSTOM[@]}" --shard 3/3 --out "$S/edited" 2>/dev/null
run_rc rc "$MC" merge "$S/edited" --out "$WORK/out_edited"
refused "foreign shard (other input contents): exit 2, names the file and the fingerprint" 2 \
  "$S/edited/custom.shard-3-of-3.json: foreign shard: fingerprint"
run_rc rc "$MC" merge "$WORK/custom/n3" --out "$WORK/out_edited"
refused "input file changed since the shards: exit 2, names the input file" 2 \
  "--model in/tracking_2d.yaml has changed since the shards were computed"
check "changed input: no output" no_files "$WORK/out_edited"
rm "$M"
run_rc rc "$MC" merge "$WORK/custom/n3" --out "$WORK/out_edited"
refused "input file gone: exit 2, names the input file" 2 "--model in/tracking_2d.yaml: cannot read the file"
cp "$WORK/model.orig" "$M"
run_rc rc "$MC" merge "$WORK/custom/n3" --out "$WORK/out_restored"
check "the restored input merges again" cmp "$WORK/custom/full/custom.csv" "$WORK/out_restored/custom.csv"

# malformed shard files: the file and the problem are named
malformed() {
  local name=$1 pattern=$2
  local C
  C=$(case_dir "bad_$name")
  cat >"$C/zhou_fig2.shard-2-of-3.json"
  run_rc rc "$MC" merge "$C" --out "$WORK/out_bad"
  refused "malformed shard ($name): exit 2, names the file and the problem" 2 "$C/zhou_fig2.shard-2-of-3.json: " "$pattern"
  check "malformed shard ($name): no output" no_files "$WORK/out_bad"
}
head -c 2000 "$G-2-of-3.json" | malformed truncated "truncated"
printf '' | malformed empty "empty shard file"
echo "not a shard" | malformed garbage "line 1, column 1: expected '{'"
sed 's/"runs": 130,/"runs": "many",/' "$G-2-of-3.json" | malformed "wrong type" "'runs': expected an integer"
sed 's/"format": "[^"]*"/"format": "something else"/' "$G-2-of-3.json" | malformed "not a shard" "not a montecarlo shard file"
sed 's/"index": 1,/"index": 4,/' "$G-2-of-3.json" | malformed "wrong block" "expected block 1, found block 4"
sed 's/"fingerprint": "[0-9a-f]*"/"fingerprint": "0"/' "$G-2-of-3.json" | malformed "edited fingerprint" \
  "'fingerprint' 0 does not match"
sed '0,/"mean": \[/s/"mean": \[/"mean": [1, /' "$G-2-of-3.json" | malformed "extra value" "expected 4 numbers in 'mean'"
sed 's/"shard": 2,/"shard": 1,/' "$G-2-of-3.json" | malformed "renamed" "the file name says zhou_fig2 shard 2 of 3"

# the directories
run_rc rc "$MC" merge
refused "merge without a directory: usage error, exit 2" 2 "expected one or more directories" "usage: montecarlo merge DIR..."
run_rc rc "$MC" merge "$WORK/nowhere"
refused "merge of a missing directory: exit 2, names it" 2 "$WORK/nowhere: no such directory"
mkdir -p "$WORK/empty"
run_rc rc "$MC" merge "$WORK/empty"
refused "merge of a directory without shards: exit 2, names it" 2 "$WORK/empty: no shard files"
run_rc rc "$MC" merge "$S/good" --bogus 1
refused "merge with an unknown option: exit 2" 2 "unknown option '--bogus'"
run_rc rc "$MC" merge --help
check "merge --help exits 0 and documents --out" grep -q -- "--out DIR" "$WORK/out.txt"

# --shard syntax
for spec in 0/3 4/3 x 1/0 "" 1/3/4 -1/3 " 2/3"; do
  run_rc rc "$MC" "${base[@]}" --shard "$spec" --out "$WORK/out_spec"
  refused "--shard '$spec': usage error, exit 2, names the flag" 2 "option '--shard': expected K/N" "usage: montecarlo"
done
check "--shard errors: no output" no_files "$WORK/out_spec"
run_rc rc "$MC" --help
check "montecarlo --help documents --shard K/N and merge" \
  bash -c "grep -q -- '--shard K/N' '$WORK/out.txt' && grep -q 'montecarlo merge DIR' '$WORK/out.txt'"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
