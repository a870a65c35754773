#!/usr/bin/env python3
"""A stability map from Python: the verdict of the stability analysis (docs/stability.md) for one
model over a grid of on/off Gilbert-Elliott links, failure rate p against recovery rate r.

The model: a state that turns by 90 degrees and grows by 20 % per step, one sensor that sees its
first coordinate only. Its sensor sees each direction at one parity of time, so the verdict
depends on p as well as r, and the stable set of r need not be a half-line (docs/stability.md,
section 3.6).

usage: stability_map.py [OUT.png]     (default: stability_map.png in the current directory)
"""
import sys

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap
import networked_estimation as ne

out = sys.argv[1] if len(sys.argv) > 1 else "stability_map.png"
# x_k = A x_{k-1} + w_{k-1} (a turn by 90 degrees and 20 % growth per step), y_k = x_k[0] + v_k
model = ne.Model(name="rotation", A=[[0, -1.2], [1.2, 0]], Q=np.eye(2),
                 sensors=[ne.Sensor("s", C=[[1, 0]], R=[[1]])])
kinds, colours = ["stable", "undecided", "unstable"], ["tab:green", "gold", "tab:red"]
p = r = np.linspace(0.0125, 0.9875, 40)  # cell centres of a 40 x 40 grid on [0, 1]^2
# the verdict for all the model's sensors together (here its one sensor), at every (p, r): verdict()
# gives analyze()'s verdict without the rest of the report
verdict = [[ne.verdict(model, ne.GilbertElliott(p=a, r=b))["verdict"]["kind"] for a in p] for b in r]
fig, ax = plt.subplots(figsize=(6.5, 5))
cells = ax.pcolormesh(p, r, [[kinds.index(v) for v in row] for row in verdict], cmap=ListedColormap(colours),
                      vmin=-0.5, vmax=2.5, shading="nearest")
fig.colorbar(cells, ticks=range(len(kinds))).ax.set_yticklabels(kinds)
ax.set(xlabel="failure rate p = P(good -> bad)", ylabel="recovery rate r = P(bad -> good)",
       title=f"E[P] of kfio on '{model.name}' over an on/off Gilbert-Elliott link")
fig.savefig(out, dpi=90, bbox_inches="tight")
print(f"wrote {out}: " + ", ".join(f"{sum(row.count(k) for row in verdict)} {k}" for k in kinds))
