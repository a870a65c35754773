#!/usr/bin/env bash
# Runs the Python module's tests (test/python, pytest) against a built workspace.
#   usage: test_python.sh RESULT_XML TOOLS_DIR PYTHON_DIR REPO_ROOT
# PYTHON_DIR is the workspace's Python folder holding networked_estimation (devel or install space);
# TOOLS_DIR the tools the results are compared with. pytest writes the JUnit result itself.
set -euo pipefail
if [ $# -ne 4 ]; then
  echo "usage: $0 RESULT_XML TOOLS_DIR PYTHON_DIR REPO_ROOT" >&2
  exit 2
fi
mkdir -p "$(dirname "$1")"
RESULT=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
NE_TOOLS=$(cd "$2" && pwd)
NE_ROOT=$(cd "$4" && pwd)
PYTHON_DIR=$(cd "$3" && pwd)
export NE_TOOLS NE_ROOT
# Debian's python3 and its modules (numpy, pytest, dask), not a pyenv interpreter.
source "$NE_ROOT/scripts/env.sh"
export PYTHONPATH="$PYTHON_DIR${PYTHONPATH:+:$PYTHONPATH}"
cd "$NE_ROOT/test/python"
exec python3 -m pytest -q -rs -p no:cacheprovider --junitxml="$RESULT" -o junit_family=xunit1 .
