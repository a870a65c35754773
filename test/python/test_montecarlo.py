# montecarlo() against the tool (the CSV byte for byte, the JSON but for threads and wall time),
# shards and merge, the progress callback, refusals, and the GIL released meanwhile.
import json
import pickle

import numpy as np
import pytest

import networked_estimation as ne
from conftest import CHANNELS, ESTIMATORS, MODELS, same, tool
from test_estimators import longest_pause_while


def untimed(text):
    d = json.loads(text)
    d.pop("threads")
    d.pop("wall_seconds")
    return d


def test_zhou_fig1_equals_the_tool(tmp_path):
    tool("montecarlo", "--experiment", "zhou_fig1", "--runs", 200, "--steps", 60, "--seed", 4, "--threads", 2,
         "--out", tmp_path)
    calls = []
    r = ne.montecarlo("zhou_fig1", runs=200, steps=60, seed=4, threads=1, progress=lambda d, t: calls.append((d, t)))
    assert r.csv() == (tmp_path / "zhou_fig1.csv").read_text()
    assert untimed(r.json()) == untimed((tmp_path / "zhou_fig1.json").read_text())
    # the arrays are the CSV's numbers (printed with 10 digits)
    case = r.cases[0]
    series = next(iter(case["series"].values()))
    assert len(case["x"]) == len(series["mean"]) == len(series["sd"]) and series["n"] == 200
    assert r.case(case["name"])["title"] == case["title"]
    with pytest.raises(KeyError, match="is not a case"):
        r.case("nope")
    # progress: every block reported once, in order, up to the total
    assert calls and calls[-1][0] == calls[-1][1] and [d for d, _ in calls] == sorted(d for d, _ in calls)
    r.write(tmp_path / "again")
    assert (tmp_path / "again" / "zhou_fig1.csv").read_text() == r.csv()


def test_custom_equals_the_tool(tmp_path):
    files = dict(model=MODELS / "planar_robot.yaml", channels={"odom": CHANNELS / "wifi_bursty.yaml"},
                 settings=[ESTIMATORS / "kfio.yaml", ESTIMATORS / "kf.yaml"])
    tool("montecarlo", "--experiment", "custom", "--runs", 70, "--steps", 40, "--out", tmp_path,
         "--model", files["model"], "--channel", f"odom={files['channels']['odom']}",
         "--settings", ",".join(map(str, files["settings"])))
    r = ne.montecarlo("custom", runs=70, steps=40, **files)
    assert r.csv() == (tmp_path / "custom.csv").read_text()


def test_covariance_only_equals_the_tool(tmp_path):
    # the tool's custom --covariance-only and montecarlo(custom, covariance_only=True) both run the
    # experiment covariance: tr P per step of kfio and rseio, no plant
    files = dict(model=MODELS / "scheduled_example.yaml", channels={"s1": CHANNELS / "bernoulli_0.2.yaml"},
                 settings=[ESTIMATORS / "kfio.yaml", ESTIMATORS / "rseio.yaml"])
    tool("montecarlo", "--experiment", "custom", "--covariance-only", "--runs", 90, "--steps", 400, "--out", tmp_path,
         "--model", files["model"], "--channel", f"s1={files['channels']['s1']}",
         "--settings", ",".join(map(str, files["settings"])))
    r = ne.montecarlo("custom", runs=90, steps=400, covariance_only=True, **files)
    assert r.experiment == "covariance"
    assert r.csv() == (tmp_path / "covariance.csv").read_text()
    assert ne.montecarlo("covariance", runs=90, steps=400, **files).csv() == r.csv()
    series = r.cases[0]["series"]
    assert list(series) == ["kfio", "rseio"] and len(series["kfio"]["mean"]) == 400
    with pytest.raises(ValueError, match="covariance_only is only for the experiments custom, covariance and sweep"):
        ne.montecarlo("zhou_fig1", covariance_only=True)
    with pytest.raises(ValueError, match="estimator 'aoe'"):
        ne.montecarlo("covariance", runs=2, steps=2, model=files["model"], settings=[ESTIMATORS / "aoe.yaml"])


def test_objects_equal_the_files_they_stand_for(tmp_path):
    # a Model, Link objects, an algorithm name and a dict of settings give the numbers of the files
    # they stand for; the shards carry their text and merge; another object is a foreign shard
    files = dict(model=MODELS / "tracking_2d.yaml",
                 channels={"gnss": CHANNELS / "gilbert_elliott_bursty.yaml", "camera": CHANNELS / "bernoulli_0.2.yaml"},
                 settings=[ESTIMATORS / "kfio.yaml", ESTIMATORS / "rseio.yaml"])
    model = ne.Model.from_yaml(files["model"])
    objects = dict(model=model,
                   channels={"gnss": ne.GilbertElliott(p=0.05, r=0.4, seed=1), "camera": ne.Bernoulli(0.2, seed=1)},
                   settings=["kfio", {"algorithm": "rseio", "mu": 0.8}])
    for experiment in ("custom", "covariance"):
        a = ne.montecarlo(experiment, runs=70, steps=30, **files)
        b = ne.montecarlo(experiment, runs=70, steps=30, **objects)
        sa, sb = a.cases[0]["series"], b.cases[0]["series"]
        assert list(sa) == list(sb) == ["kfio", "rseio"]
        for name in sa:
            for key in ("mean", "sd", "median", "p95"):
                assert same(sa[name][key], sb[name][key]), (experiment, name, key)
    named = ne.montecarlo("custom", runs=10, steps=5, model=model, settings=[{"algorithm": "rseio", "mu": 0.9,
                                                                              "name": "robust"}, "rseio"])
    assert list(named.cases[0]["series"]) == ["robust", "rseio"]
    # shards of objects: merged = unsharded, also after pickling; the model's text is checked
    whole = ne.montecarlo("custom", runs=200, steps=20, **objects)
    shards = [pickle.loads(pickle.dumps(ne.montecarlo("custom", runs=200, steps=20, shard=(k, 2), **objects)))
              for k in (1, 2)]
    assert ne.merge(shards).csv() == whole.csv()
    other = ne.Model(name=model.name, period=model.period, A=model.A, B=model.B, Q=2 * model.Q,
                     sensors=[ne.Sensor(n, C=model.C[o:o + r], R=model.R[o:o + r, o:o + r]) for n, o, r in model.sensors])
    foreign = ne.montecarlo("custom", runs=200, steps=20, shard=(2, 2), **dict(objects, model=other))
    with pytest.raises(ValueError, match="foreign shard: fingerprint"):
        ne.merge([shards[0], foreign])
    # analyze, verdict and design take a model file as well as a Model
    assert ne.design(files["model"]) == ne.design(model)
    assert ne.verdict(str(files["model"])) == ne.verdict(model)
    with pytest.raises(TypeError, match=r"design\(\): model: expected a Model or a model file, found int"):
        ne.design(3)
    with pytest.raises(ValueError, match="settings: algorithm: unknown algorithm 'kalman'"):
        ne.montecarlo("custom", runs=2, steps=2, model=model, settings=[{"algorithm": "kalman"}])
    with pytest.raises(TypeError, match="a list holds the tool's --channel arguments"):
        ne.montecarlo("custom", runs=2, steps=2, model=model, settings="kfio", channels=[ne.Bernoulli(0.2)])


def test_shards_merge_to_the_unsharded_run(tmp_path):
    whole = ne.montecarlo("zhou_fig2", runs=300, steps=30, seed=2)
    shards = [ne.montecarlo("zhou_fig2", runs=300, steps=30, seed=2, shard=(k, 3)) for k in (1, 2, 3)]
    assert [s.index for s in shards] == [1, 2, 3] and shards[0].count == 3
    merged = ne.merge(reversed([pickle.loads(pickle.dumps(s)) for s in shards]))
    assert merged.csv() == whole.csv()
    assert untimed(merged.json()) == untimed(whole.json())
    assert np.array_equal(merged.samples[whole.cases[0]["name"]], whole.samples[whole.cases[0]["name"]])
    paths = [s.write(tmp_path) for s in shards]
    assert ne.merge(paths).csv() == whole.csv()
    with pytest.raises(ValueError, match="shard"):
        ne.merge(paths[:2])


def test_montecarlo_refusals():
    with pytest.raises(ValueError, match=r"^montecarlo\(\): experiment: unknown experiment 'zhou_fig9'"):
        ne.montecarlo("zhou_fig9")
    with pytest.raises(TypeError, match=r"montecarlo\(\): channels: expected a Link \(Bernoulli, GilbertElliott, "
                                        r"Link\) or a channel file, found int"):
        ne.montecarlo("custom", model=MODELS / "zhou_example.yaml", settings=ESTIMATORS / "kfio.yaml", channels=3)
    one = ne.montecarlo("zhou_fig1", runs=128, steps=5, shard=(1, 2))
    with pytest.raises(ValueError, match=r"missing shard 2 of 2 of zhou_fig1 \(found 1\)$"):
        ne.merge([one])
    with pytest.raises(ValueError, match=r"duplicate shard 1 of 2: <Shard 1 of 2 of zhou_fig1> and "
                                         r"<Shard 1 of 2 of zhou_fig1>"):
        ne.merge([one, pickle.loads(pickle.dumps(one))])
    with pytest.raises(ValueError, match=r"needs model= and settings="):
        ne.montecarlo("custom", runs=10)
    with pytest.raises(ValueError, match=r"model is only for the experiments custom, covariance and sweep"):
        ne.montecarlo("zhou_fig1", model=MODELS / "zhou_example.yaml")
    with pytest.raises(ValueError, match=r"shard: expected \(k, n\) with 1 <= k <= n"):
        ne.montecarlo("zhou_fig1", runs=10, shard=(0, 3))
    with pytest.raises(ValueError, match="found none"):
        ne.merge([])
    with pytest.raises(ZeroDivisionError):  # the callback's own error comes back, after the run
        ne.montecarlo("zhou_fig1", runs=64, steps=10, progress=lambda d, t: 1 / 0)


def test_montecarlo_releases_the_gil():
    runs = 256
    while True:
        seconds, gap = longest_pause_while(lambda: ne.montecarlo("zhou_fig1", runs=runs, steps=200, threads=1))
        if seconds > 1.0 or runs > 400000:
            break
        runs *= 2
    assert seconds > 0.6, "the run is too short to tell"
    assert gap < seconds / 3, (gap, seconds)


def test_sweep_equals_the_tool_and_its_arrays_are_the_csv(tmp_path):
    files = dict(model=MODELS / "unstable_two_links.yaml", channels={"camera": CHANNELS / "gilbert_elliott_bursty.yaml"},
                 settings=[ESTIMATORS / "kfio.yaml", ESTIMATORS / "kf.yaml"],
                 axes=["gnss.arrival_rate=0.2:0.8:3", "camera.recovery_rate=0.1:0.7:4"])
    tool("montecarlo", "--experiment", "sweep", "--model", files["model"],
         "--channel", f"camera={files['channels']['camera']}", "--settings", ",".join(map(str, files["settings"])),
         "--axis", files["axes"][0], "--axis", files["axes"][1], "--runs", 70, "--steps", 20, "--out", tmp_path)
    r = ne.montecarlo("sweep", runs=70, steps=20, **files)
    text = (tmp_path / "sweep.csv").read_text()
    assert r.csv() == text
    sw = r.sweep
    assert sw["axes"] == ["gnss.arrival_rate", "camera.recovery_rate"] and sw["values"].shape == (12, 2)
    header = text.splitlines()[0].split(",")
    col = {h: i for i, h in enumerate(header)}
    rows = [line.split(",") for line in text.splitlines()[1:]]
    for row in rows:
        point, name = int(row[0]), row[5]
        cells = sw["estimators"][name]
        assert [float(row[3]), float(row[4])] == list(sw["values"][point])
        assert int(row[6]) == cells["n"][point] and row[col["verdict"]] == sw["verdicts"][point]
        assert float(row[9]) == pytest.approx(cells["trP_mean"][point], rel=1e-9)  # the CSV prints 10 digits
        for key in ("trP_median", "trP_p95", "growth"):
            assert float(row[col[key]]) == pytest.approx(cells[key][point], rel=1e-9)
    assert ne.montecarlo("zhou_fig1", runs=64, steps=5).sweep is None


def test_sweep_over_any_parameter_with_objects(tmp_path):
    # a Model, a Link and a named settings dict swept over the model's a and the estimator's mu: the
    # numbers of the tool on the files they stand for, and shards of it merge to the whole
    model = ne.Model.from_yaml(MODELS / "zhou_example.yaml")
    objects = dict(model=model, channels=ne.Bernoulli(0.2, seed=1),
                   settings=["kfio", {"algorithm": "rseio", "mu": 0.8, "name": "robust"}],
                   axes=["model.A[0][0]=0.9:1.1:3", "robust.mu=0.5:1:2"])
    (tmp_path / "robust.yaml").write_text("algorithm: rseio\nmu: 0.8\n")
    tool("montecarlo", "--experiment", "sweep", "--model", MODELS / "zhou_example.yaml",
         "--channel", CHANNELS / "bernoulli_0.2.yaml", "--settings", f"kfio,{tmp_path / 'robust.yaml'}",
         "--axis", objects["axes"][0], "--axis", objects["axes"][1], "--runs", 70, "--steps", 20,
         "--out", tmp_path / "tool")
    r = ne.montecarlo("sweep", runs=70, steps=20, **objects)
    assert r.csv() == (tmp_path / "tool" / "sweep.csv").read_text()
    sw = r.sweep
    assert sw["axes"] == ["model.A[0][0]", "robust.mu"] and sw["values"].shape == (6, 2)
    # mu matters for rseio on this uncertain plant, not for kfio
    kfio, robust = sw["estimators"]["kfio"]["trP_mean"], sw["estimators"]["robust"]["trP_mean"]
    assert kfio[0] == kfio[1] and robust[0] != robust[1]
    shards = [pickle.loads(pickle.dumps(ne.montecarlo("sweep", runs=130, steps=20, shard=(k, 2), **objects)))
              for k in (1, 2)]
    assert ne.merge(shards).csv() == ne.montecarlo("sweep", runs=130, steps=20, **objects).csv()
    with pytest.raises(ValueError, match=r"--axis 'kfio.mu=0.5:1:2': mu is rseio's; estimator 'kfio' is kfio"):
        ne.montecarlo("sweep", runs=2, steps=2, **dict(objects, axes=["kfio.mu=0.5:1:2"]))
