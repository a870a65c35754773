#!/usr/bin/env python3
"""The Estimator of a graph test, configured at test time by import_robot_localization.

    load_imported_estimator.py RL_CONFIG MANAGER [import options...]   (as a roslaunch node)

Runs the importer on RL_CONFIG (a robot_localization parameter YAML or launch / rostest file, as
its user has it), keeps the result in ROS_HOME (imported_<node name>.yaml, for a look after the
test), loads it as this node's private parameters and then becomes the nodelet loader of
networked_estimation/Estimator into MANAGER under this node's name: the Estimator reads exactly
the importer's output. An importer failure ends the node with its message and exit status.
"""
import os
import subprocess
import sys

import roslib.packages
import rosparam
import rospkg


def main():
    args = [a for a in sys.argv[1:] if ":=" not in a]
    remaps = [a for a in sys.argv[1:] if ":=" in a]
    if len(args) < 2:
        sys.exit("usage: load_imported_estimator.py RL_CONFIG MANAGER [import options...]")
    rl_config, manager, options = args[0], args[1], args[2:]
    # The node's name as roslaunch gives it (__name:=, in ROS_NAMESPACE): the Estimator's namespace.
    # No rospy node: the nodelet loader that replaces this process registers that name.
    base = next((a.split(":=", 1)[1] for a in remaps if a.startswith("__name:=")), None)
    if not base:
        sys.exit("load_imported_estimator.py: run it as a roslaunch node (no __name:= given)")
    name = os.environ.get("ROS_NAMESPACE", "/").rstrip("/") + "/" + base
    package = rospkg.RosPack().get_path("networked_estimation")
    importer = os.path.join(package, "scripts", "import_robot_localization")
    out_dir = os.environ.get("ROS_HOME", os.path.join(os.path.expanduser("~"), ".ros"))
    os.makedirs(out_dir, exist_ok=True)
    out = os.path.join(out_dir, "imported_%s.yaml" % name.strip("/").replace("/", "_"))
    run = subprocess.run([sys.executable, importer, rl_config, "--output", out] + options,
                         stderr=subprocess.PIPE, universal_newlines=True)
    sys.stderr.write(run.stderr)
    if run.returncode != 0:
        sys.stderr.write("load_imported_estimator.py: import_robot_localization %s failed (exit %d)\n" %
                         (rl_config, run.returncode))
        sys.exit(run.returncode)
    print("load_imported_estimator.py: import_robot_localization %s -> %s" % (rl_config, out))
    # rosparam's own reader, as <rosparam command="load"> in a launch file reads the file.
    for params, ns in rosparam.load_file(out, default_namespace=name):
        rosparam.upload_params(ns, params)
    binary = next((c for c in roslib.packages.find_node("nodelet", "nodelet") if os.access(c, os.X_OK)), None)
    if binary is None:
        sys.exit("load_imported_estimator.py: the nodelet executable of package nodelet was not found")
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(binary, [binary, "load", "networked_estimation/Estimator", manager, "--no-bond"] + remaps)


if __name__ == "__main__":
    main()
