#!/usr/bin/env bash
# The researchers' command: the Python module without ROS. Installs the few Debian 12 packages the
# build without ROS needs (scripts/install_deps.sh --core: no ROS package), builds and installs the
# package into a virtual environment in the clone (.venv, with Debian's numpy and matplotlib:
# `pip install --no-build-isolation .`, offline), and runs the Python examples (scripts/examples),
# whose figures go to research_output/. Then: `source .venv/bin/activate; python3 -c "import
# networked_estimation"`. NE_JOBS: parallel compile jobs (default: the CPU count).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/install_deps.sh" --core
# Debian's interpreter (its numpy and matplotlib), not another python3 on PATH.
PY=/usr/bin/python3
VENV="$ROOT/.venv"
if [ ! -x "$VENV/bin/python3" ]; then
  echo "research: creating $VENV (a virtual environment that sees Debian's Python packages)"
  "$PY" -m venv --system-site-packages "$VENV"
fi
cd "$ROOT"
echo "research: building and installing networked_estimation into $VENV (pip, CMake without ROS)"
start=$(date +%s)
NE_JOBS="${NE_JOBS:-$(nproc)}" "$VENV/bin/python3" -m pip install --no-build-isolation --no-index --no-deps -q .
echo "research: installed in $(( $(date +%s) - start )) s"
OUT="$ROOT/research_output"
mkdir -p "$OUT"
cd "$OUT"
for example in zhou_fig1 stability_map; do
  MPLBACKEND=Agg "$VENV/bin/python3" "$ROOT/scripts/examples/$example.py" "$OUT/$example.png"
done
MPLBACKEND=Agg "$VENV/bin/python3" "$ROOT/scripts/examples/gilbert_elliott_recovery.py"
echo "research: done; the figures are in $OUT; use the module with: source $VENV/bin/activate"
