# The Python package networked_estimation (src/networked_estimation), installed by catkin_python_setup()
# next to the compiled module _core and the generated messages (docs/python.md).
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["networked_estimation"], package_dir={"": "src"}))
