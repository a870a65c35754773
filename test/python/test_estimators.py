# Estimators from Python: a step loop equals the batch run, run() equals the replay tool bit for bit,
# refusals leave the estimate untouched, clone/reset, divergence, and the GIL released in run().
import re
import threading
import time

import numpy as np
import pytest

import networked_estimation as ne
from conftest import CHANNELS, ESTIMATORS, MODELS, columns, read_csv, same, tool

CASES = [  # model, settings file, channel, actuator channel
    ("zhou_example.yaml", "kfio.yaml", "gilbert_elliott_bursty.yaml", None),
    ("zhou_example.yaml", "rseio.yaml", "bernoulli_0.2.yaml", None),
    ("zhou_example.yaml", "kf.yaml", "bernoulli_0.2.yaml", None),
    ("planar_robot.yaml", "kfio.yaml", "wifi_bursty.yaml", None),
    ("zhou_actuated.yaml", "aoe.yaml", "bernoulli_0.2.yaml", "actuator_q1_0.3_q2_0.4.yaml"),
    ("zhou_actuated.yaml", "oe.yaml", "bernoulli_0.2.yaml", "actuator_q1_0.3_q2_0.4.yaml"),
]


@pytest.mark.parametrize("model_file, settings, channel, actuator", CASES)
def test_run_equals_the_replay_tool(tmp_path, model_file, settings, channel, actuator):
    args = ["--model", MODELS / model_file, "--channel", CHANNELS / channel, "--steps", 300, "--seed", 11,
            "--out", tmp_path]
    if actuator:
        args += ["--actuator-channel", CHANNELS / actuator]
    tool("simulate", *args)
    tool("replay", "--model", MODELS / model_file, "--settings", ESTIMATORS / settings,
         "--input", tmp_path / "input.csv", "--output", tmp_path / "out.csv")
    header, out = read_csv(tmp_path / "out.csv")

    model = ne.Model.from_yaml(MODELS / model_file)
    data = ne.load_replay_input(tmp_path / "input.csv", model)
    est = ne.make_estimator(model, str(ESTIMATORS / settings))
    x, P, trace = est.run(data["Y"], data["gamma"], U=data["U"])
    n = model.n
    assert same(x, columns(header, out, "x"))
    assert same(P.reshape(len(x), n * n), out[:, 2 + n:2 + n + n * n])
    assert same(trace, out[:, -1])


@pytest.mark.parametrize("model_file, settings, channel, actuator", CASES)
def test_step_loop_equals_run(model_file, settings, channel, actuator):
    model = ne.Model.from_yaml(MODELS / model_file)
    sim = ne.simulate(model, CHANNELS / channel, steps=200, seed=4,
                      actuator_link=(CHANNELS / actuator) if actuator else None)
    batch = ne.make_estimator(model, str(ESTIMATORS / settings))
    x, P, trace = batch.run(sim["y"], sim["gamma"], U=sim["u"] if model.p else None)
    single = ne.make_estimator(model, str(ESTIMATORS / settings))
    for k in range(len(x)):
        single.step(sim["y"][k], bool(sim["gamma"][k]), sim["u"][k] if model.p else None)
        assert same(single.x, x[k]) and same(single.P, P[k]), k
    assert single.steps == batch.steps == len(x)


def zhou():
    return ne.Model.from_yaml(MODELS / "zhou_example.yaml")


def test_refused_steps_leave_the_estimate_untouched():
    est = ne.make_estimator(zhou(), "kfio")
    est.step([0.5], True)
    x, P = est.x, est.P
    with pytest.raises(ValueError, match=r"step\(\): y: expected shape \(m,\) = \(1,\), found \(2,\)"):
        est.step([1.0, 2.0], True)
    with pytest.raises(ValueError, match=r"step\(\): R"):
        est.step([1.0], True, R=np.eye(2))
    with pytest.raises(ValueError, match="y"):
        est.step(["a"], True)
    assert same(est.x, x) and same(est.P, P) and est.steps == 1


def test_a_step_covariance_is_checked_before_the_step():
    m = ne.Model.from_yaml(MODELS / "planar_robot.yaml")
    est = ne.make_estimator(m, "kfio")
    y = np.full(m.m, np.nan)
    y[0:2] = [0.1, 0.2]  # odom arrives; imu and gps do not
    R = np.array(m.R)
    R[4, 4] = -1.0  # gps's block: not fused at this step, not checked
    est.step(y, True, R=R)
    x, P = est.x, est.P
    bad = np.array(m.R)
    bad[1, 1] = -1.0
    with pytest.raises(ValueError, match=r"step\(\): R: sensor 'odom': its block is not positive definite"):
        est.step(y, True, R=bad)
    bad = np.array(m.R)
    bad[0, 1] = 1e-4
    with pytest.raises(ValueError, match=r"step\(\): R: sensor 'odom': its block is not symmetric"):
        est.step(y, True, R=bad)
    bad = np.array(m.R)
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match=r"step\(\): R: sensor 'odom': its block is not finite"):
        est.step(y, True, R=bad)
    assert same(est.x, x) and same(est.P, P) and est.steps == 1  # untouched, and it still steps:
    est.step(y, True, R=R)
    Rs = np.tile(m.R, (3, 1, 1))
    Rs[2, 0, 0] = 0.0
    Rs[2, 1, 1] = 0.0
    with pytest.raises(ValueError, match=r"run\(\): step 2: R: sensor 'odom': its block is not positive definite"):
        est.run(np.tile(y, (3, 1)), np.ones(3), R=Rs)


def test_run_refusals_name_the_argument():
    est = ne.make_estimator(zhou(), "kfio")
    with pytest.raises(ValueError, match=r"run\(\): Y: expected shape \(N, m\) with m = 1, found \(5, 2\)"):
        est.run(np.zeros((5, 2)), np.ones(5))
    with pytest.raises(ValueError, match=r"run\(\): Gamma: expected shape \(N,\) with N = 5"):
        est.run(np.zeros((5, 1)), np.ones(4))
    with pytest.raises(ValueError, match=r"run\(\): Gamma\[2\]: expected 0 or 1"):
        est.run(np.zeros((5, 1)), [1, 1, 2, 1, 1])
    Y = np.zeros((5, 1))
    Y[3, 0] = np.inf
    with pytest.raises(ValueError, match=r"run\(\): step 3"):
        est.run(Y, np.ones(5))
    assert est.steps == 3  # the steps before the bad one are kept, as in a step() loop


def test_gamma_is_0_1_or_a_bool_in_step_as_in_run():
    # run() refuses a Gamma other than 0/1/bool; step() takes the same values, not Python's truth value
    est = ne.make_estimator(zhou(), "kfio")
    est.step([0.5], True)
    x, P = est.x, est.P
    for bad, shown in ((2, "2"), (0.5, "0.5"), (-1, "-1"), (float("nan"), "nan"), ("1", "'1'"), (None, "None")):
        with pytest.raises(ValueError, match=r"^step\(\): gamma: expected 0 or 1 \(or a bool\), found "
                                             + re.escape(shown) + "$"):
            est.step([1.0], bad)
    with pytest.raises(ValueError, match=r"^run\(\): Gamma\[1\]: expected 0 or 1"):
        est.run([[1.0], [1.0]], [1, 0.5])
    assert same(est.x, x) and same(est.P, P) and est.steps == 1  # refused before stepping
    # what is taken: bools, numpy's bools and numbers 0 / 1, each the same as True / False
    ref = est.clone()
    ref.step([0.7], True)
    ref.step([0.9], False)
    for yes, no in ((1, 0), (1.0, 0.0), (np.True_, np.False_), (np.int64(1), np.float32(0))):
        twin = est.clone()
        twin.step([0.7], yes)
        twin.step([0.9], no)
        assert same(twin.x, ref.x) and same(twin.P, ref.P), (yes, no)


def test_an_arrived_sample_with_every_value_nan_is_refused():
    # NaN marks a sensor that did not arrive: y all NaN with gamma 1 says "arrived" and "nothing
    # arrived" at once. Refused naming the step; gamma 0 with y all NaN is the usual loss.
    m = ne.Model.from_yaml(MODELS / "planar_robot.yaml")
    est = ne.make_estimator(m, "kfio")
    y = np.full(m.m, np.nan)
    y[0:2] = [0.1, 0.2]  # odom arrives: some sensor's values are numbers
    est.step(y, True)
    x, P = est.x, est.P
    empty = np.full(m.m, np.nan)
    with pytest.raises(ValueError, match=r"^step\(\): step 2: y: every value is NaN .* but gamma is 1"):
        est.step(empty, True)
    with pytest.raises(ValueError, match=r"^step\(\): step 2: y: every value is NaN"):
        est.step(empty, 1)
    assert same(est.x, x) and same(est.P, P) and est.steps == 1
    est.step(empty, False)  # a loss: a prediction
    assert est.steps == 2 and not est.last_updated
    Y = np.tile(y, (4, 1))
    Y[2] = np.nan
    with pytest.raises(ValueError, match=r"^run\(\): step 2: Y\[2\]: every value is NaN .* but Gamma\[2\] is 1"):
        est.run(Y, np.ones(4))
    assert est.steps == 4  # the rows before the bad one are kept, as in a step() loop
    x, P, trace = est.run(Y, [1, 1, 0, 1])  # the same row as a loss
    assert np.isfinite(trace).all() and est.steps == 8
    for algorithm, settings in (("kf", {}), ("rseio", {"mu": 0.8})):  # kf too (it would have only predicted)
        with pytest.raises(ValueError, match=r"^run\(\): step 0: Y\[0\]: every value is NaN"):
            ne.make_estimator(m, algorithm, **settings).run(np.full((1, m.m), np.nan), [True])


def test_settings_refusals():
    m = zhou()
    with pytest.raises(ValueError, match="kfi0"):
        ne.make_estimator(m, "kfi0")
    with pytest.raises(ValueError, match="mu"):
        ne.make_estimator(m, "rseio", mu=2.0)
    with pytest.raises(ValueError, match="bogus"):
        ne.make_estimator(m, "kfio", bogus=1)
    with pytest.raises(ValueError, match="give no keywords"):
        ne.make_estimator(m, str(ESTIMATORS / "rseio.yaml"), mu=0.5)
    with pytest.raises(ValueError, match=r"^make_estimator\(\): .*control_link"):
        ne.make_estimator(ne.Model.from_yaml(MODELS / "zhou_actuated.yaml"), "aoe")


def test_clone_and_reset():
    est = ne.make_estimator(zhou(), "rseio", mu=0.8)
    est.step([1.0], True)
    twin = est.clone()
    twin.step([2.0], True)
    assert est.steps == 1 and twin.steps == 2
    est.step([2.0], True)
    assert same(est.x, twin.x) and same(est.P, twin.P)
    est.reset()
    assert est.steps == 0 and same(est.x, zhou().x0)


def test_divergence_is_its_own_error():
    m = ne.Model(A=[[1e40]], Q=[[1.0]], sensors=[ne.Sensor("y", C=[[1.0]], R=[[1.0]])], x0=[0.0], P0=[[1.0]])
    est = ne.make_estimator(m, "kfio")
    with pytest.raises(ne.DivergenceError, match=r"kfio diverged at step"):
        est.run(np.zeros((50, 1)), np.zeros(50))
    assert issubclass(ne.DivergenceError, RuntimeError)


def longest_pause_while(work):
    """Runs work() in a thread; returns (its seconds, the longest gap between two iterations of a
    Python loop in this thread meanwhile). A call holding the GIL stops this loop for its whole length."""
    started, done = threading.Event(), threading.Event()

    def worker():
        started.set()
        work()
        done.set()

    t = threading.Thread(target=worker)
    t.start()
    started.wait()
    t0 = last = time.perf_counter()
    gap = 0.0
    while not done.is_set():
        now = time.perf_counter()
        gap = max(gap, now - last)
        last = now
    t.join()
    return time.perf_counter() - t0, gap


def test_run_releases_the_gil():
    m = ne.Model.from_yaml(MODELS / "zhou_actuated.yaml")
    sim = ne.simulate(m, CHANNELS / "bernoulli_0.2.yaml", steps=400, seed=2,
                      actuator_link=CHANNELS / "actuator_q1_0.3_q2_0.4.yaml")
    reps = 1
    while True:  # enough oe steps (a mixture of 512 components: slow) for a run of about 1 s or more
        est = ne.make_estimator(m, "oe", control_link={"recovery": 0.3, "failure": 0.4}, max_components=512)
        Y, G, U = (np.tile(a, (reps, 1)) if a.ndim == 2 else np.tile(a, reps) for a in (sim["y"], sim["gamma"], sim["u"]))
        seconds, gap = longest_pause_while(lambda: est.run(Y, G, U=U))
        if seconds > 1.0 or reps > 256:
            break
        reps *= 2
    assert seconds > 0.6, "the run is too short to tell"
    # Holding the GIL would pause this thread for the whole run; released, only the interpreter's
    # switch interval (5 ms) and the OS scheduler's slices (tens of ms on a busy 2-core machine)
    # separate two iterations: a third of a run of 1 s is far from both.
    assert gap < seconds / 3, (gap, seconds)
