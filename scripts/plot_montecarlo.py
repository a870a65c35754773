#!/usr/bin/env python3
"""Plots the output of the `montecarlo` tool in the style of the papers' figures.

usage: plot_montecarlo.py DIR [--out OUTDIR] [--experiment NAME ...] [--dpi 100]
                          [--statistic auto|mean|median]

DIR holds, for each experiment NAME, `NAME.csv` (header `case,series,x,mean,sd,n`, then optionally
`se,p5,p25,median,p75,p95` and `P_gt_M` columns) and `NAME.json` (the run's settings and summary;
each series' "statistic" says whether its mean is estimable). Every experiment found in DIR (every
`NAME.json`), or only the named ones, is drawn into OUTDIR (default DIR); the PNGs written are listed
on stdout, one per line. The script knows no experiment by name: the JSON's "plot" member says how to
draw it (docs/formats.md, "Plot hints"), its x_label, y_label, log_x and log_y label and scale the
axes:

  series      NAME.png: one panel per case (lin_fig2..5, yang_fig2, custom, covariance, ...)
  averaged    NAME_<case>.png per case: the full x range and a zoom on "zoom": [lo, hi] (zhou_fig1:
              80 <= k <= 500) whose legend gives each series' time average
  density     NAME.png: empirical PDF (Gaussian KDE) of the samples file's "columns"
              (`NAME_samples.csv`, header `case,run,<columns>`; zhou_fig2: P11, P12, P22 at the last
              step), one panel per column, the cases overlaid; plus NAME_series.png only when a
              series of NAME.csv has more than one x (zhou_fig2 writes one x, the last step)
  sweep       NAME.png (a stability map; the JSON has a "sweep" member and NAME.csv one row per
              grid point and estimator, see docs/formats.md section 8): per estimator, two axes:
              a heat map of log10 of the mean tr P_T (colours over at most 5 decades above the
              smallest, larger values in the top colour) with the critical curve of the analysis
              over it (solid, stable above it; along the top edge where no value of the second
              axis is stable) and its undecided band (hatched) where there is one;
              one axis: mean tr P_T against the axis value (log y) with a vertical line at the
              critical value. Grid points without a mean (runs that diverged or crossed the
              rounding floor) are grey.
  tails       NAME_tail.png besides, when "tails" is true and NAME.csv has P_gt_M columns
              (montecarlo --threshold M): per case, P(value > M) against x for every series and
              threshold (log y)

A JSON without "plot" (an older montecarlo) is drawn as a sweep when it has a "sweep" member, as
series with tails otherwise.

Mean lines, with a light band of +-2 standard errors (sd / sqrt(n)) where n > 1 and sd > 0. Where
the mean is not estimable (the JSON's series "statistic": "median": a mean that is not finite, a
standard error above a fifth of it, or a mean above the 95th percentile) the series is drawn as its
median with a p25-p75 band and a lighter p5-p95 band, its legend entry says "median", and the
caption names the series and the reason; --statistic mean or median forces one for every series
(sweeps: the colour of the map, median when some cell's mean is missing or not estimable). A
series is drawn as a dashed bound (no markers, no band) when its JSON entry has "bound": true or
"style": "dashed", or when its name contains "bound", "lower", "upper" or "mare" or starts with
"sup"/"inf". A JSON series entry may carry "label" to override the legend text.

A series drawn as its median is named on stderr: `note: <png>: <series> drawn as its median
(<why>)`. Errors (missing DIR, a CSV without the expected header, a JSON that does not parse, ...)
are reported as `error: <file>: <problem>` on stderr; the experiments that are fine are still drawn,
and the exit code is 2.

Runs with Debian's python3 and python3-matplotlib (`apt-get install python3-matplotlib`). A pyenv
python lacks Debian's modules: run it as `/usr/bin/python3 scripts/plot_montecarlo.py ...`, or
after `source scripts/env.sh` (which strips pyenv from PATH). If matplotlib cannot be imported and
/usr/bin/python3 exists, the script re-runs itself with /usr/bin/python3.
"""

import argparse
import csv
import io
import json
import math
import os
import re
import sys
import warnings

SYSTEM_PYTHON = "/usr/bin/python3"
CSV_HEADER = ["case", "series", "x", "mean", "sd", "n"]
QUANTILE_COLUMNS = ["p5", "p25", "median", "p75", "p95"]
STATISTIC = "auto"  # --statistic
SAMPLES_HEADER = ["case", "run"]
SWEEP_HEADER = ["point", "i1", "i2", "x1", "x2", "estimator", "n", "diverged", "floored",
                "trP_mean", "trP_sd"]
MAP_DECADES = 5.0  # the colour range of a stability map, in decades of tr P


class InputError(Exception):
    """A problem with one input file: reported as `error: <file>: <problem>`."""

    def __init__(self, path, problem):
        super().__init__("%s: %s" % (path, problem))
        self.path = path
        self.problem = problem


def import_plotting():
    """Imports numpy and matplotlib (Agg). Re-runs with Debian's python when they are missing."""
    try:
        import numpy
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as pyplot
        import matplotlib.ticker as tick
        return numpy, pyplot, tick
    except ImportError as exc:
        here = os.path.realpath(sys.executable or "")
        if (os.path.exists(SYSTEM_PYTHON) and here != os.path.realpath(SYSTEM_PYTHON)
                and not os.environ.get("PLOT_MONTECARLO_REEXEC")):
            os.environ["PLOT_MONTECARLO_REEXEC"] = "1"
            script = os.path.abspath(sys.argv[0])
            os.execv(SYSTEM_PYTHON, [SYSTEM_PYTHON, script] + sys.argv[1:])
        sys.stderr.write("error: %s: %s (install python3-matplotlib and run with %s)\n"
                         % (sys.executable, exc, SYSTEM_PYTHON))
        sys.exit(2)


np = None
plt = None
ticker = None


# ---------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------

def parse_float(text, path, line, column):
    try:
        return float(text)
    except ValueError:
        raise InputError(path, "line %d: %s is not a number: %r" % (line, column, text))


def csv_rows(path, header, missing="missing", prefix=False):
    """The (line number, fields) of the non-empty data rows of a CSV whose header starts with
    `header` (prefix: the file may have more columns, and the message says so)."""
    expected = ",".join(header) + (",..." if prefix else "")
    if not os.path.isfile(path):
        raise InputError(path, missing)
    try:
        with open(path, newline="") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(path, "cannot read: %s" % exc)
    if not rows:
        raise InputError(path, "empty file, expected header %s" % expected)
    if [h.strip() for h in rows[0]][:len(header)] != header:
        raise InputError(path, "unexpected header %r, expected %s" % (",".join(rows[0]), expected))
    out = []
    for line, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) < len(header):
            raise InputError(path, "line %d: %d fields, expected %s%d"
                             % (line, len(row), "at least " if prefix else "", len(header)))
        out.append((line, row))
    return out


def csv_header(path):
    try:
        with open(path, newline="") as handle:
            return [h.strip() for h in next(csv.reader(handle), [])]
    except (OSError, UnicodeDecodeError, csv.Error):
        return []


def read_results_csv(path):
    """Returns {case: {series: {"x", "mean", "sd", "n", the quantile columns present (NaN where a
    cell is empty), "tail": {M: P(value > M)}}, arrays sorted by x}}."""
    rows = csv_rows(path, CSV_HEADER)
    header = csv_header(path)
    extra = [(i, h) for i, h in enumerate(header) if h in QUANTILE_COLUMNS or h.startswith("P_gt_")]
    data = {}
    for line, row in rows:
        case, series = row[0].strip(), row[1].strip()
        point = [parse_float(row[k], path, line, CSV_HEADER[k]) for k in range(2, 6)]
        for i, h in extra:
            text = row[i].strip() if i < len(row) else ""
            point.append(float("nan") if text == "" else parse_float(text, path, line, h))
        data.setdefault(case, {}).setdefault(series, []).append(point)
    out = {}
    for case, per_series in data.items():
        out[case] = {}
        for series, points in per_series.items():
            arr = np.array(sorted(points, key=lambda p: p[0]), dtype=float)
            d = {"x": arr[:, 0], "mean": arr[:, 1], "sd": arr[:, 2], "n": arr[:, 3], "tail": {}}
            for j, (_, h) in enumerate(extra):
                if h.startswith("P_gt_"):
                    d["tail"][h[len("P_gt_"):]] = arr[:, 4 + j]
                else:
                    d[h] = arr[:, 4 + j]
            out[case][series] = d
    return out


def read_json(path):
    if not os.path.isfile(path):
        raise InputError(path, "missing")
    try:
        with open(path) as handle:
            meta = json.load(handle)
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, "cannot read: %s" % exc)
    except ValueError as exc:
        raise InputError(path, "not valid JSON: %s" % exc)
    if not isinstance(meta, dict):
        raise InputError(path, "expected a JSON object at the top level")
    cases = meta.get("cases", [])
    if not isinstance(cases, list) or not all(isinstance(c, dict) for c in cases):
        raise InputError(path, "\"cases\" must be a list of objects")
    for case in cases:
        series = case.get("series", [])
        if not isinstance(series, list) or not all(isinstance(s, dict) for s in series):
            raise InputError(path, "\"series\" of case %r must be a list of objects"
                             % case.get("name"))
    return meta


def read_samples_csv(path, columns):
    """Returns {case: {column: samples}} of NAME_samples.csv (header `case,run,<columns>...`) for the
    columns asked for, cases in file order."""
    rows = csv_rows(path, SAMPLES_HEADER, "missing (the density plot is drawn from it)", prefix=True)
    header = csv_header(path)
    index = {}
    for column in columns:
        if column not in header[2:]:
            raise InputError(path, "no column %r (the JSON's \"plot\" draws it)" % column)
        index[column] = header.index(column)
    data = {}
    for line, row in rows:
        per_case = data.setdefault(row[0].strip(), {k: [] for k in columns})
        for column, i in index.items():
            if i >= len(row):
                raise InputError(path, "line %d: %d fields, expected %d" % (line, len(row), len(header)))
            per_case[column].append(parse_float(row[i], path, line, column))
    if not data:
        raise InputError(path, "no data rows")
    return {case: {k: np.array(v, dtype=float) for k, v in cols.items()}
            for case, cols in data.items()}


PLOT_KINDS = ("series", "averaged", "density", "sweep")


def plot_hints(meta, path):
    """The JSON's "plot" member: {"kind", "tails", and the kind's own hints} (docs/formats.md). A JSON
    without one (written by an older montecarlo): a sweep when it has a "sweep" member, else series."""
    hints = meta.get("plot")
    if hints is None:
        return {"kind": "sweep" if "sweep" in meta else "series", "tails": "sweep" not in meta}
    if not isinstance(hints, dict):
        raise InputError(path, "\"plot\" must be an object")
    if hints.get("kind") not in PLOT_KINDS:
        raise InputError(path, "\"plot\": \"kind\" must be one of %s, found %r"
                         % (", ".join(PLOT_KINDS), hints.get("kind")))
    if hints["kind"] == "averaged":
        zoom = hints.get("zoom")
        if not (isinstance(zoom, list) and len(zoom) == 2
                and all(isinstance(v, (int, float)) for v in zoom)):
            raise InputError(path, "\"plot\": an averaged plot needs \"zoom\": [lo, hi]")
    if hints["kind"] == "density":
        columns = hints.get("columns")
        if not (isinstance(columns, list) and columns
                and all(isinstance(c, dict) and isinstance(c.get("column"), str) for c in columns)):
            raise InputError(path, "\"plot\": a density plot needs \"columns\": [{\"column\": ...}, ...]")
    return hints


# ---------------------------------------------------------------------------------------------
# Styles
# ---------------------------------------------------------------------------------------------

# The papers' markers (Zhou Fig. 1: square Kalman filter, diamond KFIO, x RSE, triangle RSEMM,
# circle this paper's RSEIO).
KNOWN_STYLES = {
    "KF": ("s", "tab:blue"),
    "KFIO": ("D", "tab:orange"),
    "RSE": ("x", "tab:green"),
    "RSEMM": ("^", "tab:purple"),
    "RSEIO": ("o", "tab:red"),
}
CYCLE_MARKERS = ["o", "s", "^", "D", "v", "x", "+", "*", "<", ">"]
CYCLE_COLORS = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
                "tab:pink", "tab:gray", "tab:olive", "tab:cyan"]
BOUND_RE = re.compile(r"(bound|lower|upper|mare|^sup|^inf)", re.IGNORECASE)


def series_meta(meta, case):
    """{series name: JSON entry} of one case."""
    for entry in meta.get("cases", []):
        if str(entry.get("name")) == case:
            return {str(s.get("name")): s for s in entry.get("series", [])}
    return {}


def is_bound(name, entry):
    if entry.get("bound") is True or entry.get("style") == "dashed":
        return True
    return bool(BOUND_RE.search(name))


class Styler:
    """Gives each series name one colour and marker for the whole experiment."""

    def __init__(self, names):
        self.styles = {}
        used_colors = {c for _, c in (KNOWN_STYLES[n] for n in names if n in KNOWN_STYLES)}
        colors = [c for c in CYCLE_COLORS if c not in used_colors] or CYCLE_COLORS
        i = 0
        for name in names:
            if name in KNOWN_STYLES:
                self.styles[name] = KNOWN_STYLES[name]
            elif name not in self.styles:
                self.styles[name] = (CYCLE_MARKERS[i % len(CYCLE_MARKERS)],
                                     colors[i % len(colors)])
                i += 1

    def __call__(self, name):
        return self.styles[name]


def mark_indices(x, count, phase, log_x):
    """About `count` marker indices evenly spread along x (in log x when the axis is log),
    shifted by `phase` (0..1) of a spacing so that different series do not overlap."""
    size = len(x)
    if size <= 25:
        return None  # few points (a parameter sweep): mark them all
    t = np.log10(np.where(x > 0, x, np.nan)) if log_x else x.astype(float)
    good = np.isfinite(t)
    if good.sum() < 2:
        return None
    lo, hi = np.nanmin(t), np.nanmax(t)
    if hi <= lo:
        return None
    step = (hi - lo) / count
    targets = lo + step * (phase + np.arange(count))
    tt = np.where(good, t, np.inf)
    idx = sorted({int(np.argmin(np.abs(tt - v))) for v in targets})
    return idx


def caption(meta, extra=""):
    parts = []
    for key, fmt in (("runs", "%s runs"), ("steps", "%s steps"), ("seed", "seed %s"),
                     ("threads", "%s threads")):
        if meta.get(key) is not None:
            parts.append(fmt % meta[key])
    wall = meta.get("wall_seconds")
    if isinstance(wall, (int, float)):
        parts.append("%.1f s" % wall)
    text = "%s: %s" % (meta.get("experiment", "?"), ", ".join(parts))
    if extra:
        text += "; " + extra
    return text


def finish(fig, meta, path, dpi, extra=""):
    fig.text(0.01, 0.005, caption(meta, extra), fontsize=7, color="0.35", ha="left",
             va="bottom")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
    plt.close(fig)
    png = buffer.getvalue()
    try:  # a 256-colour palette keeps the files small enough to commit (about 3x smaller)
        from PIL import Image
        image = Image.open(io.BytesIO(png)).convert("RGB")
        small = io.BytesIO()
        image.quantize(colors=256, method=Image.Quantize.MEDIANCUT
                       if hasattr(Image, "Quantize") else 0).save(small, format="PNG",
                                                                   optimize=True)
        if small.tell() < len(png):
            png = small.getvalue()
    except Exception:  # PIL missing or too old: keep matplotlib's RGBA PNG
        pass
    try:
        with open(path, "wb") as handle:
            handle.write(png)
    except OSError as exc:
        raise InputError(path, "cannot write: %s" % exc.strerror)


def safe_name(text):
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "case"


def case_order(meta, data):
    names = [str(c.get("name")) for c in meta.get("cases", []) if c.get("name") is not None]
    return names + [c for c in data if c not in names]


def case_title(meta, case):
    for entry in meta.get("cases", []):
        if str(entry.get("name")) == case and entry.get("title"):
            return str(entry["title"])
    return case


def series_order(meta, data, case):
    names = list(series_meta(meta, case))
    present = data.get(case, {})
    return [s for s in names if s in present] + [s for s in present if s not in names]


# ---------------------------------------------------------------------------------------------
# Drawing
# ---------------------------------------------------------------------------------------------

def uses_median(entry, series):
    """Whether a series is drawn as its median: --statistic, else its JSON "statistic"."""
    if "median" not in series or not np.isfinite(series["median"]).any():
        return False
    if STATISTIC != "auto":
        return STATISTIC == "median"
    return entry.get("statistic") == "median"


def draw_panel(ax, meta, data, case, styler, xwin=None, legend_extra=None, medians=None):
    """Mean lines (+-2 SE bands), or median lines (p25-p75 and p5-p95 bands) where the mean is not
    estimable, of every series of one case; xwin = (lo, hi) crops x. The names of the series drawn
    as medians, with the reason, are appended to `medians`."""
    log_x, log_y = bool(meta.get("log_x")), bool(meta.get("log_y"))
    if log_x:
        ax.set_xscale("log", nonpositive="mask")
    if log_y:
        ax.set_yscale("log", nonpositive="mask")
    entries = series_meta(meta, case)
    names = series_order(meta, data, case)
    bands = []
    for i, name in enumerate(names):
        series = data[case][name]
        keep = np.ones(len(series["x"]), dtype=bool)
        if xwin is not None:
            keep = (series["x"] >= xwin[0]) & (series["x"] <= xwin[1])
        col = {k: (v[keep] if isinstance(v, np.ndarray) else v) for k, v in series.items()}
        x, mean, sd, n = col["x"], col["mean"], col["sd"], col["n"]
        if len(x) == 0:
            continue
        mean = np.where(np.isfinite(mean), mean, np.nan)
        entry = entries.get(name, {})
        label = str(entry.get("label", name))
        median = uses_median(entry, col) and not is_bound(name, entry)
        if median:
            label += " (median)"
            if medians is not None and name not in [m for m, _ in medians]:
                medians.append((name, "--statistic median" if STATISTIC == "median"
                                else str(entry.get("mean_note", "mean not estimable"))))
        if legend_extra is not None:
            label = legend_extra(label, entry)
        marker, color = styler(name)
        if is_bound(name, entry):
            ax.plot(x, mean, "--", color=color, lw=1.4, label=label)
            continue
        # the first series widest, the later ones narrower on top: a series hidden under another
        # (lin_fig2's OE under the AOE) still shows as the outline of the line over it
        width = 1.1 + 1.4 * (len(names) - 1 - i) / max(len(names) - 1, 1)
        every = mark_indices(x, 10, (i + 0.5) / max(len(names), 1), log_x)
        y = col["median"] if median else mean
        ax.plot(x, y, "-", color=color, lw=width, marker=marker, markevery=every, ms=5,
                mfc="none", mew=1.1, label=label, zorder=2 + i)
        if median:
            for lo_key, hi_key, alpha in (("p5", "p95", 0.10), ("p25", "p75", 0.22)):
                if lo_key in col and hi_key in col:
                    bands.append((x, col[lo_key], col[hi_key], color, alpha))
            continue
        ok = (n > 1) & (sd > 0) & np.isfinite(sd) & np.isfinite(mean)
        if ok.any():
            se = np.where(ok, sd / np.sqrt(np.where(n > 1, n, 1.0)), np.nan)
            bands.append((x, mean - 2 * se, mean + 2 * se, color, 0.18))
    if bands:
        bottom = ax.get_ylim()[0] if log_y else None
        for x, lo, hi, color, alpha in bands:
            if log_y:
                lo = np.where(np.isnan(lo) | (lo > bottom), lo, bottom)
            ax.fill_between(x, lo, hi, color=color, alpha=alpha, lw=0)
        if log_y:
            ax.set_ylim(bottom=bottom)
    if not names or not ax.lines:
        ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", va="center",
                color="0.4")
        ax.tick_params(which="both", left=False, bottom=False, labelleft=False,
                       labelbottom=False)
    log_ticks(ax, log_x, log_y)
    ax.set_xlabel(str(meta.get("x_label", "x")))
    ax.set_ylabel(str(meta.get("y_label", "")))
    ax.grid(True, which="major", color="0.9", lw=0.6)
    if ax.lines:
        legend(ax)


def legend(ax, **kwargs):
    ax.legend(fontsize=8, title_fontsize=8, frameon=True, framealpha=0.85, edgecolor="none",
              **kwargs)


def log_ticks(ax, log_x, log_y):
    """Plain numbers on log axes (2, 3, 5 rather than 2x10^0 on a short range)."""
    for on, axis in ((log_x, ax.xaxis), (log_y, ax.yaxis)):
        if on:
            axis.set_major_formatter(ticker.LogFormatter(labelOnlyBase=False))
            axis.set_minor_formatter(ticker.LogFormatter(labelOnlyBase=False,
                                                         minor_thresholds=(2, 0.5)))


def panel_grid(count):
    ncols = 1 if count <= 1 else 2
    nrows = int(math.ceil(count / float(ncols)))
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.4 if ncols == 1 else 11.0, 4.2 * nrows),
                             squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[count:]:
        ax.set_visible(False)
    return fig, flat[:count]


def all_series(meta, data, cases):
    names = []
    for case in cases:
        for name in series_order(meta, data, case):
            if name not in names:
                names.append(name)
    return names


def note_medians(path, medians):
    """Says on stderr which series of a figure are drawn as medians, and why."""
    for name, why in medians:
        sys.stderr.write("note: %s: %s drawn as its median (%s)\n" % (path, name, why))


def band_caption(medians):
    """What the bands are: mean +-2 SE, and which series are medians and why."""
    if not medians:
        return "bands: mean +-2 SE"
    why = "; ".join("%s: %s" % (n, r) for n, r in medians[:3])
    if len(medians) > 3:
        why += "; ..."
    return "bands: mean +-2 SE; median with p25-p75 and p5-p95 bands for %s" % why


def plot_generic(name, meta, data, outdir, dpi, suffix=""):
    cases = case_order(meta, data)
    if not cases:
        cases = [""]
    styler = Styler(all_series(meta, data, cases))
    fig, axes = panel_grid(len(cases))
    medians = []
    for ax, case in zip(axes, cases):
        draw_panel(ax, meta, data, case, styler, medians=medians)
        ax.set_title(case_title(meta, case), fontsize=10)
    fig.suptitle(name, fontsize=11)
    path = os.path.join(outdir, "%s%s.png" % (name, suffix))
    finish(fig, meta, path, dpi, band_caption(medians))
    note_medians(path, medians)
    return [path]


def plot_tails(name, meta, data, outdir, dpi):
    """NAME_tail.png: P(value > M) against x for every series and threshold of every case (the
    P_gt_M columns), or nothing when there are none."""
    cases = [c for c in case_order(meta, data)
             if any(v.get("tail") for v in data.get(c, {}).values())]
    if not cases:
        return []
    styler = Styler(all_series(meta, data, cases))
    styles = ["-", "--", ":", "-."]
    fig, axes = panel_grid(len(cases))
    for ax, case in zip(axes, cases):
        ax.set_yscale("log", nonpositive="mask")
        if meta.get("log_x"):
            ax.set_xscale("log", nonpositive="mask")
        for series_name in series_order(meta, data, case):
            series = data[case][series_name]
            _, color = styler(series_name)
            for k, (m, p) in enumerate(series.get("tail", {}).items()):
                ax.plot(series["x"], np.where(p > 0, p, np.nan), styles[k % len(styles)], color=color,
                        lw=1.2, label="%s: P(> %s)" % (series_name, m))
        ax.set_xlabel(str(meta.get("x_label", "x")))
        ax.set_ylabel("fraction of runs above M")
        ax.set_title(case_title(meta, case), fontsize=10)
        ax.grid(True, which="major", color="0.9", lw=0.6)
        log_ticks(ax, bool(meta.get("log_x")), True)
        if ax.lines:
            legend(ax)
    fig.suptitle("%s: tail probabilities of %s" % (name, meta.get("y_label", "the values")), fontsize=11)
    path = os.path.join(outdir, "%s_tail.png" % name)
    finish(fig, meta, path, dpi, "P(value > M) over the runs at each x; 0 not drawn")
    return [path]


def plot_averaged(name, meta, hints, data, outdir, dpi):
    """One figure per case: the full x range, and a zoom on the hints' "zoom" range whose legend
    gives each series' time average."""
    cases = case_order(meta, data)
    styler = Styler(all_series(meta, data, cases))
    written = []
    for case in cases:
        xs = np.concatenate([v["x"] for v in data.get(case, {}).values()] or [np.zeros(0)])
        lo, hi = float(hints["zoom"][0]), float(hints["zoom"][1])
        if xs.size and not ((xs >= lo) & (xs <= hi)).sum() >= 2:
            # too short a horizon for the paper's window: zoom on the second half instead
            lo, hi = float(xs.min() + 0.5 * (xs.max() - xs.min())), float(xs.max())
        if xs.size:
            hi = min(hi, float(xs.max()))
        fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.6), squeeze=False)
        full, zoom = axes[0]
        medians = []
        draw_panel(full, meta, data, case, styler, medians=medians)
        full.set_title("full horizon", fontsize=10)

        def with_average(label, entry):
            avg = entry.get("time_average")
            if isinstance(avg, (int, float)) and math.isfinite(avg):
                return "%s (%.4g)" % (label, avg)
            return label

        draw_panel(zoom, meta, data, case, styler, xwin=(lo, hi), legend_extra=with_average)
        zoom.set_title(r"$%g \leq %s \leq %g$" % (lo, x_symbol(meta), hi), fontsize=10)
        if zoom.get_legend() is not None:
            window = None
            for entry in series_meta(meta, case).values():
                if isinstance(entry.get("window"), list) and len(entry["window"]) == 2:
                    window = entry["window"]
                    break
            title = "time average"
            if window is not None:
                title += " over k in [%s, %s]" % (window[0], window[1])
            legend(zoom, title=title, loc="upper center", bbox_to_anchor=(0.5, -0.13),
                   ncol=min(4, len(zoom.lines)))
        fig.suptitle("%s: %s" % (name, case_title(meta, case)), fontsize=11)
        path = os.path.join(outdir, "%s_%s.png" % (name, safe_name(case)))
        finish(fig, meta, path, dpi, band_caption(medians))
        note_medians(path, medians)
        written.append(path)
    return written


def kde(samples, grid):
    """Gaussian kernel density estimate on `grid`, bandwidth by the normal reference rule with
    a robust spread (median absolute deviation / 0.6745), as Matlab's ksdensity does."""
    n = samples.size
    spread = np.median(np.abs(samples - np.median(samples))) / 0.6745
    if not spread > 0:
        spread = np.std(samples)
    if not spread > 0:
        spread = max(abs(float(samples[0])) * 1e-3, 1e-12)
    bw = spread * (4.0 / (3.0 * n)) ** 0.2
    density = np.zeros_like(grid)
    for start in range(0, n, 2048):
        chunk = samples[start:start + 2048]
        z = (grid[:, None] - chunk[None, :]) / bw
        density += np.exp(-0.5 * z * z).sum(axis=1)
    return density / (n * bw * math.sqrt(2.0 * math.pi)), bw


def x_symbol(meta):
    """The x axis' label as a mathtext symbol when it is one plain word (k, M), else x."""
    label = str(meta.get("x_label", "x"))
    return label if re.fullmatch(r"[A-Za-z]\w*", label) else "x"


def case_label(hints, meta, case):
    labels = hints.get("case_labels")
    if isinstance(labels, dict) and isinstance(labels.get(case), str):
        return labels[case]
    return case_title(meta, case)


def plot_density(name, meta, hints, samples, outdir, dpi):
    """Empirical PDFs (Gaussian KDE) of the hints' sample columns, one panel each, the cases
    overlaid (x o square diamond, as in Zhou's Fig. 2)."""
    cases = [c for c in case_order(meta, {}) if c in samples] + \
        [c for c in samples if c not in case_order(meta, {})]
    markers = ["x", "o", "s", "D"]
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    elements = [(c["column"], str(c.get("label", c["column"])), str(c.get("title", c["column"])))
                for c in hints["columns"]]
    fig, axes = plt.subplots(len(elements), 1, figsize=(6.4, 3.1 * len(elements)), squeeze=False)
    for ax, (column, xlabel, title) in zip(axes[:, 0], elements):
        finite = {c: samples[c][column][np.isfinite(samples[c][column])] for c in cases}
        usable = [c for c in cases if finite[c].size >= 2]
        if not usable:
            ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", va="center")
            continue
        pooled = np.concatenate([finite[c] for c in usable])
        lo, hi = float(pooled.min()), float(pooled.max())
        pad = 3.0 * max(kde(finite[c], np.zeros(1))[1] for c in usable)
        grid = np.linspace(lo - pad, hi + pad, 400)
        for c in usable:
            density, _ = kde(finite[c], grid)
            k = cases.index(c)
            ax.plot(grid, density, "-", color=colors[k % 4], lw=1.1, marker=markers[k % 4],
                    markevery=(5 + (10 * k) % 40, 40), ms=5, mfc="none", mew=1.1,
                    label="%s (%d runs)" % (case_label(hints, meta, c), finite[c].size))
        ax.set_xlim(grid[0], grid[-1])
        ax.set_ylim(bottom=0)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("EPDF")
        ax.set_title(title, fontsize=10)
        ax.grid(True, color="0.9", lw=0.6)
        if column == elements[0][0]:
            legend(ax)
    fig.suptitle("%s: %s" % (name, hints.get("title", "empirical PDFs of the samples")), fontsize=11)
    path = os.path.join(outdir, "%s.png" % name)
    finish(fig, meta, path, dpi, "Gaussian KDE, normal-reference bandwidth")
    return [path]


SWEEP_MEDIAN_COLUMNS = ["trP_p5", "trP_p25", "trP_median", "trP_p75", "trP_p95"]


def read_sweep_csv(path):
    """Returns {estimator: [(i1, i2, x1, x2, n, trP_mean, trP_sd, quantiles)]} of a sweep's CSV, in
    file order, quantiles {column: value} of the trP_p5 .. trP_p95 columns present; an empty cell
    (no mean at that point, or no second axis) is NaN."""
    data = {}
    rows = csv_rows(path, SWEEP_HEADER, prefix=True)
    header = csv_header(path)
    for line, row in rows:

        def number(column, empty_ok=False):
            text = row[header.index(column)].strip() if header.index(column) < len(row) else ""
            if empty_ok and text == "":
                return float("nan")
            return parse_float(text, path, line, column)

        quantiles = {c: number(c, True) for c in SWEEP_MEDIAN_COLUMNS if c in header}
        data.setdefault(row[5].strip(), []).append(
            (int(number("i1")), int(number("i2")), number("x1"), number("x2", True),
             number("n"), number("trP_mean", True), number("trP_sd", True), quantiles))
    if not data:
        raise InputError(path, "no data rows")
    return data


def sweep_statistic(data):
    """("mean" or "median", why): the statistic a stability map shows (--statistic; auto: the
    median when some cell's mean is missing while its median is not, its standard error is above a
    fifth of it, or it lies above the 95th percentile)."""
    cells = [r for rows in data.values() for r in rows]
    has_median = any(np.isfinite(r[7].get("trP_median", np.nan)) for r in cells)
    if STATISTIC != "auto":
        return (STATISTIC, "--statistic") if has_median or STATISTIC == "mean" else ("mean", "no median")
    if not has_median:
        return "mean", ""
    for _, _, _, _, n, mean, sd, q in cells:
        median = q.get("trP_median", np.nan)
        if not np.isfinite(median):
            continue
        if not np.isfinite(mean):
            return "median", "a cell without a finite mean"
        if n > 1 and sd / math.sqrt(n) > 0.2 * abs(mean):
            return "median", "a mean with a standard error above 20 %"
        if mean > q.get("trP_p95", np.inf):
            return "median", "a mean above the 95th percentile"
    return "mean", ""


def sweep_meta(meta, path):
    sweep = meta.get("sweep")
    if not isinstance(sweep, dict) or not isinstance(sweep.get("axes"), list) or \
            not 1 <= len(sweep["axes"]) <= 2 or \
            not all(isinstance(a, dict) and isinstance(a.get("values"), list)
                    for a in sweep["axes"]):
        raise InputError(path, "\"sweep\" must hold \"axes\": one or two objects with \"values\"")
    critical = sweep.get("critical", {})
    curve = critical.get("curve", []) if isinstance(critical, dict) else []
    if not isinstance(curve, list) or not all(isinstance(c, dict) for c in curve):
        raise InputError(path, "\"sweep\".\"critical\".\"curve\" must be a list of objects")
    return sweep, curve


def curve_values(curve, key):
    return np.array([c.get(key) if isinstance(c.get(key), (int, float)) else np.nan
                     for c in curve], dtype=float)


def cell_edges(values):
    v = np.asarray(values, dtype=float)
    if v.size == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else np.array([v[0] * 0.95, v[0] * 1.05])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def plot_sweep(name, meta, indir, outdir, dpi):
    json_path = os.path.join(indir, name + ".json")
    sweep, curve = sweep_meta(meta, json_path)
    data = read_sweep_csv(os.path.join(indir, name + ".csv"))
    axes_meta = sweep["axes"]
    estimators = [e for e in sweep.get("estimators", []) if e in data] + \
        [e for e in data if e not in sweep.get("estimators", [])]
    fig, panels = panel_grid(len(estimators))
    div = curve_values(curve, "diverges_at")
    conv = curve_values(curve, "converges_at")
    band = np.array([bool(c.get("undecided_band")) for c in curve], dtype=bool)
    names = [str(a.get("name", "axis %d" % (i + 1))) for i, a in enumerate(axes_meta)]
    statistic, why = sweep_statistic(data)
    extra = "tr P at k = %s; grey: no mean (diverged or floored runs)" \
        % meta.get("steps", "T")
    if statistic == "median":
        extra = "median tr P at k = %s (the mean is not estimable: %s), p25-p75 band; grey: no value" \
            % (meta.get("steps", "T"), why)

    def value(r):
        return r[7].get("trP_median", np.nan) if statistic == "median" else r[5]
    for ax, est in zip(panels, estimators):
        rows = data[est]
        if len(axes_meta) == 2:
            v1 = np.array(axes_meta[0]["values"], dtype=float)
            v2 = np.array(axes_meta[1]["values"], dtype=float)
            grid = np.full((v2.size, v1.size), np.nan)
            for r in rows:
                i1, i2, v = r[0], r[1], value(r)
                if 0 <= i1 < v1.size and 0 <= i2 < v2.size and v > 0:
                    grid[i2, i1] = math.log10(v)
            ax.set_facecolor("0.75")
            finite = grid[np.isfinite(grid)]
            if finite.size:
                # at most MAP_DECADES decades of colour: the deep unstable corner (tr P growing
                # like a power of T) would otherwise flatten the region near the boundary
                lo = float(finite.min())
                hi = max(min(float(finite.max()), lo + MAP_DECADES), lo + 1e-9)
                mesh = ax.pcolormesh(cell_edges(v1), cell_edges(v2), np.ma.masked_invalid(grid),
                                     cmap="viridis", shading="flat", vmin=lo, vmax=hi)
                bar = fig.colorbar(mesh, ax=ax, label=r"$\log_{10}$ %s tr $P_T$" % statistic,
                                   extend="max" if finite.max() > hi else "neither")
                formatter = bar.ax.yaxis.get_major_formatter()
                if hasattr(formatter, "set_useOffset"):  # a flat map: plain numbers
                    formatter.set_useOffset(False)
            at = curve_values(curve, "at")
            # not stable even at the largest value (converges_at null, diverges_at given): the
            # curve runs along the top edge of the map
            conv = np.where(np.isnan(conv) & np.isfinite(div), cell_edges(v2)[-1], conv)
            if at.size == v1.size and np.isfinite(conv).any():
                ax.plot(at, conv, "-", color="white", lw=2.4)
                ax.plot(at, conv, "-", color="tab:red", lw=1.4,
                        label="critical %s (analysis)" % names[1])
                if band.any():
                    ax.fill_between(at, np.where(band, div, np.nan), np.where(band, conv, np.nan),
                                    facecolor="none", edgecolor="tab:red", hatch="///", lw=0,
                                    label="undecided band")
                legend(ax, loc="upper right")
            ax.set_xlim(cell_edges(v1)[0], cell_edges(v1)[-1])
            ax.set_ylim(cell_edges(v2)[0], cell_edges(v2)[-1])
            ax.set_xlabel(names[0])
            ax.set_ylabel(names[1])
        else:
            pts = sorted(rows, key=lambda r: r[2])
            x = np.array([r[2] for r in pts], dtype=float)
            mean = np.array([value(r) for r in pts], dtype=float)
            sd = np.array([r[6] for r in pts], dtype=float)
            n = np.array([r[4] for r in pts], dtype=float)
            ax.set_yscale("log", nonpositive="mask")
            ax.plot(x, mean, "-o", color="tab:blue", ms=4, mfc="none", label="%s tr $P_T$" % statistic)
            if statistic == "median":
                lo = np.array([r[7].get("trP_p25", np.nan) for r in pts], dtype=float)
                hi = np.array([r[7].get("trP_p75", np.nan) for r in pts], dtype=float)
            else:
                se = np.where(n > 1, sd / np.sqrt(np.where(n > 1, n, 1.0)), np.nan)
                lo, hi = np.maximum(mean - 2 * se, mean * 1e-3), mean + 2 * se
            ok = np.isfinite(lo) & np.isfinite(hi) & np.isfinite(mean)
            if ok.any():
                ax.fill_between(x[ok], lo[ok], hi[ok], color="tab:blue", alpha=0.18, lw=0)
            missing = x[~np.isfinite(mean)]
            if missing.size:
                for xm in missing:
                    ax.axvspan(xm - 0.5 * (x[1] - x[0] if x.size > 1 else 0.02),
                               xm + 0.5 * (x[1] - x[0] if x.size > 1 else 0.02),
                               color="0.75", lw=0)
            if conv.size and np.isfinite(conv[0]):
                ax.axvline(conv[0], color="tab:red", lw=1.4, label="critical value (analysis)")
                if band.size and band[0] and np.isfinite(div[0]):
                    ax.axvspan(div[0], conv[0], facecolor="none", edgecolor="tab:red",
                               hatch="///", lw=0, label="undecided band")
            ax.set_xlabel(names[0])
            ax.set_ylabel("%s tr $P_T$" % statistic)
            ax.grid(True, which="major", color="0.9", lw=0.6)
            legend(ax)
        ax.set_title(est, fontsize=10)
    fig.suptitle("%s: stability map" % name, fontsize=11)
    path = os.path.join(outdir, "%s.png" % name)
    finish(fig, meta, path, dpi, extra)
    if statistic == "median":
        note_medians(path, [("tr P_T", why)])
    return [path]


# ---------------------------------------------------------------------------------------------
# Main
# ---------------------------------------------------------------------------------------------

def plot_experiment(name, indir, outdir, dpi):
    json_path = os.path.join(indir, name + ".json")
    meta = read_json(json_path)
    meta.setdefault("experiment", name)
    hints = plot_hints(meta, json_path)
    kind = hints["kind"]
    if kind == "sweep":
        return plot_sweep(name, meta, indir, outdir, dpi)
    data = read_results_csv(os.path.join(indir, name + ".csv"))
    if kind == "density":
        samples = read_samples_csv(os.path.join(indir, name + "_samples.csv"),
                                   [c["column"] for c in hints["columns"]])
        written = plot_density(name, meta, hints, samples, outdir, dpi)
        # The table of a density experiment summarises the samples (one x per series): nothing to
        # draw beyond the PDFs. A table with curves over x gets its own figure.
        if any(len(v["x"]) > 1 for per_case in data.values() for v in per_case.values()):
            written += plot_generic(name, meta, data, outdir, dpi, suffix="_series")
    else:
        if not data:
            raise InputError(os.path.join(indir, name + ".csv"), "no data rows")
        if kind == "averaged":
            written = plot_averaged(name, meta, hints, data, outdir, dpi)
        else:
            written = plot_generic(name, meta, data, outdir, dpi)
    if hints.get("tails", True):
        written += plot_tails(name, meta, data, outdir, dpi)
    return written


def main(argv):
    parser = argparse.ArgumentParser(
        description="Plot the output of the montecarlo tool (see the module docstring).")
    parser.add_argument("dir", metavar="DIR", help="directory written by montecarlo")
    parser.add_argument("--out", metavar="OUTDIR", help="where the PNGs go (default DIR)")
    parser.add_argument("--experiment", metavar="NAME", nargs="+", action="extend",
                        help="plot only these experiments")
    parser.add_argument("--dpi", type=int, default=100, help="resolution (default 100)")
    parser.add_argument("--statistic", choices=["auto", "mean", "median"], default="auto",
                        help="the line of every series: auto (the mean, or the median where the JSON "
                             "says the mean is not estimable; default), mean or median")
    args = parser.parse_args(argv)
    global STATISTIC
    STATISTIC = args.statistic

    def fail(path, problem):
        sys.stderr.write("error: %s: %s\n" % (path, problem))
        return 2

    if not os.path.isdir(args.dir):
        return fail(args.dir, "no such directory")
    if args.dpi <= 0:
        return fail("--dpi", "must be positive")
    if args.experiment:
        names = list(dict.fromkeys(args.experiment))
    else:
        names = sorted(f[:-5] for f in os.listdir(args.dir)
                       if f.endswith(".json") and os.path.isfile(os.path.join(args.dir, f)))
        if not names:
            return fail(args.dir, "no experiment found (no NAME.json)")
    outdir = args.out or args.dir
    try:
        os.makedirs(outdir, exist_ok=True)
    except OSError as exc:
        return fail(outdir, "cannot create: %s" % exc.strerror)

    global np, plt, ticker
    np, plt, ticker = import_plotting()
    warnings.filterwarnings("ignore", module="matplotlib")
    plt.rcParams.update({"font.size": 9, "axes.titlesize": 10, "legend.fontsize": 8})

    status = 0
    for name in names:
        try:
            for path in plot_experiment(name, args.dir, outdir, args.dpi):
                print(path)
                sys.stdout.flush()
        except InputError as exc:
            status = fail(exc.path, exc.problem)
        except Exception as exc:  # a drawing problem (e.g. a bad mathtext label): no traceback
            plt.close("all")
            status = fail(os.path.join(args.dir, name + ".json"),
                          "cannot plot: %s: %s" % (type(exc).__name__, exc))
    return status


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except KeyboardInterrupt:
        sys.exit(130)
