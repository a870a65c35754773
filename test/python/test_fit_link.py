# fit_link() against the tool, on bags written here by ROS's own Python rosbag (uncompressed, bz2 and
# lz4 chunks): the core's bag reader gives what rosbag wrote, the counts give the fit's numbers.
import json
import random

import pytest

import networked_estimation as ne
from conftest import tool

rosbag = pytest.importorskip("rosbag")
rospy = pytest.importorskip("rospy")
from sensor_msgs.msg import NavSatFix  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

N = 5000


def gilbert_pattern(p, r, n, seed):
    """1 arrived, 0 lost: a two-state chain on the arrivals, p = P(lost | arrived before)."""
    rng = random.Random(seed)
    lost, out = False, []
    for _ in range(n):
        lost = (rng.random() >= r) if lost else (rng.random() < p)
        out.append(0 if lost else 1)
    return out


def write_bag(path, pattern, compression="none", period=0.1, delay=0.02):
    with rosbag.Bag(str(path), "w", compression=compression) as bag:
        for k, arrived in enumerate(pattern):
            if not arrived:
                continue
            m = NavSatFix()
            m.header.seq = k
            m.header.stamp = rospy.Time.from_sec(1000 + k * period)
            bag.write("/gps/fix", m, rospy.Time.from_sec(1000 + k * period + delay + 0.001 * (k % 7)))
        for k in range(10):
            bag.write("/level", Float64(data=k), rospy.Time.from_sec(1000 + k))


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    d = tmp_path_factory.mktemp("bags")
    pattern = gilbert_pattern(0.05, 0.3, N, 3)
    paths = {c: d / f"gps_{c}.bag" for c in ("none", "bz2", "lz4")}
    for c, p in paths.items():
        write_bag(p, pattern, c)
    return pattern, paths


def test_counts_and_maximum_likelihood(bags):
    pattern, paths = bags
    fit = ne.fit_link(bag=paths["none"], topic="/gps/fix")
    first, last = pattern.index(1), len(pattern) - 1 - pattern[::-1].index(1)
    slots = pattern[first:last + 1]
    assert fit["slots_from"] == "header.seq"
    assert fit["expected"] == len(slots) and fit["received"] == sum(pattern)
    # p = n01 / (n00 + n01), r = n10 / (n10 + n11) with 0 arrived, 1 lost: the maximum likelihood.
    pairs = list(zip(slots, slots[1:]))
    n00 = sum(1 for a, b in pairs if a and b)
    n01 = sum(1 for a, b in pairs if a and not b)
    n10 = sum(1 for a, b in pairs if not a and b)
    n11 = sum(1 for a, b in pairs if not a and not b)
    assert fit["gilbert"]["p"]["value"] == n01 / (n00 + n01)
    assert fit["gilbert"]["r"]["value"] == n10 / (n10 + n11)
    assert fit["gilbert"]["p"]["lower"] <= 0.05 <= fit["gilbert"]["p"]["upper"]
    assert fit["gilbert"]["r"]["lower"] <= 0.3 <= fit["gilbert"]["r"]["upper"]
    assert fit["model"] == "gilbert"
    # Delays 20 ms + k mod 7 ms exactly as written.
    assert fit["delay"]["max"] == pytest.approx(0.026, abs=1e-6)
    assert fit["delay"]["min"] == pytest.approx(0.020, abs=1e-6)


def test_compressions_read_alike_and_equal_the_tool(bags):
    _, paths = bags
    fits = {c: ne.fit_link(bag=p, topic="/gps/fix") for c, p in paths.items()}
    for c in ("bz2", "lz4"):
        a, b = dict(fits[c]), dict(fits["none"])
        a.pop("source"), b.pop("source")
        assert a == b, c
    _, out, _ = tool("fit_link", "--bag", paths["lz4"], "--topic", "/gps/fix", "--json")
    assert json.loads(out)["links"][0] == fits["lz4"]


def test_output_is_a_channel_file(bags, tmp_path):
    _, paths = bags
    fit = ne.fit_link(bag=paths["bz2"], topic="/gps/fix", output=tmp_path / "gps.yaml")
    link = ne.Link.from_yaml(tmp_path / "gps.yaml")
    assert link.model == "gilbert_elliott"
    assert (link.p, link.r, link.loss_bad, link.loss_good) == (
        fit["channel"]["p"], fit["channel"]["r"], 1.0, 0.0)
    series = ne.fit_link(bag=paths["none"], topic=["/gps/fix"], series=True)[0]["series"]
    assert len(series["arrived"]) == fit["expected"] and set(series["arrived"]) == {"0", "1"}


def test_refusals(bags, tmp_path):
    _, paths = bags
    with pytest.raises(ValueError, match=r"no topic /imu in the bag \(its topics: /gps/fix, /level\)"):
        ne.fit_link(bag=paths["none"], topic="/imu")
    with pytest.raises(ValueError, match=r"topic /level \(std_msgs/Float64\) has no header stamps"):
        ne.fit_link(bag=paths["none"], topic="/level")
    with pytest.raises(ValueError, match=r"exactly one of bag, csv and events"):
        ne.fit_link(bag=paths["none"], topic="/gps/fix", csv=tmp_path / "x.csv")
    with pytest.raises(ValueError, match=r"contradicts"):
        ne.fit_link(bag=paths["none"], topic="/gps/fix", rate=25)
    short = tmp_path / "short.bag"
    write_bag(short, [1] * 40)
    with pytest.raises(ValueError, match=r"40 messages, fewer than the 50 a fit needs"):
        ne.fit_link(bag=short, topic="/gps/fix")
    code, _, err = tool("fit_link", "--bag", short, "--topic", "/gps/fix", check=False)
    assert code == 2 and "40 messages, fewer than the 50" in err
