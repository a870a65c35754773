#!/usr/bin/env python3
"""Speed of the Python module against the C++ it binds (docs/python.md, "Speed"):

  1. step() from Python vs the C++ step, kfio at n = 4 (a 2-D constant-velocity model, m = 2): the C++
     step is timed by run(), which steps the same sequence in one C++ loop; the overhead per step is
     (a Python loop of step() calls - run()) / N.
  2. run() vs the replay tool on the same input file: load_replay_input() + run() against
     `replay` (which also parses that file, and writes its output), and run() alone.
  3. montecarlo("zhou_fig1") vs the montecarlo tool, same runs, steps, seed and threads.
  4. the covariance-only Monte Carlo against the state-simulating one at n = 4: montecarlo("covariance")
     and montecarlo("custom") on the model of part 1 behind a Bernoulli link, kfio, same runs, steps and
     threads, in runs per second (the issue's target: at least 10x).

Usage (after scripts/build.sh; Debian's python3, see scripts/env.sh):
  source .ws/devel/setup.bash; python3 scripts/bench_python.py [--repeat R] [--steps N] [--runs M]
Prints a table; each time is the best of R repetitions (the least disturbed by the rest of the machine).
"""
import argparse
import os
import pathlib
import subprocess
import tempfile
import time

import numpy as np

import networked_estimation as ne

ROOT = pathlib.Path(__file__).resolve().parents[1]


def tools_dir():
    for prefix in os.environ.get("CMAKE_PREFIX_PATH", "").split(":"):
        d = pathlib.Path(prefix) / "lib" / "networked_estimation"
        if (d / "replay").exists():
            return d
    raise SystemExit("bench_python: the tools are not on CMAKE_PREFIX_PATH: source the workspace's setup.bash")


def best(repeat, f):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def cv_model():
    dt = 0.02
    A = np.eye(4)
    A[0, 2] = A[1, 3] = dt
    return ne.Model(name="cv_2d", period=dt, A=A, Q=np.diag([1e-6, 1e-6, 1e-2, 1e-2]),
                    sensors=[ne.Sensor("pos", C=np.eye(2, 4), R=np.eye(2) * 0.01)], x0=np.zeros(4), P0=np.eye(4))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--steps", type=int, default=200000, help="steps of parts 1 and 2")
    ap.add_argument("--runs", type=int, default=2000, help="runs of part 3 (zhou_fig1, 500 steps each)")
    ap.add_argument("--threads", type=int, default=1, help="threads of part 3")
    a = ap.parse_args()
    tools = tools_dir()
    rows = []

    # 1. step() overhead at n = 4
    m = cv_model()
    sim = ne.simulate(m, ne.Bernoulli(0.2, seed=3), steps=a.steps, seed=1)
    Y, G = sim["y"], sim["gamma"]
    ys, gs = list(Y), [bool(g) for g in G]

    def loop():
        est = ne.make_estimator(m, "kfio")
        step = est.step
        for y, g in zip(ys, gs):
            step(y, g)

    t_run = best(a.repeat, lambda: ne.make_estimator(m, "kfio").run(Y, G))
    t_loop = best(a.repeat, loop)
    impl = ne.make_estimator(m, "kfio").implementation
    rows.append((f"kfio n=4 m=2 ({impl}): C++ step, in run()", t_run / a.steps * 1e9, "ns/step"))
    rows.append(("kfio n=4 m=2: step() from a Python loop", t_loop / a.steps * 1e9, "ns/step"))
    rows.append(("  overhead of step() over the C++ step (target <= 2000)", (t_loop - t_run) / a.steps * 1e9,
                 "ns/step"))

    # 2. run() vs replay on the same input
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        model_file = ROOT / "config" / "models" / "planar_robot.yaml"
        subprocess.run([tools / "simulate", "--model", model_file, "--channel",
                        ROOT / "config" / "channels" / "wifi_bursty.yaml", "--steps", str(a.steps), "--seed", "2",
                        "--out", tmp], check=True, capture_output=True)
        settings = ROOT / "config" / "estimators" / "kfio.yaml"
        replay = [tools / "replay", "--model", model_file, "--settings", settings, "--input", tmp / "input.csv",
                  "--output", tmp / "out.csv"]
        t_replay = best(a.repeat, lambda: subprocess.run(replay, check=True))
        planar = ne.Model.from_yaml(model_file)

        def load_and_run():
            d = ne.load_replay_input(tmp / "input.csv", planar)
            ne.make_estimator(planar, str(settings)).run(d["Y"], d["gamma"])

        data = ne.load_replay_input(tmp / "input.csv", planar)
        t_load_run = best(a.repeat, load_and_run)
        t_run_only = best(a.repeat, lambda: ne.make_estimator(planar, str(settings)).run(data["Y"], data["gamma"]))
    rows.append((f"replay tool, planar_robot n=6, {a.steps} steps (parse, filter, write)", t_replay * 1e3, "ms"))
    rows.append(("load_replay_input() + run() on the same file", t_load_run * 1e3, "ms"))
    rows.append(("  ratio to replay (target <= 1.10)", t_load_run / t_replay, ""))
    rows.append(("run() alone (arrays in, arrays out)", t_run_only * 1e3, "ms"))

    # 3. zhou_fig1
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [tools / "montecarlo", "--experiment", "zhou_fig1", "--runs", str(a.runs), "--seed", "1",
               "--threads", str(a.threads), "--out", tmp]
        t_tool = best(a.repeat, lambda: subprocess.run(cmd, check=True, capture_output=True))
    t_py = best(a.repeat, lambda: ne.montecarlo("zhou_fig1", runs=a.runs, seed=1, threads=a.threads))
    rows.append((f"montecarlo tool, zhou_fig1, {a.runs} runs, {a.threads} thread(s)", t_tool, "s"))
    rows.append(("montecarlo() from Python, the same", t_py, "s"))
    rows.append(("  ratio to the tool (target <= 1.10)", t_py / t_tool, ""))

    # 4. covariance only vs the state simulation, n = 4
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "model.yaml").write_text(m.to_yaml())
        (tmp / "link.yaml").write_text(ne.Bernoulli(0.2, seed=3).to_yaml())
        (tmp / "kfio.yaml").write_text("algorithm: kfio\n")
        files = dict(model=tmp / "model.yaml", channels=tmp / "link.yaml", settings=tmp / "kfio.yaml")
        cov_runs, cov_steps = a.runs, 500
        t_state = best(a.repeat, lambda: ne.montecarlo("custom", runs=cov_runs, steps=cov_steps, seed=1,
                                                       threads=a.threads, **files))
        t_cov = best(a.repeat, lambda: ne.montecarlo("covariance", runs=cov_runs, steps=cov_steps, seed=1,
                                                     threads=a.threads, **files))
    rows.append((f"custom (state simulated), kfio n=4, {cov_runs} runs x {cov_steps} steps", cov_runs / t_state,
                 "runs/s"))
    rows.append(("covariance only, the same", cov_runs / t_cov, "runs/s"))
    rows.append(("  speed-up (the issue's target: >= 10)", t_state / t_cov, ""))

    width = max(len(r[0]) for r in rows)
    print(f"bench_python: best of {a.repeat}, numpy {np.__version__}")
    for name, value, unit in rows:
        print(f"  {name:<{width}}  {value:10.3f} {unit}")


if __name__ == "__main__":
    main()
