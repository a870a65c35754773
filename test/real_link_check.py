#!/usr/bin/env python3
"""The assertions of test/test_real_link.sh on a finished run (scripts/real_link.py's WORK folder).

Usage: real_link_check.py WORK SOURCE_DIR TOOLS_DIR   (TOOLS_DIR holds montecarlo)
Prints one line per check (ok / FAIL) and exits 1 when any failed.
"""
import bisect
import json
import math
import os
import shutil
import subprocess
import sys

import yaml

work, src, tools = sys.argv[1:4]
sys.path.insert(0, os.path.join(src, "scripts"))
import real_link as rl  # noqa: E402

failures = []


def check(ok, what):
    print(("ok: " if ok else "FAIL: ") + what, flush=True)
    if not ok:
        failures.append(what)


def wilson(successes, trials, z):
    """The Wilson score interval of successes / trials at z standard deviations (no trials: none)."""
    if trials == 0:
        return float("nan"), float("nan")
    p = successes / trials
    d = 1 + z * z / trials
    c = (p + z * z / (2 * trials)) / d
    h = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / d
    return max(0.0, c - h), min(1.0, c + h)


def parse_rate(text):
    """"0.0155 [0.0042, 0.0547] (129 transitions)" -> (value, lower, upper, trials)."""
    value, rest = text.split(" [", 1)
    bounds, rest = rest.split("] (", 1)
    lower, upper = bounds.split(", ")
    return float(value), float(lower), float(upper), int(rest.split()[0])


run, truth, est, sent, diag = rl.load_run(work)
snapshots = {}
with open(os.path.join(work, "counters.jsonl")) as f:
    for line in f:
        d = json.loads(line)
        snapshots[round(d["stamp"], 6)] = d
final = run["final_counters"]
names = [n for n, _ in rl.SENSORS]

# 1. Each Estimator got the transport it asked for, on every input (the udp one from the robot's
#    roscpp publishers: UDPROS, no fallback), as its diagnostics say.
for t, want in (("udp", "udp: UDPROS from 1 publisher"), ("tcp", "tcp")):
    last = diag[t]["estimator"][-1]["values"]
    for n in names:
        check(last.get(n + " transport") == want, "%s Estimator, %s: transport '%s' (expected '%s')" %
              (t, n, last.get(n + " transport"), want))

# 2. The whole run, counted once the plant had stopped and TCP had drained: over tcp every message
#    the robot sent arrived (TCP turns a loss into a delay); over udp every datagram sent reached
#    the base station's input hook (the veth loses nothing itself), and the Estimator received
#    exactly those the drop rules let through. Exact counts: no tolerance.
for n in names:
    sent_n = len(sent.get(n, []))
    tcp_got = float(diag["tcp"]["estimator"][-1]["values"][n + " messages"])
    udp_got = float(diag["udp"]["estimator"][-1]["values"][n + " messages"])
    seen, dropped = final["udp_%s_seen" % n], final["udp_%s_dropped" % n]
    check(tcp_got == sent_n, "tcp, %s: no input lost: received %d of the %d sent" % (n, tcp_got, sent_n))
    check(seen == sent_n, "udp, %s: the kernel saw every datagram sent (%d of %d)" % (n, seen, sent_n))
    check(udp_got == seen - dropped, "udp, %s: received %d = the %d the kernel delivered (%d seen, %d dropped)" %
          (n, udp_got, seen - dropped, seen, dropped))

# 3. Per phase.
model_path = os.path.join(src, "config", "models", "demo_robot.yaml")
mc_dir = os.path.join(work, "montecarlo")
os.makedirs(mc_dir, exist_ok=True)
with open(model_path) as f:
    model = yaml.safe_load(f)
# The Estimator's sensors at their own rates, as montecarlo sees them: the PlantSimulator sends the
# IMU (10 Hz) at steps 1, 6, 11, ... and the fixes (5 Hz) at 1, 11, 21, ... (a periodic schedule:
# a sensor not scheduled is not lost).
model["schedule"] = {"pattern": [["odom", "imu", "gps"]] + [["odom"]] * 4 + [["odom", "imu"]] + [["odom"]] * 4}
scheduled_model = os.path.join(mc_dir, "demo_robot_rates.yaml")
with open(scheduled_model, "w") as f:
    yaml.safe_dump(model, f)
settings = os.path.join(src, "config", "estimators", "kfio.yaml")


def monte_carlo_prediction(name, channels, steps, transient=250, runs=40):
    """Time-averaged squared errors of `runs` independent montecarlo runs (custom, kfio, the model
    at the sensors' rates, each sensor behind its link) over `steps` steps after `transient` steps
    from the prior: one run per call (--runs 1: the CSV's per-step mean is that run's error)."""
    args = []
    for n, spec in channels.items():
        path = os.path.join(mc_dir, "%s_%s.yaml" % (name, n))
        with open(path, "w") as f:
            yaml.safe_dump(spec, f)
        args += ["--channel", "%s=%s" % (n, path)]
    out = []
    for r in range(runs):
        d = os.path.join(mc_dir, "%s_run%d" % (name, r))
        p = subprocess.run([os.path.join(tools, "montecarlo"), "--experiment", "custom", "--model", scheduled_model,
                            "--settings", settings, "--runs", "1", "--steps", str(transient + steps), "--seed",
                            str(1000 + r), "--threads", "1", "--out", d] + args, capture_output=True, text=True)
        if p.returncode != 0:
            check(False, "%s: montecarlo failed (exit %d): %s" % (name, p.returncode, p.stderr.strip()[-400:]))
            return None
        errors = []
        with open(os.path.join(d, "custom.csv")) as f:
            header = f.readline().strip().split(",")
            ix, im = header.index("x"), header.index("mean")
            for line in f:
                cells = line.strip().split(",")
                if float(cells[ix]) > transient:
                    errors.append(float(cells[im]))
        shutil.rmtree(d)
        out.append(sum(errors) / len(errors))
    return out


budgets = {}
for ph in run["phases"]:
    stats = {t: rl.phase_stats(run, truth, est, sent, diag, ph, t) for t in rl.TRANSPORTS}
    for t in rl.TRANSPORTS:
        check(stats[t] is not None, "%s, %s: diagnostics over the phase" % (ph["name"], t))
    if any(s is None for s in stats.values()):
        continue
    u = stats["udp"]
    budgets[ph["name"]] = {t: stats[t]["budget_max"] for t in rl.TRANSPORTS}
    # 3a. Over udp, each sensor's arrival rate (messages the Estimator received / messages the robot
    #     sent with stamps in the window between two of its diagnostics) against the delivered
    #     fraction of the kernel's counters read at those two diagnostics. Both count the same
    #     packets, so no sampling error separates them: only the messages at the windows' ends,
    #     those sent within the lag between a diagnostics (the Estimator's count) and the kernel's
    #     read that followed it (measured: the read's wall time - the diagnostics' stamp), plus one
    #     still queued in the Estimator, at each end. Each such message moves one fraction by at
    #     most 1 / n: tolerance (lag_a + lag_b) x rate + 2 messages, over n.
    a_snap, b_snap = snapshots.get(round(u["diag_from"], 6)), snapshots.get(round(u["diag_to"], 6))
    check(a_snap is not None and b_snap is not None, "%s: kernel counters at the udp Estimator's diagnostics" %
          ph["name"])
    if a_snap is None or b_snap is None:
        continue
    lags = [max(0.0, a_snap["wall"] - u["diag_from"]), max(0.0, b_snap["wall"] - u["diag_to"])]
    a_snap, b_snap = a_snap["counters"], b_snap["counters"]
    for n in names:
        n_sent = u["sent"][n]
        seen = b_snap["udp_%s_seen" % n] - a_snap["udp_%s_seen" % n]
        delivered = seen - (b_snap["udp_%s_dropped" % n] - a_snap["udp_%s_dropped" % n])
        if seen == 0 or n_sent == 0:
            check(False, "%s, udp, %s: the kernel counted %d datagrams, the robot sent %d" % (ph["name"], n, seen,
                                                                                           n_sent))
            continue
        arrival = u["received"][n] / n_sent
        kernel = delivered / seen
        edge = sum(math.ceil(lag * rl.RATES[n]) for lag in lags) + 2
        tol = edge / n_sent
        check(abs(arrival - kernel) <= tol, "%s, udp, %s: arrival rate %.4f (%d of %d) vs the kernel's delivered "
              "fraction %.4f (%d of %d), tolerance %.4f (%d messages at the ends, the reads %.0f / %.0f ms late)" %
              (ph["name"], n, arrival, u["received"][n], n_sent, kernel, delivered, seen, tol, edge, 1e3 * lags[0],
               1e3 * lags[1]))
        # The rule itself: each datagram dropped with probability N / 100, by the kernel's own
        # (unseeded) generator: the delivered fraction within 4.5 binomial standard deviations of
        # 1 - N / 100 (a false alarm once in 150 000 checks).
        if ph["kind"] == "random":
            q = 1.0 - ph["percent"] / 100.0
            sd = math.sqrt(q * (1 - q) / seen)
            check(abs(kernel - q) <= 4.5 * sd + 1e-12, "%s, %s: the kernel delivered %.4f, the rule %.2f (4.5 sd = "
                  "%.4f)" % (ph["name"], n, kernel, q, 4.5 * sd))
    # 3b. Over udp the losses are losses, not delays: the latency budget stays under 50 ms (it
    #     adapts to the delays of what arrives; a veth's are below a millisecond).
    check(u["budget_max"] < 0.05, "%s, udp: latency budget at most %.3f s < 0.05 s" % (ph["name"], u["budget_max"]))
    # 3c. The squared error against montecarlo's prediction for the link the kernel made (random
    #     phases): each sensor behind a Bernoulli link with the loss its flow met (the kernel's
    #     counters over the phase). The measured value is one run's time average over the window;
    #     40 montecarlo runs of the same length give that average's distribution (mean m, standard
    #     deviation s, each run an independent draw of it). The measured one must lie within
    #     m +- 4 s sqrt(1 + 1/40) (a new draw against a 40-run estimate; the time average of ~1000
    #     correlated steps is close to normal, so 4 s leaves ~1e-4 for a false alarm).
    if ph["kind"] == "random" and all(ph["counters"]["udp_%s_seen" % n] > 0 for n in names):
        c = ph["counters"]
        channels = {n: {"model": "bernoulli", "loss": c["udp_%s_dropped" % n] / c["udp_%s_seen" % n], "seed": 1}
                    for n in names}
        steps = int(round(ph["seconds"] / 0.02))
        runs = monte_carlo_prediction(ph["name"], channels, steps)
        if runs is None:
            continue
        m = sum(runs) / len(runs)
        s = math.sqrt(sum((x - m) ** 2 for x in runs) / (len(runs) - 1))
        tol = 4 * s * math.sqrt(1 + 1 / len(runs))
        check(abs(u["mse"] - m) <= tol, "%s, udp: squared error %.4f vs montecarlo %.4f +- %.4f (sd of one run %.4f, "
              "%d estimates)" % (ph["name"], u["mse"], m, tol, s, len(u["errors"])))
    # 3d'. The random phases' loss in the live link verdict: the odometry's window (its last 1000
    #     steps, all inside the phase) estimates a Gilbert-Elliott link (link_model: markov), which
    #     for independent drops of probability N / 100 has p = N / 100 and r = 1 - N / 100: each
    #     inside the estimate's Wilson interval widened to z = 4 (the kernel's drops are not
    #     seeded: a false alarm about once in 16 000 checks).
    if ph["kind"] == "random" and ph["percent"] > 0:
        loss = ph["percent"] / 100.0
        for key, nominal in (("odom failure rate p", loss), ("odom recovery rate r", 1.0 - loss)):
            text = u["link"].get(key, "")
            if not text:
                check(False, "%s, udp: the live estimate '%s' is in the diagnostics" % (ph["name"], key))
                continue
            value, lower, upper, trials = parse_rate(text)
            lo, hi = wilson(round(value * trials) if trials else 0, trials, 4.0)
            check(lo <= nominal <= hi, "%s, udp: the link verdict's %s = %s, the drops' %.2f in [%.4f, %.4f] (z = 4)" %
                  (ph["name"], key, text, nominal, lo, hi))
    # 3d. The bursty phase: the Estimator's live link estimate of the odometry (a sample every step,
    #     the toggler's step: its chain is the toggler's) against the toggler's p and r, inside the
    #     Wilson interval of the estimate's own counts, widened from its 95 % (z = 1.96) to z = 4
    #     (a pass/fail test must not fail one run in twenty; the chain is seeded); and against
    #     the chain the toggler actually drew over the same window (its log), which the estimate
    #     counts exactly but for the window's ends (3 steps each way: tolerance 6 / trials).
    if ph["kind"] == "bursty":
        for key, nominal in (("odom failure rate p", ph["p"]), ("odom recovery rate r", ph["r"])):
            text = u["link"].get(key, "")
            check(bool(text), "%s, udp: the live estimate '%s' is in the diagnostics" % (ph["name"], key))
            if not text:
                continue
            value, lower, upper, trials = parse_rate(text)
            lo, hi = wilson(round(value * trials) if trials else 0, trials, 4.0)
            check(trials >= 20 and lo <= nominal <= hi, "%s, udp: live %s = %s, the toggler's %.3f in [%.4f, %.4f] "
                  "(z = 4)" % (ph["name"], key, text, nominal, lo, hi))
        states = []
        with open(os.path.join(work, "toggler.csv")) as f:
            f.readline()
            for line in f:
                name, boundary, wall, bad = line.strip().split(",")
                if name == ph["name"]:
                    states.append((float(boundary), int(bad)))
        link_at = rl.last_before(diag["udp"]["link"], ph["stop"])["stamp"]
        window = [b for t, b in states if t + 0.01 <= link_at][-1000:]  # odometry sample t + 10 ms
        good_prev = sum(1 for x in window[:-1] if x == 0)
        bad_prev = len(window) - 1 - good_prev
        fails = sum(1 for x, y in zip(window, window[1:]) if x == 0 and y == 1)
        recoveries = sum(1 for x, y in zip(window, window[1:]) if x == 1 and y == 0)
        for key, drawn, trials in (("odom failure rate p", fails / max(1, good_prev), good_prev),
                                   ("odom recovery rate r", recoveries / max(1, bad_prev), bad_prev)):
            text = u["link"].get(key, "")
            if not text:
                continue
            value = parse_rate(text)[0]
            tol = 6.0 / max(1, trials)
            check(abs(value - drawn) <= tol, "%s, udp: live %s %.4f vs the toggler's drawn chain %.4f (%d steps), "
                  "tolerance %.4f" % (ph["name"], key, value, drawn, trials, tol))
        # Not asserted: montecarlo gives every sensor a link of its own, while here one outage
        # takes all three at once (the trace channel of a recorded run is what can replay that).
        print("note: %s, udp: squared error %.4f (montecarlo's links are independent per sensor: not compared)" %
              (ph["name"], u["mse"]))

# 5. Recorded across the real link (the bursty phase's bag, recorded at the base station over udp
#    by `rosbag record --udp`): fit_link finds the odometry's expected messages from header.seq and
#    fits the link; the trace channel (model: trace) replays that bag.
for ph in run["phases"]:
    if ph["kind"] != "bursty" or not ph.get("record"):
        continue
    bag = os.path.join(work, ph["name"] + ".bag")
    if not os.path.isfile(bag):
        check(False, "%s: the base station's bag %s was recorded" % (ph["name"], bag))
        continue
    p = subprocess.run([os.path.join(tools, "fit_link"), "--bag", bag, "--topic", "/odom", "--json", "--series"],
                       capture_output=True, text=True)
    check(p.returncode == 0, "%s: fit_link --bag on the recorded bag: exit %d %s" % (ph["name"], p.returncode,
                                                                                     p.stderr.strip()[-300:]))
    if p.returncode != 0:
        continue
    fit = json.loads(p.stdout)["links"][0]
    slots, t0, period = fit["expected"], fit["first_stamp"], fit["period"]
    arrived = [int(c) for c in fit["series"]["arrived"]]
    # 5a. The base station's arrival sequence, independently of the bag: the robot's own record of
    #     the odometry it sent over the fit's slots (one message per slot, stamps 20 ms apart), each
    #     dropped by the kernel exactly when the toggler's chain was bad at its send time (the chain
    #     switches half a step away from the samples: no sample sits on a switch). The bag's slots
    #     must be that sequence, message for message: no tolerance.
    sent_odom = sorted(sent.get("odom", []))
    window = [s for s in sent_odom if t0 - period / 2 <= s < t0 + (slots - 0.5) * period]
    chain = []
    with open(os.path.join(work, "toggler.csv")) as f:
        f.readline()
        for line in f:
            name, boundary, wall, bad = line.strip().split(",")
            if name == ph["name"]:
                chain.append((float(boundary), int(bad)))
    switches = [b for b, _ in chain]
    kernel = []
    for s in window:
        i = bisect.bisect_right(switches, s) - 1
        kernel.append(None if i < 0 else 1 - chain[i][1])
    check(len(window) == slots, "%s: fit_link's %d expected messages are the %d the robot sent over them" %
          (ph["name"], slots, len(window)))
    differ = sum(1 for a, k in zip(arrived, kernel) if a != k)
    check(len(window) == slots and differ == 0, "%s: the bag's arrivals are the toggler chain's, message for "
          "message (%d of %d differ)" % (ph["name"], differ, slots))
    # 5b. The fitted Gilbert link against the toggler's chain. The chain drawn over the bag's slots
    #     gives p and r by the same counts (n01 / (n00 + n01), n10 / (n10 + n11)), so the fit must
    #     equal them exactly when 5a holds. The toggler's nominal p, r (seed 36: the same chain every
    #     run) must lie in the fit's 95 % interval; printed, and asserted on the Wilson interval of the
    #     fit's own counts widened to z = 4 as in 3d (a pass/fail test must not fail one run in 20).
    g = fit["gilbert"]
    pairs = list(zip(kernel, kernel[1:])) if None not in kernel else []
    n00 = sum(1 for a, b in pairs if a == 1 and b == 1)
    n01 = sum(1 for a, b in pairs if a == 1 and b == 0)
    n10 = sum(1 for a, b in pairs if a == 0 and b == 1)
    n11 = sum(1 for a, b in pairs if a == 0 and b == 0)
    for key, nominal, drawn in (("p", ph["p"], n01 / max(1, n00 + n01)), ("r", ph["r"], n10 / max(1, n10 + n11))):
        est = g[key]
        check(abs(est["value"] - drawn) < 1e-12, "%s: fit_link's %s = %.4f, the chain the toggler drew over the bag's "
              "slots %.4f" % (ph["name"], key, est["value"], drawn))
        lo, hi = wilson(est["successes"], est["trials"], 4.0)
        inside = est["lower"] <= nominal <= est["upper"]
        check(lo <= nominal <= hi, "%s: the toggler's %s = %.3f in fit_link's [%.4f, %.4f] (z = 4; its 95 %% interval "
              "[%.4f, %.4f] %s it)" % (ph["name"], key, nominal, lo, hi, est["lower"], est["upper"],
                                         "holds" if inside else "misses"))
    # 5c. The trace channel replaying that bag (model: trace, trace: the bag, trace_topic: /odom) in
    #     simulate, one step per slot: a replay starts at the slot its seed chooses and loops, so its
    #     arrivals must be the base station's sequence turned round to one start (and that start must
    #     be the only one that fits: the sequence has no period of its own).
    channel = os.path.join(work, "bursty_trace.yaml")
    with open(channel, "w") as f:
        yaml.safe_dump({"model": "trace", "trace": bag, "trace_topic": "/odom"}, f)
    out = os.path.join(work, "replay")
    p = subprocess.run([os.path.join(tools, "simulate"), "--model", os.path.join(src, "config", "models",
                        "zhou_example.yaml"), "--channel", channel, "--steps", str(slots), "--seed", "3", "--out", out],
                       capture_output=True, text=True)
    check(p.returncode == 0, "%s: simulate with the bag as a trace channel: exit %d %s" %
          (ph["name"], p.returncode, p.stderr.strip()[-300:]))
    if p.returncode != 0:
        continue
    with open(os.path.join(out, "input.csv")) as f:
        header = f.readline().strip().split(",")
        gamma = [int(line.split(",")[header.index("gamma")]) for line in f if line.strip()]
    starts = [s for s in range(slots) if len(gamma) == slots and all(gamma[i] == kernel[(s + i) % slots]
                                                                       for i in range(slots))]
    check(len(starts) == 1, "%s: the trace channel replays the base station's %d arrivals in order (from slot %s)" %
          (ph["name"], slots, starts[0] if len(starts) == 1 else "none" if not starts else "several"))

# 4. Over tcp the budget adapts to the retransmissions' delays: far above what udp needs once
#    packets are lost (every lost segment is resent after at least a retransmission timeout).
for name in ("random_10", "random_20"):
    if name in budgets and "random_0" in budgets:
        b0, b = budgets["random_0"]["tcp"], budgets[name]["tcp"]
        check(b >= 0.1 and b >= 3 * b0, "%s, tcp: latency budget adapted to %.3f s (>= 0.1 s and >= 3 x the %.3f s "
              "at 0 %%)" % (name, b, b0))

print("real_link: %d checks failed" % len(failures) if failures else "real_link: every check passed")
sys.exit(1 if failures else 0)
