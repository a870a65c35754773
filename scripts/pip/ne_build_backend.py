"""pyproject.toml's build backend: setuptools' own, with NE_PIP_BUILD set so that setup.py builds the
package without ROS (the compiled module with plain CMake) rather than for catkin."""
import os

os.environ["NE_PIP_BUILD"] = "1"

from setuptools.build_meta import *  # noqa: E402,F401,F403
