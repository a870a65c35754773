# Model, Sensor and Link: the same checks and messages as the files, round trips, pickling.
import gc
import pickle

import numpy as np
import pytest

import networked_estimation as ne
from conftest import CHANNELS, MODELS


def small_model(**changes):
    keys = dict(name="two", A=np.array([[1.0, 0.1], [0.0, 1.0]]), Q=np.eye(2) * 0.01,
                sensors=[ne.Sensor("pos", C=[[1.0, 0.0]], R=[[0.04]])], x0=[0.0, 0.0], P0=np.eye(2))
    keys.update(changes)
    return ne.Model(**keys)


def test_model_from_keys_equals_the_file():
    text = (MODELS / "zhou_example.yaml").read_text()
    from_file = ne.Model.from_yaml(MODELS / "zhou_example.yaml")
    import yaml  # Debian's python3-yaml, which ROS needs anyway
    keys = yaml.safe_load(text)
    from_keys = ne.Model(**keys)
    for name in ("A", "B", "Q", "C", "R", "x0", "P0"):
        assert np.array_equal(getattr(from_file, name), getattr(from_keys, name)), name
    assert from_keys.n == 2 and from_keys.m == 1 and from_keys.sensors == from_file.sensors


def test_model_numbers_are_read_exactly():
    v = 0.1 + 0.2  # 0.30000000000000004: needs all 17 digits
    m = small_model(Q=np.eye(2) * v)
    assert m.Q[0, 0] == v


def test_model_to_yaml_reads_back():
    m = ne.Model.from_yaml(MODELS / "planar_robot.yaml")
    import yaml
    again = ne.Model(**yaml.safe_load(m.to_yaml()))
    for name in ("A", "Q", "C", "R", "x0", "P0"):
        assert np.array_equal(getattr(m, name), getattr(again, name)), name
    assert again.angles == m.angles and again.states == m.states


@pytest.mark.parametrize("path", sorted(MODELS.glob("*.yaml")), ids=lambda p: p.name)
def test_every_example_model_pickles_exactly(path):
    m = ne.Model.from_yaml(path)
    again = pickle.loads(pickle.dumps(m))
    for name in ("A", "B", "Q", "C", "R", "Bu", "x0", "P0"):
        assert np.array_equal(getattr(m, name), getattr(again, name)), name
    assert (again.name, again.period, again.sensors, again.angles) == (m.name, m.period, m.sensors, m.angles)
    sim, sim2 = ne.simulate(m, None, 50, 3), ne.simulate(again, None, 50, 3)  # uncertainty, schedule too
    assert np.array_equal(sim["y"], sim2["y"], equal_nan=True) and np.array_equal(sim["x"], sim2["x"])


@pytest.mark.parametrize("changes, words", [
    (dict(Q=np.eye(3)), ["Q", "3"]),                                  # wrong size
    (dict(Q=-np.eye(2)), ["Q", "positive"]),                          # not positive definite
    (dict(A=[[1.0, float("nan")], [0.0, 1.0]]), ["A"]),               # not finite
    (dict(sensors=[ne.Sensor("pos", C=[[1.0]], R=[[1.0]])]), ["C"]),  # C of the wrong width
    (dict(bogus=1), ["bogus"]),                                       # unknown key
])
def test_model_refusals_name_the_key(changes, words):
    with pytest.raises(ValueError) as e:
        small_model(**changes)
    assert str(e.value).startswith("Model()"), str(e.value)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_model_refuses_a_value_it_cannot_read():
    with pytest.raises(TypeError, match=r"Model\(\): A: expected a number.*found object"):
        small_model(A=object())
    with pytest.raises(TypeError, match=r"Model\(\): sensors\[0\]\.C\[1\]: expected"):
        small_model(sensors=[ne.Sensor("pos", C=[[1.0, 0.0], object()], R=[[1.0]])])


def test_model_from_missing_file_names_it():
    with pytest.raises(ValueError, match="no_such_model.yaml"):
        ne.Model.from_yaml("no_such_model.yaml")


def test_links_and_their_refusals():
    b = ne.Bernoulli(0.2, seed=5)
    assert (b.model, b.loss, b.seed) == ("bernoulli", 0.2, 5)
    assert ne.Bernoulli(p=0.3).loss == ne.Bernoulli(loss=0.3).loss == 0.3
    with pytest.raises(ValueError, match="once"):
        ne.Bernoulli(0.3, loss=0.3)
    with pytest.raises(ValueError, match="needs loss"):
        ne.Bernoulli()
    g = ne.GilbertElliott(0.05, 0.4, loss_good=0.005)
    assert (g.model, g.p, g.r, g.loss_good, g.loss_bad) == ("gilbert_elliott", 0.05, 0.4, 0.005, 1.0)
    f = ne.Link.from_yaml(CHANNELS / "wifi_bursty.yaml")
    assert f.model == "gilbert_elliott" and f.delay > 0
    with pytest.raises(ValueError, match="loss"):
        ne.Bernoulli(1.5)
    with pytest.raises(ValueError, match="'loss' applies only to model bernoulli"):
        ne.GilbertElliott(0.1, 0.5, loss=0.2)
    with pytest.raises(ValueError, match="model"):
        ne.Link(model="markov")


def test_links_pickle_and_print():
    g = ne.GilbertElliott(0.05, 0.4, loss_good=0.005, seed=3)
    again = pickle.loads(pickle.dumps(g))
    assert (again.p, again.r, again.loss_good, again.loss_bad, again.seed) == (0.05, 0.4, 0.005, 1.0, 3)
    assert repr(g) == "GilbertElliott(p=0.05, r=0.4, loss_good=0.005, loss_bad=1, seed=3)"
    assert "gilbert_elliott" in g.to_yaml()


def test_estimator_outlives_its_model():
    m = small_model()
    est = ne.make_estimator(m, "kfio")
    del m
    gc.collect()
    est.step([1.0], True)
    assert est.steps == 1 and est.model.name == "two"
