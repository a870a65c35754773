#!/usr/bin/env python3
"""Input-to-output latency of an estimator, seen from outside (scripts/bench_robot.sh, bench_peer.sh).

Subscribes to the estimator's inputs (nav_msgs/Odometry on --odom, sensor_msgs/Imu on --imu) and
to its output (--estimate: networked_estimation/Estimate, or nav_msgs/Odometry with --odometry), as
raw messages, and notes the wall time each message is received. For an output stamped t, the
inputs that match it are those with a header stamp within half a period of t; the input that
completed it is the last of them received, and the latency is the output's receipt minus that
input's. With --match all (default) an output some of whose matching inputs arrived after it is
left out (an Estimator's step waits for its inputs: such an input was late for it); with --match
received the input that completed it is the last matching one received before it (an estimator
that publishes on a timer, stamped with its newest input, such as robot_localization's, then
counts every output: an input stamped a little after t that arrives after the output is not in
it). Runs until --seconds have passed since the first input, then prints one line
`estimates=N matched=M median_us=... p90_us=... p99_us=... max_us=...`, and with --odometry
` x=... y=... z=...`, the position of the last output received.
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


def odometry_position(msg):
    """x, y, z of a serialized nav_msgs/Odometry: after the header (seq, stamp, frame_id) and
    child_frame_id, pose.pose.position is the first field."""
    b = msg._buff
    offset = 12
    (n,) = struct.unpack_from("<I", b, offset)
    offset += 4 + n
    (n,) = struct.unpack_from("<I", b, offset)
    offset += 4 + n
    return struct.unpack_from("<ddd", b, offset)


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
    ap.add_argument("--match", choices=("all", "received"), default="all",
                    help="all: every matching input must precede the output; received: the last matching "
                         "input received before it")
    ap.add_argument("--odometry", action="store_true",
                    help="the output is nav_msgs/Odometry: also print the last one's position")
    args = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node("latency_probe", anonymous=True, disable_signals=True)
    lock = threading.Lock()
    last_input = {}  # stamp (ns, rounded to the grid) -> latest wall receipt (s)
    estimates = []   # (stamp ns, wall receipt)
    last_position = []
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
            if args.odometry:
                last_position[:] = odometry_position(msg)

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
                if args.match == "all" or last_input[stamps[i]] <= received:
                    best = max(best or 0.0, last_input[stamps[i]])
                i += 1
            if best is not None and received >= best:
                latencies.append(1e6 * (received - best))
    line = ("estimates=%d matched=%d median_us=%.1f p90_us=%.1f p99_us=%.1f max_us=%.1f" %
            (len(estimates), len(latencies), quantile(latencies, 0.5), quantile(latencies, 0.9),
             quantile(latencies, 0.99), max(latencies) if latencies else 0.0))
    if args.odometry and last_position:
        line += " x=%.4f y=%.4f z=%.4f" % tuple(last_position)
    print(line)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
