#!/usr/bin/env bash
# Checks scripts/plot_montecarlo.py on small synthetic montecarlo outputs (zhou_fig1, zhou_fig2,
# lin_fig4, a two-axis and a one-axis sweep), on the JSON's plot hints and on bad inputs.
#   usage: test_plot_montecarlo.sh REPO_ROOT
# Needs Debian's python3 with python3-matplotlib (run with /usr/bin/python3: a pyenv python lacks
# Debian's modules). Prints "N passed, M failed" and exits non-zero when any check failed.
set -euo pipefail

if [ $# -ne 1 ]; then
  echo "usage: $0 REPO_ROOT" >&2
  exit 2
fi
ROOT=$(cd "$1" && pwd)
SCRIPT=$ROOT/scripts/plot_montecarlo.py
PY=/usr/bin/python3
[ -x "$PY" ] || PY=python3
if [ ! -f "$SCRIPT" ]; then
  echo "missing $SCRIPT" >&2
  exit 2
fi
if ! "$PY" -c 'import numpy, matplotlib' 2>/dev/null; then
  echo "$PY lacks numpy/matplotlib: apt-get install -y --no-install-recommends python3-matplotlib" >&2
  exit 2
fi

WORK=$(mktemp -d "${TMPDIR:-/tmp}/test_plot_montecarlo.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

# shared helpers: check, run_rc, differ, no_files, passed / failed
source "$(dirname "${BASH_SOURCE[0]}")/check_lib.sh"
# is_png FILE: exists, non-empty, starts with the PNG signature.
is_png() {
  [ -s "$1" ] && [ "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ]
}
smaller_than() { [ "$(wc -c <"$1")" -lt "$2" ]; }
no_traceback() { ! grep -q Traceback "$WORK/err.txt"; }

# --- synthetic inputs ------------------------------------------------------------------------
IN=$WORK/in
T=$WORK/tails
mkdir -p "$IN" "$T"
"$PY" - "$IN" "$T" <<'EOF'
import json, math, random, sys
d = sys.argv[1] + "/"
t = sys.argv[2] + "/"
rnd = random.Random(3)
def meta(name, cases, **kw):
    m = dict(experiment=name, runs=50, steps=120, seed=5, threads=2, wall_seconds=0.4,
             x_label="k", y_label="MSE_k", log_x=False, log_y=True, assumptions=["synthetic"],
             cases=cases, notes=["test data"])
    m.update(kw)
    with open(d + name + ".json", "w") as f:
        json.dump(m, f)
header = "case,series,x,mean,sd,n\n"
# zhou_fig1: 3 cases x 4 estimators x 120 steps
rows, cases = [], []
for c in ("delta1_mu0.8", "delta1_mu0.95", "delta10_mu0.8"):
    series = []
    for s, lvl in (("KF", 3.0), ("KFIO", 2.0), ("RSE", 2.5), ("RSEIO", 2.2)):
        for k in range(1, 121):
            m = lvl * (1 + 10 * math.exp(-k / 10.0)) * (1 + 0.05 * rnd.gauss(0, 1))
            rows.append("%s,%s,%d,%.6g,%.6g,50" % (c, s, k, m, 1.4 * m))
        series.append(dict(name=s, time_average=lvl, final=lvl, window=[80, 120]))
    cases.append(dict(name=c, title=c, series=series))
open(d + "zhou_fig1.csv", "w").write(header + "\n".join(rows) + "\n")
meta("zhou_fig1", cases, plot=dict(kind="averaged", tails=True, zoom=[80, 500]))
# zhou_fig2: an empty results table and 4 x 300 samples of P_120|120
open(d + "zhou_fig2.csv", "w").write(header)
p0 = ("P0_0.1", "P0_1", "P0_10", "P0_100")
meta("zhou_fig2", [dict(name=c, title=c, series=[]) for c in p0], runs=300, log_y=False,
     plot=dict(kind="density", tails=False, title="EPDF of the elements of $P_{120|120}$",
               columns=[dict(column="P" + ij, label="$[P_{120|120}]_{%s}$" % ij, title="$P_{%s}$" % ij)
                        for ij in ("11", "12", "22")],
               case_labels={c: r"$P_{0|0} = %s\,I_2$" % c[3:] for c in p0}))
rows = []
for c in p0:
    for r in range(300):
        p11, p22 = 2 + rnd.gammavariate(3, 0.5), 1 + rnd.gammavariate(2, 0.4)
        p12 = 0.4 * math.sqrt(p11 * p22)
        rows.append("%s,%d,%.6g,%.6g,%.6g,%.6g" % (c, r, p11, p12, p12, p22))
open(d + "zhou_fig2_samples.csv", "w").write("case,run,P11,P12,P21,P22\n" + "\n".join(rows) + "\n")
# lin_fig4: bounds (dashed, deterministic) around two Monte Carlo means
rows = []
for s, f in (("lower_bound", 1.0), ("OE", 1.3), ("AOE", 1.4), ("upper_bound", 2.0)):
    for k in range(1, 31):
        m = f * (3 + math.log(k))
        sd, n = (0, 1) if "bound" in s else (0.5 * m, 50)
        rows.append("main,%s,%d,%.6g,%.6g,%d" % (s, k, m, sd, n))
open(d + "lin_fig4.csv", "w").write(header + "\n".join(rows) + "\n")
meta("lin_fig4", [dict(name="main", title="bounds", series=[])], log_y=False, steps=30,
     y_label="tr E[P_k]")
# sweep: a 6 x 5 stability map of two estimators, one cell without a mean (floored runs), the
# critical curve with an undecided band on part of it; sweep_line: one axis, a critical value
sweep_header = ("point,i1,i2,x1,x2,estimator,n,diverged,floored,trP_mean,trP_sd,err_mean,err_sd,"
                "trP_avg_mean,trP_avg_sd,err_avg_mean,err_avg_sd,verdict\n")
def axis(name, lo, hi, n):
    return dict(name=name, sensor=name.split(".")[0], param=name.split(".")[1], arg="", lo=lo,
                hi=hi, count=n, values=[lo + (hi - lo) * i / (n - 1) for i in range(n)])
a1, a2 = axis("gnss.arrival_rate", 0.1, 0.9, 6), axis("camera.arrival_rate", 0.1, 0.9, 5)
rows, verdicts = [], []
for i, l1 in enumerate(a1["values"]):
    for j, l2 in enumerate(a2["values"]):
        g = 2.25 * (1 - l1) * (1 - l2)
        verdicts.append("stable" if g < 1 else "unstable")
        for est in ("kfio", "kf"):
            m = 1.0 / max(1 - g, 0.01)
            stats = ",".join(["%.6g" % m] * 8) if (i, j) != (0, 0) else ",,,,,,,"
            rows.append("%d,%d,%d,%g,%g,%s,100,0,%d,%s,%s" % (i * 5 + j, i, j, l1, l2, est,
                        100 if (i, j) == (0, 0) else 0, stats, verdicts[-1]))
curve = [dict(at=l1, diverges_at=max(0, 1 - 1 / (2.25 * (1 - l1))) - (0.05 if k < 2 else 1e-7),
              converges_at=max(0, 1 - 1 / (2.25 * (1 - l1))), undecided_band=k < 2, half_line=True,
              note="") for k, l1 in enumerate(a1["values"])]
open(d + "sweep.csv", "w").write(sweep_header + "\n".join(rows) + "\n")
meta("sweep", [], x_label=a1["name"], y_label=a2["name"], log_y=False,
     sweep=dict(axes=[a1, a2], estimators=["kfio", "kf"], points=30, incomplete_cells=2,
                verdicts=verdicts, critical=dict(axis=a2["name"], along=a1["name"], curve=curve)))
rows = []
for i, l in enumerate(a2["values"]):
    m = 1.0 / max(1 - 2.25 * (1 - l) * 0.5, 0.01)
    rows.append("%d,%d,0,%g,,kfio,100,0,0,%s,unstable" % (i, i, l, ",".join(["%.6g" % m] * 8)))
open(d + "sweep_line.csv", "w").write(sweep_header + "\n".join(rows) + "\n")
meta("sweep_line", [], x_label=a2["name"], y_label="tr P_T",
     sweep=dict(axes=[a2], estimators=["kfio"], points=5, incomplete_cells=0, verdicts=[],
                critical=dict(axis=a2["name"], along=None,
                              curve=[dict(at=None, diverges_at=0.111111, converges_at=0.111112,
                                          undecided_band=False, half_line=True, note="")])))
# heavy tails (a separate folder): a covariance experiment with quantile and tail columns whose
# series kfio has a mean that is not estimable (the JSON says so) and rseio one that is; a
# one-axis sweep whose last cell has a median but no mean
cols = "case,series,x,mean,sd,n,se,p5,p25,median,p75,p95,P_gt_10,P_gt_100\n"
rows = []
for s, heavy in (("kfio", True), ("rseio", False)):
    for k in range(1, 201):
        med = 2 + math.log(k)
        mean = med * (1 + (k / 10.0 if heavy else 0.1))
        rows.append("scalar,%s,%d,%.6g,%.6g,1000,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g" % (
            s, k, mean, 3 * mean, 0.1 * mean, 0.5 * med, 0.8 * med, med, 1.3 * med, 3 * med,
            min(1, 0.01 * k), 0.001 * k / (2 if heavy else 4)))
open(t + "covariance.csv", "w").write(cols + "\n".join(rows) + "\n")
with open(t + "covariance.json", "w") as f:
    json.dump(dict(experiment="covariance", runs=1000, steps=200, x_label="k", y_label="tr P_k|k", log_y=True,
                   thresholds=[10, 100],
                   cases=[dict(name="scalar", title="scalar", series=[
                       dict(name="kfio", statistic="median", mean_note="mean not estimable: synthetic"),
                       dict(name="rseio", statistic="mean")])]), f)
rows = []
for i, l in enumerate(a2["values"]):
    m = "%.6g" % (1.0 / (0.2 * (i + 1))) if i < 4 else ""
    q = ",".join("%.6g" % (f / (0.2 * (i + 1))) for f in (0.3, 0.6, 0.9, 1.2, 2.0))
    rows.append("%d,%d,0,%g,,kfio,100,%d,0,%s,%s,,,%s,%s,,,stable,,%s,,,,,,,0" % (
        i, i, l, 0 if m else 3, m, m, m, m, q))
open(t + "sweep.csv", "w").write(sweep_header.rstrip("\n") + ",trP_se,trP_p5,trP_p25,trP_median,trP_p75,"
                                 "trP_p95,err_se,err_median,growth,growth_low,growth_high\n" + "\n".join(rows) + "\n")
with open(t + "sweep.json", "w") as f:
    json.dump(dict(experiment="sweep", steps=50, sweep=dict(axes=[a2], estimators=["kfio"], points=5,
                                                        critical=dict(curve=[]))), f)
EOF

EXPECTED="lin_fig4.png sweep.png sweep_line.png zhou_fig1_delta1_mu0.8.png zhou_fig1_delta1_mu0.95.png zhou_fig1_delta10_mu0.8.png zhou_fig2.png"

# --- every experiment into OUT ---------------------------------------------------------------
OUT=$WORK/out
run_rc rc "$PY" "$SCRIPT" "$IN" --out "$OUT"
check "plots all experiments, exit 0" [ "$rc" = 0 ]
cat "$WORK/err.txt"
check "nothing on stderr" [ ! -s "$WORK/err.txt" ]
for f in $EXPECTED; do
  check "$f is a PNG" is_png "$OUT/$f"
  check "$f is under 100 kB" smaller_than "$OUT/$f" 100000
  check "$f is listed on stdout" grep -qxF "$OUT/$f" "$WORK/out.txt"
done
check "stdout lists exactly 7 files" [ "$(wc -l <"$WORK/out.txt" | tr -d ' ')" = 7 ]
check "only the listed files are written" [ "$(ls "$OUT" | wc -l | tr -d ' ')" = 7 ]
check "the two-estimator map is wider than the one-estimator line plot" \
  "$PY" -c 'import sys, struct; w = lambda f: struct.unpack(">I", open(f, "rb").read()[16:20])[0]; sys.exit(not w(sys.argv[1]) > w(sys.argv[2]))' \
  "$OUT/sweep.png" "$OUT/sweep_line.png"
check "no zhou_fig2_series.png for an empty table" [ ! -e "$OUT/zhou_fig2_series.png" ]

# --- heavy tails: medians where the mean is not estimable, tail probabilities -------------------
run_rc rc "$PY" "$SCRIPT" "$T" --out "$WORK/tails_auto"
check "heavy tails: exit 0" [ "$rc" = 0 ]
check "heavy tails: covariance.png, covariance_tail.png and sweep.png, listed" \
  [ "$(sort "$WORK/out.txt" | tr '\n' ' ')" = "$WORK/tails_auto/covariance.png $WORK/tails_auto/covariance_tail.png $WORK/tails_auto/sweep.png " ]
for f in covariance.png covariance_tail.png sweep.png; do
  check "heavy tails: $f is a PNG" is_png "$WORK/tails_auto/$f"
done
check "the series whose mean is not estimable is named as drawn by its median, with the reason" \
  grep -qF "note: $WORK/tails_auto/covariance.png: kfio drawn as its median (mean not estimable: synthetic)" "$WORK/err.txt"
check "the series whose mean is estimable is not" bash -c "! grep -q 'rseio drawn' '$WORK/err.txt'"
check "a map with a cell without a mean shows the median and says why" \
  grep -qF "note: $WORK/tails_auto/sweep.png: tr P_T drawn as its median (a cell without a finite mean)" "$WORK/err.txt"
check "heavy tails: no error" bash -c "! grep -q '^error' '$WORK/err.txt'"
run_rc rc "$PY" "$SCRIPT" "$T" --out "$WORK/tails_mean" --statistic mean
check "--statistic mean: exit 0, no median" bash -c "[ $rc = 0 ] && ! grep -q median '$WORK/err.txt'"
check "--statistic mean draws another figure" differ "$WORK/tails_auto/covariance.png" "$WORK/tails_mean/covariance.png"
run_rc rc "$PY" "$SCRIPT" "$T" --out "$WORK/tails_median" --statistic median --experiment covariance
check "--statistic median names both series" \
  [ "$(grep -c 'drawn as its median (--statistic median)' "$WORK/err.txt")" = 2 ]
run_rc rc "$PY" "$SCRIPT" "$T" --statistic typical
check "--statistic typical: exit 2" [ "$rc" = 2 ]

# --- --experiment, default OUTDIR = DIR, --dpi -----------------------------------------------
cp -r "$IN" "$WORK/in2"
run_rc rc "$PY" "$SCRIPT" "$WORK/in2" --experiment lin_fig4 --dpi 60
check "--experiment lin_fig4 exit 0" [ "$rc" = 0 ]
check "--experiment writes into DIR by default" is_png "$WORK/in2/lin_fig4.png"
check "--experiment plots only the named one" [ ! -e "$WORK/in2/zhou_fig2.png" ]
check "--experiment lists one file" [ "$(wc -l <"$WORK/out.txt" | tr -d ' ')" = 1 ]
check "--dpi 60 makes a smaller file" \
  [ "$(wc -c <"$WORK/in2/lin_fig4.png")" -lt "$(wc -c <"$OUT/lin_fig4.png")" ]

# --- errors ----------------------------------------------------------------------------------
run_rc rc "$PY" "$SCRIPT" "$WORK/does_not_exist"
check "missing DIR gives exit 2" [ "$rc" = 2 ]
check "missing DIR is named" grep -q "^error: $WORK/does_not_exist: " "$WORK/err.txt"

BAD=$WORK/bad
mkdir -p "$BAD"
cp "$IN"/lin_fig4.* "$BAD"
sed -i '1s/.*/case,series,k,mean,sd,n/' "$BAD/lin_fig4.csv"
run_rc rc "$PY" "$SCRIPT" "$BAD"
check "bad CSV header gives exit 2" [ "$rc" = 2 ]
check "bad CSV header names the file" grep -q "^error: $BAD/lin_fig4.csv: .*header" "$WORK/err.txt"
check "bad CSV header: no traceback" no_traceback
check "bad CSV header: no PNG" [ ! -e "$BAD/lin_fig4.png" ]

BADJ=$WORK/badjson
mkdir -p "$BADJ"
cp "$IN"/lin_fig4.csv "$BADJ"
printf '{"experiment": "lin_fig4", ' >"$BADJ/lin_fig4.json"
run_rc rc "$PY" "$SCRIPT" "$BADJ"
check "unparsable JSON gives exit 2" [ "$rc" = 2 ]
check "unparsable JSON names the file" grep -q "^error: $BADJ/lin_fig4.json: " "$WORK/err.txt"
check "unparsable JSON: no traceback" no_traceback

BADS=$WORK/badsweep
mkdir -p "$BADS"
cp "$IN"/sweep.csv "$BADS"
printf '{"experiment": "sweep", "sweep": {"axes": []}}' >"$BADS/sweep.json"
run_rc rc "$PY" "$SCRIPT" "$BADS"
check "a sweep without axes gives exit 2" [ "$rc" = 2 ]
check "a sweep without axes names the file and the key" \
  grep -q "^error: $BADS/sweep.json: \"sweep\" must hold \"axes\"" "$WORK/err.txt"
check "a sweep without axes: no traceback" no_traceback
cp "$IN"/sweep.json "$BADS"
sed -i '1s/.*/point,i1,i2,x1,x2,estimator,n,trP_mean/' "$BADS/sweep.csv"
run_rc rc "$PY" "$SCRIPT" "$BADS"
check "a sweep CSV with another header gives exit 2 naming it" grep -q "^error: $BADS/sweep.csv: unexpected header" "$WORK/err.txt"

NOS=$WORK/nosamples
mkdir -p "$NOS"
cp "$IN"/zhou_fig2.json "$IN"/zhou_fig2.csv "$NOS"
run_rc rc "$PY" "$SCRIPT" "$NOS"
check "zhou_fig2 without samples gives exit 2" [ "$rc" = 2 ]
check "zhou_fig2 without samples names the file" \
  grep -q "^error: $NOS/zhou_fig2_samples.csv: " "$WORK/err.txt"

# --- the JSON's "plot" hints, not the experiment's name, choose the figure ----------------------
HINTS=$WORK/hints
mkdir -p "$HINTS"
for ext in json csv; do cp "$IN/zhou_fig1.$ext" "$HINTS/my_fig.$ext"; done
cp "$IN/zhou_fig2.json" "$HINTS/pdfs.json"
cp "$IN/zhou_fig2.csv" "$HINTS/pdfs.csv"
cp "$IN/zhou_fig2_samples.csv" "$HINTS/pdfs_samples.csv"
run_rc rc "$PY" "$SCRIPT" "$HINTS" --out "$HINTS/out"
check "renamed experiments: exit 0" [ "$rc" = 0 ]
check "an averaged plot under another name: one figure per case with its zoom" \
  [ "$(ls "$HINTS/out" | tr '\n' ' ')" = "my_fig_delta10_mu0.8.png my_fig_delta1_mu0.8.png my_fig_delta1_mu0.95.png pdfs.png " ]
"$PY" - "$HINTS/my_fig.json" <<'EOF2'
import json, sys
m = json.load(open(sys.argv[1]))
m["plot"] = dict(kind="series", tails=True)
json.dump(m, open(sys.argv[1], "w"))
EOF2
run_rc rc "$PY" "$SCRIPT" "$HINTS" --out "$HINTS/series" --experiment my_fig
check "zhou_fig1's data with series hints: one panel per case in my_fig.png" \
  [ "$(ls "$HINTS/series" | tr '\n' ' ')" = "my_fig.png " ]
printf '{"experiment": "lin_fig4", "plot": {"kind": "pie"}}' >"$HINTS/my_fig.json"
run_rc rc "$PY" "$SCRIPT" "$HINTS" --experiment my_fig
check "an unknown plot kind gives exit 2 naming the file and the key" \
  bash -c "[ $rc = 2 ] && grep -q '^error: $HINTS/my_fig.json: \"plot\": \"kind\" must be one of' '$WORK/err.txt'"
check "an unknown plot kind: no traceback" no_traceback

echo "$passed passed, $failed failed"
[ "$failed" = 0 ]
