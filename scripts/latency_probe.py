#!/usr/bin/env python3
"""Input-to-output latency of an Estimator, seen from outside (scripts/bench_robot.sh).

Subscribes to the Estimator's inputs (nav_msgs/Odometry on --odom, sensor_msgs/Imu on --imu) and
to its output (networked_estimation/Estimate on --estimate), as raw messages, and notes the wall time each message
is received. For the estimate of a step (stamp t), the input that completed it is the last one
received with a header stamp within half a period of t; the latency is the estimate's receipt
minus that input's. Runs until --seconds have passed since the first input, then prints one
line `estimates=N matched=M median_us=... p90_us=... p99_us=... max_us=...`.
"""
import argparse
import bisect
import struct
import sys
import threading
import time

import rospy

# Every message read here starts with a std_msgs/Header (uint32 seq, time stamp): the probe reads
# the stamp from the serialized bytes (rospy.AnyMsg), so it needs no Python message packages.


def stamp_ns(msg):
    _, sec, nsec = struct.unpack_from("<III", msg._buff, 0)
    return sec * 1000000000 + nsec


def quantile(values, q):
    if not values:
        return 0.0
    s = sorted(values)
    k = max(0, min(len(s) - 1, int(q * len(s) + 0.999999) - 1))
    return s[k]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--odom", default="/odom")
    ap.add_argument("--imu", default="/imu/data")
    ap.add_argument("--estimate", default="estimate")
    ap.add_argument("--period", type=float, required=True, help="the model's period (s)")
    ap.add_argument("--seconds", type=float, required=True, help="wall seconds to listen after the first input")
    args = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node("latency_probe", anonymous=True, disable_signals=True)
    lock = threading.Lock()
    last_input = {}  # stamp (ns, rounded to the grid) -> latest wall receipt (s)
    estimates = []   # (stamp ns, wall receipt)
    first = []

    def on_input(msg):
        now = time.monotonic()
        with lock:
            if not first:
                first.append(now)
            key = stamp_ns(msg)
            last_input[key] = max(last_input.get(key, 0.0), now)

    def on_estimate(msg):
        now = time.monotonic()
        with lock:
            estimates.append((stamp_ns(msg), now))

    subs = [rospy.Subscriber(args.odom, rospy.AnyMsg, on_input, queue_size=10000, tcp_nodelay=True),
            rospy.Subscriber(args.imu, rospy.AnyMsg, on_input, queue_size=10000, tcp_nodelay=True),
            rospy.Subscriber(args.estimate, rospy.AnyMsg, on_estimate, queue_size=10000, tcp_nodelay=True)]
    give_up = time.monotonic() + 120.0
    while time.monotonic() < give_up:
        with lock:
            if first and time.monotonic() > first[0] + args.seconds:
                break
        time.sleep(0.05)
    for s in subs:
        s.unregister()
    half = int(0.5 * args.period * 1e9)
    with lock:
        stamps = sorted(last_input)
        latencies = []
        for stamp, received in estimates:
            i = bisect.bisect_left(stamps, stamp - half)
            best = None
            while i < len(stamps) and stamps[i] <= stamp + half:
                best = max(best or 0.0, last_input[stamps[i]])
                i += 1
            if best is not None and received >= best:
                latencies.append(1e6 * (received - best))
    print("estimates=%d matched=%d median_us=%.1f p90_us=%.1f p99_us=%.1f max_us=%.1f" %
          (len(estimates), len(latencies), quantile(latencies, 0.5), quantile(latencies, 0.9),
           quantile(latencies, 0.99), max(latencies) if latencies else 0.0))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
