#!/usr/bin/env python3
"""Zhou's Fig. 1 from Python: the mean squared error MSE_k of KF, KFIO, RSE and RSEIO in the three
cases of the zhou_fig1 experiment (docs/reproducing.md), one panel per case, over the window the
experiment averages (k = 80 ... 500), with bands of +-2 standard errors.

usage: zhou_fig1.py [OUT.png]     (default: zhou_fig1.png in the current directory)

The paper's 5000 runs of 500 steps take about a second on two cores (docs/python.md).
"""
import sys

import matplotlib.pyplot as plt
import networked_estimation as ne

out = sys.argv[1] if len(sys.argv) > 1 else "zhou_fig1.png"
result = ne.montecarlo("zhou_fig1", runs=5000, seed=1)  # the paper's 5000 runs, all cores
fig, axes = plt.subplots(1, len(result.cases), figsize=(15, 4.5))
for ax, case in zip(axes, result.cases):
    for name, s in case["series"].items():
        k = case["x"] >= s["window"][0]  # the steps the experiment averages over
        band = 2 * s["sd"][k] / s["n"] ** 0.5
        line, = ax.plot(case["x"][k], s["mean"][k], lw=1, label=f"{name} ({s['time_average']:.2f})")
        ax.fill_between(case["x"][k], s["mean"][k] - band, s["mean"][k] + band, color=line.get_color(),
                        alpha=0.15)
    ax.set(title=case["title"], xlabel=result.x_label, ylabel=result.y_label)
    ax.legend(title="time average over the window", ncol=2, loc="upper center",
              bbox_to_anchor=(0.5, -0.15))
fig.suptitle(f"Zhou, Fig. 1: {result.runs} runs of {result.steps} steps, seed {result.seed}")
fig.savefig(out, dpi=90, bbox_inches="tight")
print(f"wrote {out} ({result.wall_seconds:.1f} s of Monte Carlo on {result.threads} threads)")
