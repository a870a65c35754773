# docs/python.md and scripts/examples stay true: the three example scripts run and print what the
# guide shows, the guide's listings are the scripts' code, and the guide's other code blocks run
# (from a scratch folder that sees the repo's config/, in one session, as the guide says).
import ast
import os
import re
import subprocess
import sys

from conftest import ROOT, tools_dir

GUIDE = ROOT / "docs" / "python.md"
EXAMPLES = ROOT / "scripts" / "examples"


def python_blocks():
    return re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)


def script_code(name):
    """The script without its shebang and docstring, as the guide lists it."""
    text = (EXAMPLES / name).read_text()
    doc = ast.parse(text).body[0]
    return "\n".join(text.splitlines()[doc.end_lineno:]).lstrip("\n") + "\n"


def run_python(args, cwd):
    env = dict(os.environ, MPLBACKEND="Agg")  # files only, whatever display the machine has
    p = subprocess.run([sys.executable] + args, cwd=cwd, capture_output=True, text=True, env=env)
    assert p.returncode == 0, f"{args} exited {p.returncode}:\n{p.stdout}\n{p.stderr}"
    return p.stdout


def test_zhou_fig1_script_writes_its_figure(tmp_path):
    out = tmp_path / "fig.png"
    assert "wrote" in run_python([str(EXAMPLES / "zhou_fig1.py"), str(out)], tmp_path)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_stability_map_script_counts_every_cell(tmp_path):
    out = tmp_path / "map.png"
    text = run_python([str(EXAMPLES / "stability_map.py"), str(out)], tmp_path)
    counts = {kind: int(n) for n, kind in re.findall(r"(\d+) (stable|undecided|unstable)", text)}
    assert sum(counts.values()) == 40 * 40
    # the map shows both outcomes (the guide's figure: 512 stable, 1088 unstable)
    assert counts["stable"] > 0 and counts["unstable"] > 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_gilbert_elliott_script_grows_below_and_settles_above(tmp_path):
    text = run_python([str(EXAMPLES / "gilbert_elliott_recovery.py")], tmp_path)
    # r_c of a 1-D block is 1 - |alpha|^-2 (docs/stability.md 3.6); aoe_example's largest |alpha| is
    # 1.291 and the script prints 6 decimals
    r_c = float(re.search(r"r_c = ([0-9.]+)", text).group(1))
    assert abs(r_c - (1 - 1 / 1.291 ** 2)) < 1e-6
    rows = [line.split() for line in text.splitlines() if re.match(r"\s+0\.\d{3}\s", line)]
    assert [row[-1] for row in rows] == ["unstable", "stable"]
    below, above = ([float(v) for v in row[1:6]] for row in rows)
    # below r_c, E[P] grows like (|alpha|^2 (1 - r))^k = 1.5^k (1.5^80 = 1e14): a million is far inside
    assert below[-1] / below[0] > 1e6
    # above it, the mean over 5000 runs of a bounded tr P (about 41) moves by a few per cent at most
    assert max(above) / min(above) < 1.5


def test_guide_lists_the_scripts_code():
    blocks = python_blocks()
    for name in ("zhou_fig1.py", "stability_map.py"):
        assert script_code(name) in blocks, f"docs/python.md does not list scripts/examples/{name} as it is"
    # the guide gives the model's path from the repository root; the script finds it from its own place
    code = script_code("gilbert_elliott_recovery.py").replace("from pathlib import Path\n\n", "")
    code = code.replace('Path(__file__).resolve().parents[2] / "config/', '"config/')
    assert code in blocks, "docs/python.md does not list scripts/examples/gilbert_elliott_recovery.py as it is"


def test_guide_code_blocks_run(tmp_path):
    (tmp_path / "config").symlink_to(ROOT / "config")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    listed = {script_code(name) for name in ("zhou_fig1.py", "stability_map.py")}
    # the listings run as scripts above; the dask recipe in test_dask.py
    blocks = [b for b in python_blocks() if b not in listed and "dask" not in b and "recovery_exact" not in b]
    session = "\n".join(blocks).replace("/tmp/", f"{scratch}/")
    # the guide's simulate command writes the file that load_replay_input() reads
    subprocess.run([str(tools_dir() / "simulate"), "--model", "config/models/tracking_2d.yaml",
                    "--channel", "gnss=config/channels/wifi_bursty.yaml",
                    "--channel", "camera=config/channels/bernoulli_0.2.yaml",
                    "--steps", "2000", "--seed", "1", "--out", str(scratch / "run")],
                   cwd=tmp_path, check=True, capture_output=True)
    assert "--out /tmp/run" in GUIDE.read_text()
    out = run_python(["-c", session], tmp_path)
    assert "True True" in out  # load_replay_input() == simulate()
