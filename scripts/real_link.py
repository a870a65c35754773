#!/usr/bin/env python3
"""The robot demo across a real lossy link (scripts/real_link_lib.sh runs it; docs/ros_interface.md,
"Transport per input"): the robot's network namespace runs the master and the PlantSimulator, the
base station's runs two Estimators reading the sensors straight off the link, one over tcp and one
over udp, each in its own process (roscpp shares one connection per topic and process).

  real_link.py record WORK          robot side: truth, what was sent, the estimates and diagnostics
  real_link.py drive WORK PLAN      base side: the drop rules (nftables) phase by phase
  real_link.py table WORK [CSV]     the tcp/udp table of a finished run
  real_link.py duration PLAN        the plant's duration (s) the plan needs

PLAN is a JSON file: {"robot_ip", "base_ip", "tcpros_port", "warmup", "settle", "phases": [...]},
each phase {"name", "seconds", "kind": "random", "percent": N} or {"name", "seconds", "kind":
"bursty", "p", "r", "period", "seed"[, "record": true]}. Everything lands in WORK: truth.csv,
sent.csv, est_tcp.csv, est_udp.csv, diag.jsonl (the recorder's), phases.json, counters.jsonl (the
kernel's counters at each diagnostics of the udp Estimator), toggler.csv (the drawn chain) and, for
a phase with "record", <phase>.bag (rosbag record --udp at the base station).
"""
import bisect
import json
import math
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time
import xmlrpc.client

import rosgraph

SENSORS = [("odom", "/odom"), ("imu", "/imu/data"), ("gps", "/fix")]
RATES = {"odom": 50.0, "imu": 10.0, "gps": 5.0}
TRANSPORTS = ("tcp", "udp")
TABLE = "ne_real_link"
HALF_STEP = 0.01  # half the plant's period (config/models/demo_robot.yaml: 0.02 s)


def fail(msg):
    print("real_link: " + msg, file=sys.stderr)
    sys.exit(1)


# --------------------------------------------------------------------------------------------------
# record: the robot side


def record(work):
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import Imu, NavSatFix
    from networked_estimation.msg import Estimate, PlantState

    rospy.init_node("real_link_recorder")
    lock = threading.Lock()
    files = {
        "truth": open(os.path.join(work, "truth.csv"), "w"),
        "sent": open(os.path.join(work, "sent.csv"), "w"),
        "tcp": open(os.path.join(work, "est_tcp.csv"), "w"),
        "udp": open(os.path.join(work, "est_udp.csv"), "w"),
        "diag": open(os.path.join(work, "diag.jsonl"), "w"),
    }
    files["truth"].write("step,stamp,x\n")
    files["sent"].write("sensor,stamp\n")
    for t in TRANSPORTS:
        files[t].write("stamp,receipt,gamma,trace,x\n")

    def write(key, line):
        with lock:
            files[key].write(line)

    def on_truth(m):
        write("truth", "%d,%.9f,%s\n" % (m.step, m.header.stamp.to_sec(), " ".join("%.17g" % v for v in m.x)))

    def on_sent(name):
        def cb(m):
            write("sent", "%s,%.9f\n" % (name, m.header.stamp.to_sec()))
        return cb

    def on_estimate(t):
        def cb(m):
            now = time.time()
            write(t, "%.9f,%.9f,%d,%.17g,%s\n" % (m.header.stamp.to_sec(), now, int(m.gamma), m.covariance_trace,
                                                  " ".join("%.17g" % v for v in m.state)))
        return cb

    def on_diag(a):
        now = time.time()
        for s in a.status:
            if not any(s.name.startswith(t + "/estimator: ") for t in TRANSPORTS):
                continue
            rec = {"wall": now, "stamp": a.header.stamp.to_sec(), "name": s.name, "level": ord(s.level)
                   if isinstance(s.level, (bytes, str)) else int(s.level), "message": s.message,
                   "values": {kv.key: kv.value for kv in s.values}}
            write("diag", json.dumps(rec) + "\n")

    subs = [rospy.Subscriber("/plant/state", PlantState, on_truth, queue_size=10000),
            rospy.Subscriber("/odom", Odometry, on_sent("odom"), queue_size=10000),
            rospy.Subscriber("/imu/data", Imu, on_sent("imu"), queue_size=10000),
            rospy.Subscriber("/fix", NavSatFix, on_sent("gps"), queue_size=10000),
            rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=1000)]
    est = [rospy.Subscriber("/%s/estimate" % t, Estimate, on_estimate(t), queue_size=10000) for t in TRANSPORTS]
    subs += est

    def flush_all():
        with lock:
            for f in files.values():
                f.flush()

    def close_all():
        with lock:
            for f in files.values():
                f.close()

    rospy.on_shutdown(close_all)
    ready = False
    while not rospy.is_shutdown():
        if not ready and all(s.get_num_connections() > 0 for s in est + subs[:4]):
            ready = True
            with open(os.path.join(work, "recorder_ready"), "w") as f:
                f.write("%.6f\n" % time.time())
        flush_all()
        time.sleep(0.2)


# --------------------------------------------------------------------------------------------------
# drive: the base side


def plan_duration(plan):
    """The plant runs through the warm-up, every phase (settle + window) and one second more."""
    return plan["warmup"] + sum(plan["settle"] + ph["seconds"] for ph in plan["phases"]) + 1.0


def nft(script, check=True):
    r = subprocess.run(["nft", "-f", "-"], input=script, text=True, capture_output=True)
    if check and r.returncode != 0:
        fail("nft refused:\n%s\n%s" % (script, r.stderr))
    return r


def counters():
    r = subprocess.run(["nft", "-j", "list", "counters", "table", "inet", TABLE], text=True, capture_output=True)
    if r.returncode != 0:
        fail("nft list counters: " + r.stderr)
    out = {}
    for item in json.loads(r.stdout)["nftables"]:
        c = item.get("counter")
        if c:
            out[c["name"]] = c["packets"]
    return out


def bus_links(master, node):
    """The inbound connections of `node`: [(topic, transport, local port)]."""
    try:
        uri = master.lookupNode(node)
        code, msg, rows = xmlrpc.client.ServerProxy(uri).getBusInfo("/real_link_driver")
    except (rosgraph.MasterException, OSError, xmlrpc.client.Error):
        return None
    out = []
    for r in rows:
        if len(r) >= 7 and r[2] == "i":
            m = re.search(r"on port (\d+)", r[6])
            out.append((r[4], r[3], int(m.group(1)) if m else None))
    return out


def node_pid(master, node):
    return xmlrpc.client.ServerProxy(master.lookupNode(node)).getPid("/real_link_driver")[2]


def cpu_seconds(pid):
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def wait_file(path, timeout, what):
    end = time.time() + timeout
    while time.time() < end:
        if os.path.exists(path) and os.path.getsize(path) > 0:
            return
        time.sleep(0.1)
    fail("%s did not happen within %g s (%s)" % (what, timeout, path))


def sleep_until(t):
    while True:
        d = t - time.time()
        if d <= 0:
            return
        time.sleep(min(d, 0.5))


class Toggler:
    """A Gilbert-Elliott chain (p: good -> bad, r: bad -> good per step of `period` s, seeded)
    switching the drop rule: the robot's address is in the set @bad while the chain is bad. Its
    steps start half a plant period (10 ms) after a plant step (`phase`: the plant's first stamp),
    so that no sample is sent within 10 ms of a switch; with `period` the plant's (0.02 s) each
    step holds one odometry sample, and the chain is the per-step link the Estimator estimates."""

    def __init__(self, ph, robot_ip, phase, log):
        self.name, self.p, self.r, self.period = ph["name"], ph["p"], ph["r"], ph["period"]
        self.rng = random.Random(ph["seed"])
        self.robot_ip, self.phase, self.log = robot_ip, phase, log
        self.stop_at = None
        self.thread = None
        # one nft process fed line by line: a switch costs a write, not a process start
        self.nft = subprocess.Popen(["nft", "-i"], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL, text=True)

    def start(self, until):
        self.stop_at = until
        self.thread = threading.Thread(target=self.run)
        self.thread.start()

    def run(self):
        now = time.time()
        j = math.ceil((now - self.phase - HALF_STEP) / self.period) + 1
        bad = self.rng.random() < self.p / (self.p + self.r)  # the stationary law
        current = False
        while True:
            t = self.phase + HALF_STEP + j * self.period
            if t >= self.stop_at:
                break
            sleep_until(t)
            if bad != current:
                verb = "add" if bad else "delete"
                self.nft.stdin.write("%s element inet %s bad { %s }\n" % (verb, TABLE, self.robot_ip))
                self.nft.stdin.flush()
                current = bad
            self.log.write("%s,%.6f,%.6f,%d\n" % (self.name, t, time.time(), int(bad)))
            j += 1
            bad = (self.rng.random() >= self.r) if bad else (self.rng.random() < self.p)
        if current:
            self.nft.stdin.write("delete element inet %s bad { %s }\n" % (TABLE, self.robot_ip))
            self.nft.stdin.flush()
        self.log.flush()

    def join(self):
        if self.thread:
            self.thread.join()
        self.nft.stdin.close()
        self.nft.wait(timeout=10)


def drive(work, plan_path):
    import rospy
    from std_msgs.msg import Empty

    plan = json.load(open(plan_path))
    robot, base = plan["robot_ip"], plan["base_ip"]
    rospy.init_node("real_link_driver", disable_signals=True)
    master = rosgraph.Master("/real_link_driver")
    nodes = {t: "/base_%s_manager" % t for t in TRANSPORTS}
    # 1. Every Estimator input connected, over the transport it asked for (the udp Estimator's
    #    publisher is roscpp: no fallback).
    links = {}
    end = time.time() + 60
    while time.time() < end:
        links = {t: bus_links(master, n) for t, n in nodes.items()}
        if all(l is not None and all(any(x[0] == topic for x in l) for _, topic in SENSORS) for l in links.values()):
            break
        time.sleep(0.2)
    else:
        fail("the Estimators' inputs did not connect within 60 s: %s" % links)
    flows = {}
    for t in TRANSPORTS:
        for name, topic in SENSORS:
            rows = [x for x in links[t] if x[0] == topic]
            want = "UDPROS" if t == "udp" else "TCPROS"
            if len(rows) != 1 or rows[0][1] != want or rows[0][2] is None:
                fail("the %s Estimator's %s connection is %s, expected one %s connection" % (t, topic, rows, want))
            flows["%s_%s" % (t, name)] = rows[0][2]
    # 2. The drop rules. Only the data from the robot's publishers to the base station's
    #    subscribers: every UDP datagram from the robot (UDPROS: the graph has no other UDP) and the
    #    TCP segments from the robot's TCPROS server port (its publishers' data) other than the
    #    connection's handshake and close (SYN, FIN, RST). The master's and the nodes' XML-RPC
    #    (registration, requestTopic, publisherUpdate) and the base station's own data to the robot
    #    (/rosout, the estimates) are never touched. Per flow (the local port each subscriber got), a
    #    counter of what arrived and one of what was dropped; the phase's rule sits alone in `verdict`.
    decl = "".join("  counter %s_seen {}\n  counter %s_dropped {}\n" % (f, f) for f in flows)
    seen = "".join("    %s dport %d counter name %s_seen\n" % (f[:3], p, f) for f, p in flows.items())
    dropped = "".join("    %s dport %d counter name %s_dropped\n" % (f[:3], p, f) for f, p in flows.items())
    nft("""table inet %(t)s {
  set bad { type ipv4_addr; }
%(decl)s  chain input {
    type filter hook input priority 0; policy accept;
    ip saddr %(r)s ip daddr %(b)s meta l4proto udp jump data
    ip saddr %(r)s ip daddr %(b)s tcp sport %(port)d tcp flags & (syn | fin | rst) == 0 jump data
  }
  chain data {
%(seen)s    jump verdict
  }
  chain verdict {
  }
  chain dropping {
%(dropped)s    drop
  }
}
""" % {"t": TABLE, "decl": decl, "r": robot, "b": base, "port": plan["tcpros_port"], "seen": seen,
       "dropped": dropped})
    pids = {t: node_pid(master, n) for t, n in nodes.items()}
    # The kernel's counters at each diagnostics message of the udp Estimator (published in this
    # namespace): the two count the same packets at (nearly) the same instant.
    from diagnostic_msgs.msg import DiagnosticArray
    snapshots = open(os.path.join(work, "counters.jsonl"), "w")
    snap_lock = threading.Lock()

    def on_diag(a):
        if not any(st.name.startswith("udp/estimator: estimator") for st in a.status):
            return
        c = counters()
        with snap_lock:
            if not snapshots.closed:
                snapshots.write(json.dumps({"stamp": a.header.stamp.to_sec(), "wall": time.time(), "counters": c}) + "\n")
                snapshots.flush()
    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=10)
    # 3. The recorder listens: start the plant.
    wait_file(os.path.join(work, "recorder_ready"), 60, "the recorder's subscriptions")
    go = rospy.Publisher("/real_link/go", Empty, queue_size=1, latch=True)
    go.publish(Empty())
    sent = os.path.join(work, "sent.csv")
    end = time.time() + 30
    first = {}
    while time.time() < end and len(first) < len(SENSORS):
        with open(sent) as f:
            for line in f.readlines()[1:]:
                parts = line.strip().split(",")
                if len(parts) == 2 and parts[0] not in first:
                    first[parts[0]] = float(parts[1])
        time.sleep(0.1)
    if len(first) < len(SENSORS):
        fail("the plant published only %s within 30 s of the start" % sorted(first))
    t0 = min(first.values())  # the plant's first step (every sensor is due at it)
    # 4. The phases, on the plant's clock (wall time: its stamps).
    out = {"flows": flows, "pids": pids, "t0": t0, "phases": []}
    toggler_log = open(os.path.join(work, "toggler.csv"), "w")
    toggler_log.write("phase,boundary,wall,bad\n")
    t = t0 + plan["warmup"]
    for ph in plan["phases"]:
        rule_at, start, stop = t, t + plan["settle"], t + plan["settle"] + ph["seconds"]
        t = stop
        sleep_until(rule_at)
        toggler = None
        if ph["kind"] == "random":
            rule = "numgen random mod 100 < %d jump dropping" % ph["percent"] if ph["percent"] > 0 else ""
            nft("flush chain inet %s verdict\n%s" % (TABLE, "add rule inet %s verdict %s\n" % (TABLE, rule) if rule
                                                      else ""))
        else:
            nft("flush chain inet %s verdict\nadd rule inet %s verdict ip saddr @bad jump dropping\n" % (TABLE, TABLE))
            toggler = Toggler(ph, robot, t0, toggler_log)
            toggler.start(stop)
        sleep_until(start)
        c0 = counters()
        cpu0 = {k: cpu_seconds(p) for k, p in pids.items()}
        bag = None
        if ph.get("record"):
            bag = subprocess.Popen(["rosbag", "record", "--udp", "-O", os.path.join(work, ph["name"] + ".bag")] +
                                   [topic for _, topic in SENSORS], stdout=subprocess.DEVNULL,
                                   stderr=subprocess.STDOUT)
        sleep_until(stop)
        c = counters()
        cpu1 = {k: cpu_seconds(p) for k, p in pids.items()}
        if bag:
            bag.send_signal(signal.SIGINT)
            bag.wait(timeout=30)
        if toggler:
            toggler.join()
        rec = dict(ph)
        rec.update({"start": start, "stop": stop, "counters": {k: c[k] - c0.get(k, 0) for k in c},
                    "cpu": {k: cpu1[k] - cpu0[k] for k in cpu0}})
        out["phases"].append(rec)
        print("real_link: phase %s done" % ph["name"], flush=True)
    nft("flush chain inet %s verdict\n" % TABLE)
    out["end"] = t
    toggler_log.close()
    # The plant stops at its duration; what TCP still holds then drains within a few seconds.
    sleep_until(t0 + plan_duration(plan) + plan["tail"])
    out["final_counters"] = counters()
    with open(os.path.join(work, "phases.json"), "w") as f:
        json.dump(out, f, indent=1)
    with snap_lock:
        snapshots.close()


# --------------------------------------------------------------------------------------------------
# table: what a finished run measured


def read_csv(path):
    with open(path) as f:
        header = f.readline()
        return [line.rstrip("\n").split(",") for line in f if line.strip()], header


def load_run(work):
    """Everything a finished run measured, per phase and transport."""
    run = json.load(open(os.path.join(work, "phases.json")))
    truth = {}
    rows, _ = read_csv(os.path.join(work, "truth.csv"))
    for r in rows:
        truth[round(float(r[1]) * 1000)] = [float(v) for v in r[2].split()]
    est = {}
    for t in TRANSPORTS:
        rows, _ = read_csv(os.path.join(work, "est_%s.csv" % t))
        est[t] = [(float(r[0]), float(r[1]), int(r[2]), [float(v) for v in r[4].split()]) for r in rows]
    sent = {}
    rows, _ = read_csv(os.path.join(work, "sent.csv"))
    for r in rows:
        sent.setdefault(r[0], []).append(float(r[1]))
    diag = {t: {"estimator": [], "link": []} for t in TRANSPORTS}
    with open(os.path.join(work, "diag.jsonl")) as f:
        for line in f:
            d = json.loads(line)
            t, what = d["name"].split("/", 1)
            diag[t]["link" if what.endswith("link stability") else "estimator"].append(d)
    for t in TRANSPORTS:
        for k in diag[t]:
            diag[t][k].sort(key=lambda d: d["stamp"])
    return run, truth, est, sent, diag


def last_before(records, t):
    stamps = [d["stamp"] for d in records]
    i = bisect.bisect_right(stamps, t) - 1
    return records[i] if i >= 0 else None


def quantile(xs, q):
    if not xs:
        return float("nan")
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(math.ceil(q * len(xs))) - 1)]


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def phase_stats(run, truth, est, sent, diag, ph, t):
    """The measures of transport t over phase ph's window [start, stop]."""
    a = last_before(diag[t]["estimator"], ph["start"])
    b = last_before(diag[t]["estimator"], ph["stop"])
    if a is None or b is None or a is b:
        return None
    va, vb = a["values"], b["values"]
    s = {"diag_from": a["stamp"], "diag_to": b["stamp"]}
    num = lambda v, k: float(v[k])
    s["received"] = {n: num(vb, n + " messages") - num(va, n + " messages") for n, _ in SENSORS}
    s["late_dropped"] = num(vb, "late dropped") - num(va, "late dropped")
    due_a, due_b = num(va, "due samples"), num(vb, "due samples")
    arr_a = num(va, "due arrival rate") * due_a
    arr_b = num(vb, "due arrival rate") * due_b
    s["due"] = due_b - due_a
    s["arrival"] = (arr_b - arr_a) / (due_b - due_a) if due_b > due_a else float("nan")
    window = [d for d in diag[t]["estimator"] if a["stamp"] <= d["stamp"] <= b["stamp"]]
    s["budget_max"] = max(num(d["values"], "latency budget (s)") for d in window)
    s["budget_end"] = num(vb, "latency budget (s)")
    s["delay_p99"] = {n: num(vb, n + " delay p99 (s)") for n, _ in SENSORS}
    s["transport"] = {n: vb.get(n + " transport", "") for n, _ in SENSORS}
    # Messages the robot sent with stamps in the diagnostics' window (what could have arrived).
    s["sent"] = {n: sum(1 for x in sent.get(n, []) if a["stamp"] < x <= b["stamp"]) for n, _ in SENSORS}
    # The estimates of the window: how late each left (its stamp to its arrival at the robot, the
    # recorder's clock: the same machine's) and its squared error against the truth.
    delays, errors = [], []
    for stamp, receipt, gamma, x in est[t]:
        if ph["start"] <= stamp <= ph["stop"]:
            delays.append(receipt - stamp)
            xt = truth.get(round(stamp * 1000))
            if xt is not None:
                e = [xi - ti for xi, ti in zip(x, xt)]
                e[2] = wrap(e[2])  # the yaw (state 2 of config/models/demo_robot.yaml) is an angle
                errors.append(sum(v * v for v in e))
    s["estimates"] = len(delays)
    s["estimate_delay_p50"] = quantile(delays, 0.5)
    s["estimate_delay_p99"] = quantile(delays, 0.99)
    s["errors"] = errors
    s["mse"] = sum(errors) / len(errors) if errors else float("nan")
    inputs = sum(s["received"].values())
    s["cpu_per_input_us"] = 1e6 * ph["cpu"][t] / inputs if inputs > 0 else float("nan")
    link = last_before(diag[t]["link"], ph["stop"])
    s["link"] = link["values"] if link else {}
    s["counters"] = {k: v for k, v in ph["counters"].items() if k.startswith(t + "_")}
    return s


def table(work, csv_path=None):
    run, truth, est, sent, diag = load_run(work)
    header = ("phase", "transport", "budget max (s)", "late dropped", "arrival", "delay p99 odom/imu/gps (ms)",
              "estimate delay p50/p99 (ms)", "mse", "CPU/input (us)")
    lines = []
    for ph in run["phases"]:
        for t in TRANSPORTS:
            s = phase_stats(run, truth, est, sent, diag, ph, t)
            if s is None:
                lines.append((ph["name"], t) + ("(no diagnostics)",) + ("",) * 6)
                continue
            lines.append((ph["name"], t, "%.3f" % s["budget_max"], "%d" % s["late_dropped"], "%.3f" % s["arrival"],
                          "/".join("%.0f" % (1e3 * s["delay_p99"][n]) for n, _ in SENSORS),
                          "%.0f/%.0f" % (1e3 * s["estimate_delay_p50"], 1e3 * s["estimate_delay_p99"]),
                          "%.4f" % s["mse"], "%.0f" % s["cpu_per_input_us"]))
    widths = [max(len(str(r[i])) for r in [header] + lines) for i in range(len(header))]
    print("| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in lines:
        print("| " + " | ".join(str(v).ljust(w) for v, w in zip(r, widths)) + " |")
    if csv_path:
        with open(csv_path, "w") as f:
            f.write(",".join('"%s"' % h for h in header) + "\n")
            for r in lines:
                f.write(",".join('"%s"' % v for v in r) + "\n")


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "record":
        record(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "drive":
        drive(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 3 and sys.argv[1] == "duration":
        print(plan_duration(json.load(open(sys.argv[2]))))
    elif len(sys.argv) in (3, 4) and sys.argv[1] == "table":
        table(sys.argv[2], sys.argv[3] if len(sys.argv) == 4 else None)
    else:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
