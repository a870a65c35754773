#!/usr/bin/env bash
# Installs the Debian 12 packages the package needs. Idempotent: does nothing when all are present.
# Usage: scripts/install_deps.sh            what building the package and running its nodelets,
#                                           tools, launch files and the demo need (scripts/demo.sh)
#        scripts/install_deps.sh --tests    also what the tests need (scripts/test.sh), and the
#                                           Python module's run time: every package package.xml names
#        scripts/install_deps.sh --core     only what the build without ROS needs (scripts/research.sh:
#                                           the core, the tools and the Python module with plain CMake
#                                           and pip, and the Python examples): no ROS package
set -euo pipefail
CORE_PACKAGES=(
  build-essential cmake
  libyaml-cpp-dev libeigen3-dev nlohmann-json3-dev libgeographiclib-dev libbz2-dev liblz4-dev
  pybind11-dev python3-dev python3-setuptools python3-wheel python3-pip python3-venv
  python3-numpy python3-matplotlib
)
PACKAGES=(
  build-essential cmake
  ros-core-dev libnodeletlib-dev libnodeletlib-tools rosbash python3-rosbag
  libtf2-ros-dev libtf2-eigen-dev libdiagnostic-updater-dev libtopic-tools-dev
  libgeometry-msgs-dev libsensor-msgs-dev libnav-msgs-dev libros-rosgraph-msgs-dev libtf2-dev libtf2-msgs-dev
  libgeographiclib-dev libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libyaml-cpp-dev libeigen3-dev nlohmann-json3-dev
  # The core reads ROS bags itself (fit_link, analyze --bag, trace channels): bz2 and lz4 chunks.
  libbz2-dev liblz4-dev
  pybind11-dev python3-dev python3-setuptools python3-yaml
  # The ROS command line on the package's graphs (rostopic echo, rosservice call, dynparam):
  # Debian packs each message package's Python side apart from its C++ headers, one for every
  # package of a type the nodelets publish, subscribe to or serve (docs/ros_interface.md).
  python3-rostopic python3-rosservice
  python3-std-msgs python3-geometry-msgs python3-sensor-msgs python3-nav-msgs python3-diagnostic-msgs
  python3-tf2-msgs python3-rosgraph-msgs
)
TEST_PACKAGES=(
  python3-rostest libgtest-dev googletest libbenchmark-dev catkin-lint
  # The C++ style check (test/test_format.sh, .clang-format): clang-format 14 on Debian 12.
  clang-format
  python3-pytest python3-distributed python3-numpy python3-matplotlib
  # The real-network test (test/test_real_link.sh): nftables drops packets between two network
  # namespaces (`ip` is iproute2's, in every Debian system).
  nftables
)
case "${1:-}" in
  "") ;;
  --tests) PACKAGES+=("${TEST_PACKAGES[@]}" python3-wheel python3-pip python3-venv) ;;
  --core) PACKAGES=("${CORE_PACKAGES[@]}") ;;
  *) echo "usage: install_deps.sh [--tests | --core]  (found '$1')" >&2; exit 2 ;;
esac
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install_deps: installing ${missing[*]}"
$SUDO apt-get update -q
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
