# simulate(), analyze(), design() and score() against the tools with the same files and seeds.
import json

import numpy as np
import pytest

import networked_estimation as ne
from conftest import CHANNELS, ESTIMATORS, MODELS, columns, read_csv, same, tool

SIMS = [  # model, the tool's --channel arguments, the same links for simulate(), actuator channel
    ("zhou_example.yaml", ["gilbert_elliott_bursty.yaml"], "gilbert_elliott_bursty.yaml", None),
    ("planar_robot.yaml", ["odom=wifi_bursty.yaml", "gps=bernoulli_0.7.yaml"],
     {"odom": "wifi_bursty.yaml", "gps": "bernoulli_0.7.yaml"}, None),
    ("zhou_actuated.yaml", ["bernoulli_0.2.yaml"], "bernoulli_0.2.yaml", "actuator_q1_0.3_q2_0.4.yaml"),
]


def channel_arg(a):
    return (a.split("=")[0] + "=" + str(CHANNELS / a.split("=")[1])) if "=" in a else str(CHANNELS / a)


@pytest.mark.parametrize("model_file, args, links, actuator", SIMS)
def test_simulate_equals_the_tool(tmp_path, model_file, args, links, actuator):
    cmd = ["--model", MODELS / model_file, "--steps", 250, "--seed", 9, "--out", tmp_path]
    for a in args:
        cmd += ["--channel", channel_arg(a)]
    if actuator:
        cmd += ["--actuator-channel", CHANNELS / actuator]
    _, stdout, _ = tool("simulate", *cmd)
    links = {k: str(CHANNELS / v) for k, v in links.items()} if isinstance(links, dict) else str(CHANNELS / links)
    model = ne.Model.from_yaml(MODELS / model_file)
    sim = ne.simulate(model, links, 250, 9, actuator_link=(CHANNELS / actuator) if actuator else None)

    th, truth = read_csv(tmp_path / "truth.csv")
    ih, inp = read_csv(tmp_path / "input.csv")
    assert same(sim["k"], truth[:, 0]) and same(sim["k"], inp[:, 0])
    assert same(sim["x"], columns(th, truth, "x"))
    assert same(sim["nu"], truth[:, -1])
    assert same(sim["gamma"], inp[:, 1])
    assert same(sim["y"], columns(ih, inp, "y"))
    assert same(sim["u"], columns(ih, inp, "u"))
    shown = stdout.split("links:\n")[1].splitlines()[:len(model.sensors)]
    assert shown == sim["links"]


def test_simulate_refusals():
    m = ne.Model.from_yaml(MODELS / "planar_robot.yaml")
    with pytest.raises(ValueError, match=r"steps: expected at least 1, found 0"):
        ne.simulate(m, None, 0, 1)
    with pytest.raises(ValueError, match=r"loss_output: expected 'noise' or 'empty', found 'zero'"):
        ne.simulate(m, None, 10, 1, loss_output="zero")
    with pytest.raises(ValueError, match=r"'lidar' is not a sensor of the model \(sensors: odom, imu, gps\)"):
        ne.simulate(m, {"lidar": ne.Bernoulli(0.1)}, 10, 1)
    with pytest.raises(ValueError, match="has no control"):
        ne.simulate(m, None, 10, 1, control="constant:1")
    with pytest.raises(TypeError, match=r"links\['gps'\]: expected a Link"):
        ne.simulate(m, {"gps": 0.3}, 10, 1)


def test_simulate_with_link_objects_matches_the_files():
    m = ne.Model.from_yaml(MODELS / "planar_robot.yaml")
    a = ne.simulate(m, {"odom": CHANNELS / "wifi_bursty.yaml", "*": CHANNELS / "bernoulli_0.2.yaml"}, 300, 5)
    b = ne.simulate(m, {"odom": ne.Link.from_yaml(CHANNELS / "wifi_bursty.yaml"),
                        "*": ne.Bernoulli(0.2, seed=1)}, 300, 5)
    assert ne.Link.from_yaml(CHANNELS / "bernoulli_0.2.yaml").seed == 1
    assert same(a["y"], b["y"]) and same(a["gamma"], b["gamma"]) and same(a["x"], b["x"])
    lost = np.isnan(a["y"][:, 0]).mean()
    assert 0.0 < lost < 0.5  # wifi_bursty loses some of odom's samples


ANALYSES = [  # model, the tool's --channel arguments, links for analyze(), estimator settings
    ("zhou_example.yaml", [], None, None),
    ("zhou_example.yaml", ["wifi_bursty.yaml"], "wifi_bursty.yaml", "rseio.yaml"),
    ("planar_robot.yaml", ["wifi_bursty.yaml"], "wifi_bursty.yaml", None),
    ("planar_robot.yaml", ["gps=bernoulli_0.7.yaml", "odom=gilbert_elliott_bursty.yaml"],
     {"gps": "bernoulli_0.7.yaml", "odom": "gilbert_elliott_bursty.yaml"}, None),
    ("unstable_two_links.yaml", ["bernoulli_0.2.yaml"], "bernoulli_0.2.yaml", None),
    ("demo_robot.yaml", ["cellular_congested.yaml"], "cellular_congested.yaml", None),
]


@pytest.mark.parametrize("model_file, args, links, settings", ANALYSES)
def test_analyze_equals_the_tool(model_file, args, links, settings):
    cmd = ["--model", MODELS / model_file, "--json"]
    for a in args:
        cmd += ["--channel", channel_arg(a)]
    if settings:
        cmd += ["--estimator", ESTIMATORS / settings]
    _, stdout, _ = tool("analyze", *cmd)
    if isinstance(links, dict):
        links = {k: str(CHANNELS / v) for k, v in links.items()}
    elif links:
        links = str(CHANNELS / links)
    ours = ne.analyze(ne.Model.from_yaml(MODELS / model_file), links,
                      estimator=str(ESTIMATORS / settings) if settings else None)
    assert ours == json.loads(stdout)


@pytest.mark.parametrize("model_file, args, links, settings", ANALYSES)
def test_verdict_equals_the_tool_and_analyze(model_file, args, links, settings):
    cmd = ["--model", MODELS / model_file, "--verdict-only", "--json"]
    for a in args:
        cmd += ["--channel", channel_arg(a)]
    _, stdout, _ = tool("analyze", *cmd)
    if isinstance(links, dict):
        links = {k: str(CHANNELS / v) for k, v in links.items()}
    elif links:
        links = str(CHANNELS / links)
    model = ne.Model.from_yaml(MODELS / model_file)
    ours = ne.verdict(model, links)
    assert ours == json.loads(stdout)
    full = ne.analyze(model, links)  # the same verdicts and needed rates as the whole report
    assert ours["verdict"]["kind"] == full["all_sensors"]["verdict"]["kind"]
    assert ours["links_verdict"]["kind"] == full["all_sensors"]["links_verdict"]["kind"]
    assert full["all_sensors"]["verdict"]["reason"].startswith(ours["verdict"]["reason"])
    assert [v["margin"] for v in ours["links"]] == [v["margin"] for v in full["links"]]


def test_verdict_names_what_grows_regardless_of_the_links():
    # constant velocity, a velocity sensor only: the position's variance grows whatever the link does
    model = ne.Model(name="cv", A=[[1, 0.1], [0, 1]], Q=np.diag([0.01, 0.1]), states=["x", "vx"],
                     sensors=[ne.Sensor("odom", C=[[0, 1]], R=[[0.01]])])
    v = ne.verdict(model, ne.Bernoulli(0.2))
    assert v["verdict"]["kind"] == "unstable" and v["verdict"]["reason"].startswith("x grows regardless of the links")
    assert v["links_verdict"]["kind"] == "stable" and v["dead_states"] == "x"
    m = v["links"][0]["margin"]
    assert m["converges_at"] is None and m["grows_regardless"] == "x" and m["converges_at_observed"] == 0
    full = ne.analyze(model, ne.Bernoulli(0.2))["all_sensors"]
    assert full["verdict"]["kind"] == "unstable" and full["unbounded_at_every_rate"]
    assert full["observed"]["verdict"]["kind"] == "stable"
    assert not ne.design(model)["design"]["applicable"]


@pytest.mark.parametrize("cost", ["total_rate", "capacity"])
def test_design_equals_the_tool(cost):
    _, stdout, _ = tool("analyze", "--model", MODELS / "unstable_two_links.yaml", "--design", cost, "--json")
    assert ne.design(ne.Model.from_yaml(MODELS / "unstable_two_links.yaml"), cost) == json.loads(stdout)


def test_analyze_with_link_objects_and_refusals():
    m = ne.Model.from_yaml(MODELS / "zhou_example.yaml")
    a = ne.analyze(m, ne.Link.from_yaml(CHANNELS / "wifi_bursty.yaml"), estimator=ESTIMATORS / "rseio.yaml")
    b = ne.analyze(m, str(CHANNELS / "wifi_bursty.yaml"), estimator={"algorithm": "rseio", "mu": 0.8})
    c = ne.analyze(m, {"y": ne.GilbertElliott(0.05, 0.4, loss_good=0.005, seed=1)}, estimator="kfio")
    d = ne.analyze(m, str(CHANNELS / "wifi_bursty.yaml"))
    wifi = str(CHANNELS / "wifi_bursty.yaml")
    assert a["links"][0]["origin"] == ("y: GilbertElliott(p=0.05, r=0.4, loss_good=0.005, loss_bad=1, seed=1, "
                                       "delay=0.008, jitter=0.004) (analyze(): links)")
    assert d["links"][0]["origin"] == f"y: {wifi} (--channel {wifi})"  # a file: the tool's words
    assert c["links"][0]["origin"] == "y: GilbertElliott(p=0.05, r=0.4, loss_good=0.005, loss_bad=1, seed=1) (analyze(): links['y'])"
    for r in (a, b, c, d):
        for link in r["links"]:
            link.pop("origin")
    assert a == b and c == d and a != d  # rseio's verdicts differ from kfio's
    with pytest.raises(ValueError, match=r"at is only for a model with a built-in motion \(model 'zhou_example' is linear\)"):
        ne.analyze(m, at=[0.0, 0.0])
    with pytest.raises(ValueError, match=r"analyze\(\): estimator: 'nope' is neither an algorithm \(kf, kfio, "):
        ne.analyze(m, estimator="nope")
    with pytest.raises(ValueError, match=r"cost: expected 'total_rate' or 'capacity'"):
        ne.design(m, "cheap")
    with pytest.raises(ValueError, match=r"traces\['y'\]\[1\]: expected 0 or 1"):
        ne.analyze(m, traces={"y": [1, 3, 0]})


def test_score_equals_the_tool(tmp_path):
    tool("simulate", "--model", MODELS / "zhou_example.yaml", "--channel", CHANNELS / "bernoulli_0.2.yaml",
         "--steps", 400, "--seed", 3, "--out", tmp_path)
    tool("replay", "--model", MODELS / "zhou_example.yaml", "--settings", ESTIMATORS / "kfio.yaml",
         "--input", tmp_path / "input.csv", "--output", tmp_path / "out.csv")
    _, stdout, _ = tool("score", "--truth", tmp_path / "truth.csv", "--estimate", f"kfio={tmp_path / 'out.csv'}",
                        "--from", 50, "--csv")
    row = stdout.splitlines()[1].split(",")
    m = ne.Model.from_yaml(MODELS / "zhou_example.yaml")
    sim = ne.simulate(m, CHANNELS / "bernoulli_0.2.yaml", 400, 3)
    x, P, _ = ne.make_estimator(m, "kfio").run(sim["y"], sim["gamma"])
    s = ne.score(sim, x, P, from_=50, name="kfio")
    assert [s["name"], str(s["steps"])] == row[:2]
    for key, cell in zip(("arrival_rate", "mse", "mean_trace", "ratio"), row[2:]):
        assert s[key] == float(cell), key  # the tool prints 17 significant digits: exact
    with pytest.raises(ValueError, match=r"score\(\): x: expected shape \(N, n\) with N = 400 and n = 2"):
        ne.score(sim, x[:10], P)


def omni_2d():
    return ne.Model(name="rover", motion="omni_2d", period=0.05, Q=np.diag([1e-4] * 3 + [1e-2] * 3 + [1e-1] * 2),
                    sensors=[ne.Sensor("odom", C=np.eye(3, 8, 3), R=np.eye(3) * 1e-3),
                             ne.Sensor("imu", C=np.eye(1, 8, 2), R=[[1e-2]])],
                    x0=np.zeros(8), P0=np.eye(8))


def test_a_motion_model_from_python(tmp_path):
    m = omni_2d()
    assert m.nonlinear and m.motion == "omni_2d" and m.angles == [2] and m.states[:3] == ["x", "y", "yaw"]
    with pytest.raises(ValueError, match="ekfio"):
        ne.make_estimator(m, "kfio")
    sim = ne.simulate(m, {"odom": ne.Bernoulli(0.3)}, steps=200, seed=3)
    est = ne.make_estimator(m, "ekfio")
    x, P, _ = est.run(sim["y"], sim["gamma"], dt=np.full(200, 0.05))
    again = ne.make_estimator(m, "ekfio")
    x0, P0, _ = again.run(sim["y"], sim["gamma"])  # dt 0: the model's period, the same steps
    assert same(x, x0) and same(P, P0)
    assert np.all(np.abs(x[:, 2]) <= np.pi)  # the heading stays wrapped
    s = ne.score(sim, x, P, model=m)
    assert 0 < s["ratio"] < 3  # a consistent filter: the mean squared error about the mean trace
    # analyze at a state equals `analyze --at` on the same model written to a file
    path = tmp_path / "rover.yaml"
    path.write_text(m.to_yaml())
    at = [0, 0, 0.7, 1.0, 0.2, 0.1, 0, 0]
    _, stdout, _ = tool("analyze", "--model", path, "--at", ",".join(map(str, at)), "--json")
    ours, theirs = ne.analyze(ne.Model.from_yaml(path), at=at), json.loads(stdout)
    assert ours.pop("estimator_note") == theirs.pop("estimator_note").replace("at --at over", "at at over")
    assert ours == theirs
    with pytest.raises(ValueError, match="expected a finite state of 8 values"):
        ne.analyze(m, at=[0.0, 1.0])


def test_a_motion_period_whose_step_is_not_finite_is_refused():
    # one step of the period must be a finite step of the motion (named, not the linearisation's A(i,j) = nan)
    with pytest.raises(ValueError, match=r"period: expected a number of seconds over which one step of omni_2d is "
                                         r"finite, found 1e\+300 \(its Jacobian F has period\^2 / 2 terms: "
                                         r"F\(0,6\) = inf\)"):
        ne.Model(name="rover", motion="omni_2d", period=1e300, Q=np.eye(8),
                 sensors=[ne.Sensor("odom", C=np.eye(3, 8, 3), R=np.eye(3))])
    with pytest.raises(ValueError, match=r"period: expected a number of seconds over which the process noise of a "
                                         r"step, Q period, is finite, found 1e\+09 \(Q\(0,0\) = 1e\+300 per second\)"):
        ne.Model(name="rover", motion="omni_2d", period=1e9, Q=np.eye(8) * 1e300,
                 sensors=[ne.Sensor("odom", C=np.eye(3, 8, 3), R=np.eye(3))])


def test_a_bad_state_to_linearise_at_is_named():
    # `at` names itself and what it holds, in analyze() and design() alike (not "linearisation of model ...")
    m = omni_2d()
    with pytest.raises(ValueError, match=r"^analyze\(\): at: expected a finite state of 8 values \(omni_2d: x, y, "
                                         r"yaw, vx, vy, vyaw, ax, ay\), found 3 \(1, 2, 3\)$"):
        ne.analyze(m, at=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"^design\(\): at: entry 3 \(vx\): expected a finite number, found nan$"):
        ne.design(m, at=[0, 0, 0, np.nan, 0, 0, 0, 0])
    # a finite state whose Jacobian over the period overflows: 1e308 m/s over 10 s
    slow = ne.Model(name="slow", motion="omni_2d", period=10.0, Q=np.eye(8),
                    sensors=[ne.Sensor("odom", C=np.eye(3, 8, 3), R=np.eye(3))])
    with pytest.raises(ValueError, match=r"^analyze\(\): at: the Jacobian of omni_2d there over 10 s is not finite "
                                         r"\(F\(1,2\) = inf\): expected a state of smaller values, found "
                                         r"\[0, 0, 0, 1e\+308, 0, 0, 0, 0\]$"):
        ne.analyze(slow, at=[0, 0, 0, 1e308, 0, 0, 0, 0])
