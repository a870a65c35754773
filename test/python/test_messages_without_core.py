# The package's ROS messages and services import without the compiled module: rostopic and rosservice
# import networked_estimation.msg / .srv, and a workspace that built only the nodelets
# (scripts/demo.sh) has no networked_estimation._core. A copy of the package's Python folder with the
# generated msg and srv but no _core stands for that workspace.
import os
import pathlib
import subprocess
import sys

import networked_estimation.msg
import networked_estimation.srv

from conftest import ROOT

CHECK = """
import networked_estimation.msg, networked_estimation.srv
print(networked_estimation.srv.SetPose._type, networked_estimation.msg.Estimate._type)
import networked_estimation as ne
try:
    ne.Model
except ImportError as e:
    print("ImportError:", e)
"""


def test_messages_import_without_the_compiled_module(tmp_path):
    package = tmp_path / "networked_estimation"
    package.mkdir()
    (package / "__init__.py").write_text((ROOT / "src" / "networked_estimation" / "__init__.py").read_text())
    (package / "msg").symlink_to(pathlib.Path(networked_estimation.msg.__file__).parent)
    (package / "srv").symlink_to(pathlib.Path(networked_estimation.srv.__file__).parent)
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    p = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True, env=env, cwd=str(tmp_path))
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0] == "networked_estimation/SetPose networked_estimation/Estimate"
    # The module's own functions say what is missing.
    assert lines[1].startswith("ImportError: networked_estimation.Model: the compiled module "
                               "networked_estimation._core is not available"), lines[1]
