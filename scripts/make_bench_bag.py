#!/usr/bin/env python3
"""Writes the bag of fit_link's speed benchmark (scripts/bench_fit_link.sh): a base-station recording
of ten topics of a robot, each sent over its own lossy link (a two-state Gilbert chain) and received
a few milliseconds after its stamp. With the default --hours 1 it holds about 1.5 million messages
(417 per second of the ten topics' rates, 1 478 425 with the default seed), 0.94 GB uncompressed.

    scripts/make_bench_bag.py OUT.bag [--hours H] [--compression none|bz2|lz4] [--seed S]

Each message is serialized once per topic and its header's seq and stamp written into the bytes
(rosbag's raw write), so a one-hour bag takes about 80 s to write (a few minutes with bz2). Needs
Debian's python3-rosbag and the message packages (scripts/install_deps.sh).
"""
import argparse
import io
import random
import struct
import sys

import rosbag
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Imu, JointState, LaserScan, NavSatFix, Temperature

# topic, message, rate (Hz), p = P(lost | arrived before), r = P(arrived | lost before)
TOPICS = [
    ("/imu/data", Imu, 200.0, 0.004, 0.5),
    ("/odometry/wheel", Odometry, 50.0, 0.006, 0.4),
    ("/joint_states", JointState, 40.0, 0.006, 0.4),
    ("/scan", LaserScan, 40.0, 0.01, 0.3),
    ("/wheel/odom", Odometry, 25.0, 0.006, 0.4),
    ("/cmd_vel_stamped", TwistStamped, 20.0, 0.005, 0.5),
    ("/camera/camera_info", CameraInfo, 15.0, 0.008, 0.35),
    ("/gps/fix", NavSatFix, 10.0, 0.01, 0.25),
    ("/pose", PoseWithCovarianceStamped, 10.0, 0.005, 0.5),
    ("/temperature", Temperature, 20.0 / 3.0, 0.02, 0.3),
]


def template(cls):
    m = cls()
    if cls is LaserScan:
        m.ranges = [1.0] * 360
        m.intensities = [100.0] * 360
    if cls is JointState:
        m.name = ["front_left", "front_right", "rear_left", "rear_right"]
        m.position = m.velocity = m.effort = [0.0] * 4
    m.header.frame_id = "base_link"
    buf = io.BytesIO()
    m.serialize(buf)
    return bytearray(buf.getvalue()), cls._type, cls._md5sum, cls


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--compression", default="none", choices=["none", "bz2", "lz4"])
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    t0, end = 1700000000.0, a.hours * 3600.0
    # Every topic's next message in time order: (stamp offset, topic index, slot).
    events = []
    for i, (_, _, rate, _, _) in enumerate(TOPICS):
        n = int(round(end * rate))
        events.extend((k / rate, i, k) for k in range(n))
    events.sort()
    # The losses, and the receipts: 2 ms plus an exponential delay of mean 4 ms, in order per topic
    # (a TCP link: a late message holds back the ones behind it).
    lost = [False] * len(TOPICS)
    last = [0.0] * len(TOPICS)
    received = []
    for offset, i, k in events:
        _, _, _, p, r = TOPICS[i]
        lost[i] = (rng.random() >= r) if lost[i] else (rng.random() < p)
        if lost[i]:
            continue
        last[i] = max(last[i], offset + 0.002 + rng.expovariate(1 / 0.004))
        received.append((last[i], offset, i, k))
    received.sort()  # the recorder writes in the order it receives
    templates = [template(cls) for _, cls, _, _, _ in TOPICS]
    with rosbag.Bag(a.out, "w", compression=a.compression) as bag:
        for receipt, offset, i, k in received:
            data, datatype, md5, cls = templates[i]
            stamp = t0 + offset
            secs = int(stamp)
            struct.pack_into("<III", data, 0, k, secs, int(round((stamp - secs) * 1e9)) % 1000000000)
            bag.write(TOPICS[i][0], (datatype, bytes(data), md5, None, cls), rospy.Time.from_sec(t0 + receipt), raw=True)
    written = len(received)
    print("%s: %d messages of %d topics over %.2f h (%s)" % (a.out, written, len(TOPICS), a.hours, a.compression))


if __name__ == "__main__":
    sys.exit(main())
