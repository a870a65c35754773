#!/usr/bin/env python3
"""The ROS command-line tools on the Estimator's graph (cmdline_tools.test), run as a user runs
them, as subprocesses: rostopic echo of odometry/filtered, /diagnostics, /tf and an input topic,
rostopic hz, rosservice call set_pose, dynparam get and set. Each check reads the tool's output, not
only its exit code. This process imports no message module itself: every message type is loaded by
the tools, from the Python message packages the machine has (Debian: python3-nav-msgs, ...)."""
import argparse
import ast
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import yaml

ARGS = None
# A tool that gets no message waits forever: each one-shot call has this long (seconds of wall
# time) to answer. Only a hang or a graph that never starts can take it, never a normal run.
TOOL_TIMEOUT = 30.0


def tool_env():
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"  # the background echo's output reaches its file at once
    return env


def run_tool(*cmd):
    """Runs one command-line tool to its end; returns (exit code, stdout, stderr)."""
    try:
        p = subprocess.run(list(cmd), stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                           timeout=TOOL_TIMEOUT, env=tool_env())
    except subprocess.TimeoutExpired as e:
        raise AssertionError("%s did not finish within %.0f s; its output: %s %s"
                             % (" ".join(cmd), TOOL_TIMEOUT, e.stdout, e.stderr))
    return p.returncode, p.stdout, p.stderr


class Background:
    """A tool that runs until interrupted (rostopic hz, rostopic echo without -n), its output in a file
    that the tool appends to (O_APPEND: reading it meanwhile never moves where the tool writes)."""

    def __init__(self, *cmd):
        self.cmd = list(cmd)
        self.dir = tempfile.TemporaryDirectory()
        with open(os.path.join(self.dir.name, "stdout"), "a") as out, \
                open(os.path.join(self.dir.name, "stderr"), "a") as err:
            self.proc = subprocess.Popen(self.cmd, stdout=out, stderr=err, env=tool_env())

    def output(self, name="stdout"):
        with open(os.path.join(self.dir.name, name)) as f:
            return f.read()

    def stop(self):
        """Ctrl-C, as a user stops it; returns (exit code, stdout, stderr)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=TOOL_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        result = self.proc.returncode, self.output(), self.output("stderr")
        self.dir.cleanup()
        return result


def echo_documents(text):
    """The messages of `rostopic echo` output: YAML documents separated by '---' lines; a last one cut
    short by the interrupt is left out."""
    return [yaml.safe_load(part) for part in text.split("\n---\n")[:-1] if part.strip()]


def last_document(text):
    """The last complete message of `rostopic echo` output, or None."""
    parts = text.split("\n---\n")
    return yaml.safe_load(parts[-2]) if len(parts) >= 2 else None


def stamp(msg):
    return msg["header"]["stamp"]["secs"] + 1e-9 * msg["header"]["stamp"]["nsecs"]


def yaw_of(q):
    return math.atan2(2.0 * (q["w"] * q["z"] + q["x"] * q["y"]), 1.0 - 2.0 * (q["y"] ** 2 + q["z"] ** 2))


def angle_diff(a, b):
    return math.atan2(math.sin(a - b), math.cos(a - b))


class CommandLineTools(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with open(ARGS.model) as f:
            cls.model = yaml.safe_load(f)
        with open(ARGS.params) as f:
            cls.params = yaml.safe_load(f)
        cls.ns = ARGS.namespace.rstrip("/")
        cls.odometry = cls.ns + "/odometry/filtered"
        cls.node = cls.ns + "/estimator"

    def echo_one(self, topic):
        code, out, err = run_tool("rostopic", "echo", "-n", "1", topic)
        self.assertEqual(code, 0, "rostopic echo -n 1 %s failed (exit %d): %s" % (topic, code, err))
        docs = echo_documents(out)
        self.assertEqual(len(docs), 1, "rostopic echo -n 1 %s printed %d messages: %s%s" % (topic, len(docs), out, err))
        return docs[0]

    def test_echo_odometry_filtered(self):
        msg = self.echo_one(self.odometry)
        self.assertEqual(msg["header"]["frame_id"], self.params["world_frame"])
        self.assertEqual(msg["child_frame_id"], self.params["base_link_frame"])
        self.assertGreater(stamp(msg), 0.0)
        cov = msg["pose"]["covariance"]
        self.assertEqual(len(cov), 36)
        # The pose's x, y and yaw are estimated (a variance below the 1e6 of "not estimated"),
        # roll and pitch are not.
        for i in (0, 7, 35):
            self.assertTrue(0.0 < cov[i] < 1e6, "pose variance %d: %r" % (i, cov[i]))
        self.assertEqual(cov[21], 1e6)
        self.assertEqual(cov[28], 1e6)
        for v in msg["twist"]["twist"]["linear"].values():
            self.assertTrue(math.isfinite(v))

    def test_echo_diagnostics(self):
        msg = self.echo_one("/diagnostics")
        prefix = self.node.lstrip("/") + ": "
        statuses = {s["name"]: s for s in msg["status"]}
        self.assertIn(prefix + "estimator", statuses, "statuses: %s" % sorted(statuses))
        self.assertIn(prefix + "link stability", statuses, "statuses: %s" % sorted(statuses))
        est = statuses[prefix + "estimator"]
        self.assertEqual(est["hardware_id"], self.params["algorithm"])
        values = {kv["key"]: kv["value"] for kv in est["values"]}
        self.assertEqual(values.get("algorithm"), self.params["algorithm"])
        self.assertIn("odom messages", values)
        self.assertIn("imu messages", values)

    def test_echo_link_status(self):
        # ~link_status: per sensor, once a second, the numbers of its diagnostics (rostopic echo
        # needs the message's Python side).
        msg = self.echo_one(self.node + "/link_status")
        self.assertIn(msg["sensor"], ("odom", "imu"))
        for key in ("arrival_rate", "arrival_rate_lower", "arrival_rate_upper", "p", "r", "late_fraction",
                    "delay_p50", "delay_p99", "margin"):
            self.assertIn(key, msg)
        self.assertIn(msg["link_level"], ("OK", "WARN", "ERROR"))

    def test_echo_tf(self):
        msg = self.echo_one("/tf")
        # The Estimator's own transform (publish_tf's default): world frame -> <algorithm>_estimate.
        pairs = [(t["header"]["frame_id"], t["child_frame_id"]) for t in msg["transforms"]]
        self.assertIn(("map", self.params["algorithm"] + "_estimate"), pairs)

    def test_echo_input(self):
        # An input of the graph, sensor_msgs/Imu from the PlantSimulator.
        msg = self.echo_one("/imu/data")
        self.assertEqual(msg["header"]["frame_id"], self.params["base_link_frame"])
        self.assertTrue(math.isfinite(msg["angular_velocity"]["z"]))
        self.assertEqual(msg["orientation_covariance"][0], -1.0)

    def test_hz(self):
        # rostopic hz over about 5 s of odometry/filtered: one estimate per step, at the model's rate.
        expected = 1.0 / self.model["period"]
        hz = Background("rostopic", "hz", "-w", "10000", self.odometry)
        time.sleep(6.0)
        code, out, err = hz.stop()
        rates = [float(line.split(":")[1]) for line in out.splitlines() if line.startswith("average rate:")]
        self.assertTrue(rates, "rostopic hz printed no rate (exit %s): %s %s" % (code, out, err))
        print("rostopic hz: %s Hz (the model's rate: %g Hz)" % (rates[-1], expected))
        # The rate rostopic hz prints is (messages - 1) / (span of their receipt times). The plant
        # steps on a steady clock and the Estimator publishes one estimate per step, so the count
        # over the span is exact; only the receipt of the first and the last message can be late.
        # 20 % of a span of at least 4 s is 0.8 s of such delay, far more than a loaded machine
        # adds, while a rate off by a whole factor (every other step, or twice per step) fails.
        self.assertLess(abs(rates[-1] - expected), 0.2 * expected,
                        "rostopic hz: %.3f Hz, the model's rate %.3f Hz; its output:\n%s" % (rates[-1], expected, out))

    def test_set_pose(self):
        x, y, yaw = 100.0, -50.0, 1.0
        echo = Background("rostopic", "echo", self.odometry)
        try:
            deadline = time.time() + TOOL_TIMEOUT
            while last_document(echo.output()) is None and time.time() < deadline and echo.proc.poll() is None:
                time.sleep(0.1)
            self.assertIsNotNone(last_document(echo.output()), "rostopic echo %s printed nothing: %s"
                                 % (self.odometry, echo.output("stderr")))
            cov = [0.0] * 36
            cov[0] = cov[7] = 0.01
            cov[35] = 0.001
            request = yaml.safe_dump({"pose": {
                "header": {"frame_id": self.params["world_frame"]},
                "pose": {"pose": {"position": {"x": x, "y": y, "z": 0.0},
                                  "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}},
                         "covariance": cov}}}, default_flow_style=True).strip()
            t_call = time.time()
            code, out, err = run_tool("rosservice", "call", self.ns + "/set_pose", request)
            t_return = time.time()
            self.assertEqual(code, 0, "rosservice call %s/set_pose failed (exit %d): %s %s" % (self.ns, code, out, err))
            answer = yaml.safe_load(out)
            self.assertIs(answer["success"], True, out)
            # Every estimate whose step is stamped after the call returned was taken after the pose
            # was set: wait for a second of them.
            while time.time() < deadline and echo.proc.poll() is None:
                last = last_document(echo.output())
                if last is not None and stamp(last) > t_return + 1.0:
                    break
                time.sleep(0.1)
        finally:
            code, out, err = echo.stop()
        docs = echo_documents(out)
        before = [d for d in docs if stamp(d) < t_call]
        after = [d for d in docs if stamp(d) > t_return]
        self.assertTrue(before, "no estimate before the call: %s" % err)
        self.assertTrue(after, "no estimate after the call: %s" % err)

        def pose_of(d):
            p = d["pose"]["pose"]
            return p["position"]["x"], p["position"]["y"], yaw_of(p["orientation"])

        bx, by, _ = pose_of(before[-1])
        self.assertGreater(math.hypot(bx - x, by - y), 10.0, "the estimate was at the pose before the call")
        # The model measures only velocities: from the pose on, the estimate moves by dead reckoning.
        # The first step after the reset moves it by its gain through the position-velocity
        # covariance, at most period * |v| (1 mm here); each further one by period * |v|. The
        # velocities' stationary standard deviation is 0.032 m/s per axis and 0.005 rad/s (the model
        # file): at 5 standard deviations 0.23 m/s in the plane and 0.025 rad/s, over the time from
        # the call (the reset comes after it) to the estimate's step.
        ax, ay, ayaw = pose_of(after[0])
        elapsed = stamp(after[0]) - t_call
        print("set_pose: the first estimate after the call, %.3f s after it: (%.4f, %.4f, yaw %.4f); before: (%.3f, %.3f)"
              % (elapsed, ax, ay, ayaw, bx, by))
        self.assertLess(math.hypot(ax - x, ay - y), 0.01 + 0.23 * elapsed,
                        "first estimate after the call (%.3f s) at (%g, %g)" % (elapsed, ax, ay))
        self.assertLess(abs(angle_diff(ayaw, yaw)), 0.001 + 0.025 * elapsed,
                        "first estimate after the call (%.3f s): yaw %g" % (elapsed, ayaw))

    def test_dynparam_get(self):
        code, out, err = run_tool("rosrun", "dynamic_reconfigure", "dynparam", "get", self.node + "/reconfigure")
        self.assertEqual(code, 0, "dynparam get failed (exit %d): %s %s" % (code, out, err))
        config = ast.literal_eval(out.strip())
        for key in ("adaptive_latency", "latency_budget", "latency_budget_min", "latency_budget_max", "late_policy",
                    "trace_bound"):
            self.assertIn(key, config, out)
        # The values in use: the fixed budget of the parameters, and the default late policy.
        self.assertIs(config["adaptive_latency"], False)
        self.assertAlmostEqual(config["latency_budget"], self.params["latency_budget"])
        self.assertEqual(config["late_policy"], "drop")

    def test_dynparam_set_refuses_and_keeps_the_settings(self):
        # What a user types: a NaN trace_bound and a budget below 0. The server refuses each (its
        # ERROR names the key: the rostest ReconfigureIsValidated reads it) and keeps the settings in
        # use: no bound (shown as 1e300) and the parameters' fixed budget.
        for key, value in (("trace_bound", "nan"), ("latency_budget", "-1"), ("latency_budget_min", "-5")):
            code, out, err = run_tool("rosrun", "dynamic_reconfigure", "dynparam", "set", self.node + "/reconfigure",
                                      key, value)
            self.assertEqual(code, 0, "dynparam set %s %s failed (exit %d): %s %s" % (key, value, code, out, err))
            code, out, err = run_tool("rosrun", "dynamic_reconfigure", "dynparam", "get", self.node + "/reconfigure")
            self.assertEqual(code, 0, "dynparam get failed (exit %d): %s %s" % (code, out, err))
            config = ast.literal_eval(out.strip())
            self.assertEqual(config["trace_bound"], 1e300, "after %s = %s: %s" % (key, value, out))
            self.assertAlmostEqual(config["latency_budget"], self.params["latency_budget"], msg=out)
            self.assertGreaterEqual(config["latency_budget_min"], 0.0, out)


if __name__ == "__main__":
    import rostest

    parser = argparse.ArgumentParser()
    parser.add_argument("--namespace", required=True)
    parser.add_argument("--model", required=True)
    parser.add_argument("--params", required=True)
    ARGS, _ = parser.parse_known_args()
    rostest.rosrun("networked_estimation", "cmdline_tools", CommandLineTools, sys.argv)
