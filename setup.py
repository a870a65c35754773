# The Python package networked_estimation (src/networked_estimation) and its compiled module _core.
#
# Two builds read this file:
# - catkin (catkin_python_setup() in CMakeLists.txt): the package's Python files only; catkin builds
#   _core and the messages itself and installs them next to these files (docs/python.md).
# - pip (`pip install --no-build-isolation .`, through pyproject.toml's in-tree backend, which sets
#   NE_PIP_BUILD): the build without ROS (cmake/without_ros.cmake) compiles the core and _core with
#   plain CMake, and the wheel holds the package with _core. No ROS package is needed.
import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup

ROOT = pathlib.Path(__file__).resolve().parent

if os.environ.get("NE_PIP_BUILD") != "1":
    from catkin_pkg.python_setup import generate_distutils_setup

    setup(**generate_distutils_setup(packages=["networked_estimation"], package_dir={"": "src"}))
else:
    from setuptools.command.build_ext import build_ext

    class CMakeBuild(build_ext):
        """Builds networked_estimation._core with CMake (NE_WITH_ROS=OFF, no tools) and puts it where
        setuptools expects the extension. NE_JOBS: parallel compile jobs (default: the CPU count)."""

        def build_extension(self, ext):
            target = pathlib.Path(self.get_ext_fullpath(ext.name)).resolve()
            build = pathlib.Path(self.build_temp).resolve() / "cmake"
            build.mkdir(parents=True, exist_ok=True)
            jobs = os.environ.get("NE_JOBS") or str(os.cpu_count() or 1)
            subprocess.check_call(["cmake", "-S", str(ROOT), "-B", str(build), "-DNE_WITH_ROS=OFF",
                                   "-DNE_BUILD_TOOLS=OFF", "-DCMAKE_BUILD_TYPE=Release",
                                   "-DPython3_EXECUTABLE=" + sys.executable])
            subprocess.check_call(["cmake", "--build", str(build), "--target", "networked_estimation_python",
                                   "-j", jobs])
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(build / "python" / "networked_estimation" / "_core.so", target)

    version = re.search(r"<version>([^<]+)</version>", (ROOT / "package.xml").read_text()).group(1)
    setup(name="networked_estimation", version=version,
          description="State estimation over lossy networks: estimators, lossy links, stability analysis "
                      "and Monte Carlo (the ROS-free core of the ROS package networked_estimation)",
          license="BSD-3-Clause", python_requires=">=3.8", install_requires=["numpy"],
          packages=["networked_estimation"], package_dir={"": "src"},
          ext_modules=[Extension("networked_estimation._core", sources=[])],
          cmdclass={"build_ext": CMakeBuild}, zip_safe=False)
