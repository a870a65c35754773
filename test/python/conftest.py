# Shared helpers of the Python module's tests (run by test/test_python.sh through ctest): the repo's
# example files, and the command-line tools the results are compared with, bit for bit.
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(os.environ.get("NE_ROOT", pathlib.Path(__file__).resolve().parents[2]))
MODELS = ROOT / "config" / "models"
CHANNELS = ROOT / "config" / "channels"
ESTIMATORS = ROOT / "config" / "estimators"


def tools_dir():
    d = os.environ.get("NE_TOOLS")
    if not d or not (pathlib.Path(d) / "simulate").exists():
        pytest.fail("NE_TOOLS must name the folder of the built tools (simulate, replay, analyze, ...): "
                    "run the tests with test/test_python.sh")
    return pathlib.Path(d)


def tool(name, *args, check=True):
    """Runs a tool; returns (exit code, stdout, stderr)."""
    p = subprocess.run([str(tools_dir() / name)] + [str(a) for a in args], capture_output=True, text=True)
    if check and p.returncode != 0:
        pytest.fail(f"{name} {' '.join(map(str, args))} exited {p.returncode}: {p.stderr}")
    return p.returncode, p.stdout, p.stderr


def read_csv(path):
    """(header, rows as float64 with NaN for an empty cell): an independent reader of the tools' CSV."""
    lines = pathlib.Path(path).read_text().splitlines()
    header = lines[0].split(",")
    rows = [[float(c) if c not in ("", "-") else np.nan for c in line.split(",")] for line in lines[1:]]
    return header, np.array(rows, dtype=float).reshape(len(rows), len(header))


def columns(header, table, prefix):
    idx = [i for i, h in enumerate(header) if h.startswith(prefix) and h[len(prefix):].isdigit()]
    return table[:, idx]


def same(a, b):
    """Equal to the last bit (NaN where the other has NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
