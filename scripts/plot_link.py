#!/usr/bin/env python3
"""Draws a link measured by fit_link: the loss pattern over time, the burst-length histogram against
the fitted model's, and the delay distribution with its quantiles (one PNG per link).

    fit_link --bag base.bag --topic /gps/fix --json --series > fit.json
    scripts/plot_link.py fit.json --out link.png [--link N] [--dpi D]

FIT is fit_link's JSON with --series (`-` reads it from stdin). With several links in it (several
--topic), --link N draws the N-th (from 0) into OUT; without --link every link is drawn, the N-th
into OUT with _N before its extension. Prints the files written, one a line. Bad input (a file that
is not fit_link's JSON, a fit without --series, --link out of range) exits 2 naming it.
Needs Debian's python3-matplotlib (scripts/install_deps.sh).
"""
import argparse
import json
import math
import os
import sys


class InputError(Exception):
    pass


def load(path):
    try:
        text = sys.stdin.read() if path == "-" else open(path).read()
    except OSError as e:
        raise InputError("%s: %s" % (path, e.strerror))
    try:
        doc = json.loads(text)
    except ValueError as e:
        raise InputError("%s: not JSON (%s)" % (path, e))
    if not isinstance(doc, dict) or not isinstance(doc.get("links"), list) or not doc["links"]:
        raise InputError('%s: expected fit_link --json output (an object with a non-empty "links" list)' % path)
    for i, link in enumerate(doc["links"]):
        for key in ("period", "bursts", "model_bursts", "delay", "model"):
            if key not in link:
                raise InputError('%s: link %d has no "%s" (not fit_link --json output?)' % (path, i, key))
        if "series" not in link:
            raise InputError('%s: link %d (%s) has no "series": run fit_link with --json --series'
                             % (path, i, link.get("source", "?")))
        s = link["series"]
        if not isinstance(s.get("arrived"), str) or len(s.get("delay", [])) != len(s["arrived"]):
            raise InputError('%s: link %d: "series" must hold "arrived" (a string of 0 and 1) and as many '
                             '"delay" values' % (path, i))
    return doc["links"]


def out_name(out, index, count):
    if count == 1:
        return out
    root, ext = os.path.splitext(out)
    return "%s_%d%s" % (root, index, ext or ".png")


def plot(link, out, dpi):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise InputError("%s needs matplotlib (%s): apt-get install python3-matplotlib, and run it with "
                         "Debian's python3 (source scripts/workspace.sh)" % (sys.argv[0], e))

    arrived = link["series"]["arrived"]
    period = link["period"]
    n = len(arrived)
    t = [k * period for k in range(n)]
    fig, axes = plt.subplots(3, 1, figsize=(8, 9))
    source = link.get("source", "")
    fig.suptitle("%s: %d expected, %d lost (%.3g %%), %s chosen" % (
        source, link.get("expected", n), link.get("lost", arrived.count("0")), 100.0 * link.get("loss_rate", 0.0),
        link["model"]), fontsize=10)

    # 1. The loss pattern over time: each lost message a tick, and the loss rate over windows.
    ax = axes[0]
    lost_t = [t[k] for k in range(n) if arrived[k] == "0"]
    ax.eventplot([lost_t], colors="tab:red", lineoffsets=0.5, linelengths=1.0, linewidths=0.5)
    window = max(1, n // 200)
    centres, rates = [], []
    for k in range(0, n, window):
        chunk = arrived[k:k + window]
        centres.append((k + len(chunk) / 2.0) * period)
        rates.append(chunk.count("0") / float(len(chunk)))
    ax2 = ax.twinx()
    ax2.plot(centres, rates, color="black", linewidth=1.0)
    ax2.set_ylabel("loss rate (windows of %d)" % window)
    ax2.set_ylim(0.0, 1.05)
    ax.set_yticks([])
    ax.set_xlim(0.0, max(n * period, period))
    ax.set_xlabel("time since the first message received (s)")
    ax.set_title("losses over time (red: a lost message)", fontsize=9)

    # 2. The burst lengths observed against the fitted model's law (as fractions of the bursts).
    ax = axes[1]
    bursts = link["bursts"]
    total = float(sum(bursts))
    model = link["model_bursts"]
    if total > 0:
        lengths = list(range(1, len(bursts) + 1))
        ax.bar(lengths, [b / total for b in bursts], color="tab:blue", alpha=0.7, label="observed (%d bursts)" % total)
        m = len(model)
        ax.plot(list(range(1, m + 1)), model, "o-", color="black", markersize=3, linewidth=1.0,
                label="%s fit" % link["model"])
        ax.set_yscale("log")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no losses", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("burst length (messages lost in a row)")
    ax.set_ylabel("fraction of bursts")
    ax.set_title("burst lengths", fontsize=9)

    # 3. The delay distribution and its quantiles.
    ax = axes[2]
    d = link["delay"]
    delays = [1000.0 * x for x in link["series"]["delay"] if x is not None and math.isfinite(x)]
    if delays:
        ax.hist(delays, bins=min(100, max(10, int(math.sqrt(len(delays))))), color="tab:green", alpha=0.7)
        for q, style in (("p50", "-"), ("p90", "--"), ("p99", "-."), ("max", ":")):
            if d.get(q) is not None:
                ax.axvline(1000.0 * d[q], color="black", linestyle=style, linewidth=1.0,
                           label="%s %.3g ms" % (q, 1000.0 * d[q]))
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no delays", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("delay (ms)%s" % (": relative to the smallest (the clocks differ)" if d.get("relative") else ""))
    ax.set_ylabel("messages")
    ax.set_title("delays (receipt - stamp)", fontsize=9)

    fig.tight_layout()
    fig.savefig(out, dpi=dpi)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fit", help="fit_link --json --series output (- for stdin)")
    ap.add_argument("--out", required=True, help="the PNG to write")
    ap.add_argument("--link", type=int, help="draw only this link (from 0)")
    ap.add_argument("--dpi", type=int, default=100)
    a = ap.parse_args()
    try:
        links = load(a.fit)
        if a.link is not None:
            if not 0 <= a.link < len(links):
                raise InputError("--link %d: %s holds %d link(s)" % (a.link, a.fit, len(links)))
            chosen = [(a.out, links[a.link])]
        else:
            chosen = [(out_name(a.out, i, len(links)), l) for i, l in enumerate(links)]
        folder = os.path.dirname(os.path.abspath(a.out))
        if not os.path.isdir(folder):
            raise InputError("--out %s: no folder %s" % (a.out, folder))
        for out, link in chosen:
            plot(link, out, a.dpi)
            print(out)
    except InputError as e:
        print("error: %s" % e, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
