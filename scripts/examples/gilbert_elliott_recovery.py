#!/usr/bin/env python3
"""The critical recovery rate of a Gilbert-Elliott link, from the stability analysis, checked by
Monte Carlo.

The plant of Lin et al.'s example (config/models/aoe_example.yaml, rho(A) = 1.291) behind an on/off
Gilbert-Elliott link with failure rate p = 0.05: the analysis gives the critical recovery rate r_c
(docs/stability.md, section 3.6). At a recovery rate clearly below r_c the mean tr P of kfio over
many runs grows without bound; clearly above it, it settles. The horizon is 100 steps: the plant
itself grows by 29 % per step, and the simulator refuses to go on once its state is so large that
rounding would swamp the measurement noise (near k = 108 here).

usage: gilbert_elliott_recovery.py     (from anywhere; it reads the model from the repository)
"""
from pathlib import Path

import numpy as np
import networked_estimation as ne

model = ne.Model.from_yaml(Path(__file__).resolve().parents[2] / "config/models/aoe_example.yaml")
p, runs, steps, shown = 0.05, 5000, 100, [20, 40, 60, 80, 100]
# the analysis for all the model's sensors (here its one sensor); r_c does not depend on the link's r
analysis = ne.analyze(model, ne.GilbertElliott(p=p, r=0.5))["all_sensors"]
r_c = analysis["recovery_exact"]  # None where the stable set of r is not a half-line
print(f"{model.name} over an on/off Gilbert-Elliott link with p = {p}")
print(f"critical recovery rate r_c = {r_c:.6f} ({analysis['recovery_note']})")
print(f"mean tr P_k|k of kfio over {runs} runs:")
print(f"{'r':>10}" + "".join(f"{'k = ' + str(k):>11}" for k in shown) + f"   k = {shown[0]} -> {steps}")
kfio = ne.make_estimator(model, "kfio")
for r in (r_c - 0.3, r_c + 0.3):
    link = ne.GilbertElliott(p=p, r=r)
    sims = (ne.simulate(model, link, steps=steps, seed=seed) for seed in range(1, runs + 1))
    # every run from a fresh copy of the estimator; run() returns (x, P, tr P) at every step
    mean = np.mean([kfio.clone().run(s["y"], s["gamma"], U=s["u"])[2] for s in sims], axis=0)
    verdict = ne.analyze(model, link)["all_sensors"]["verdict"]["kind"]
    print(f"{r:10.3f}" + "".join(f"{mean[k - 1]:11.3g}" for k in shown)
          + f"   x{mean[-1] / mean[shown[0] - 1]:<9.3g} the analysis' verdict: {verdict}")
