# Source this (`source scripts/env.sh`) to use Debian's ROS 1 from a shell where a pyenv python
# comes first on PATH: Debian's catkin, rostest, roslaunch and `#!/usr/bin/env python3` tools need
# Debian's python3 and its ROS modules, which a pyenv interpreter lacks. It removes pyenv's folders
# from PATH and sets PYENV_VERSION=system, and changes nothing else (no ROS_HOSTNAME, ROS_HOME or
# ROS_MASTER_URI: a multi-machine graph keeps its own network settings). Without pyenv it does
# nothing. On Noetic (/opt/ros/noetic) source /opt/ros/noetic/setup.bash instead.
case ":$PATH:" in
  *"/.pyenv/"*)
    PATH="$(printf %s "$PATH" | tr ':' '\n' | grep -v '/\.pyenv/' | paste -sd:)"
    export PATH
    export PYENV_VERSION=system
    ;;
esac
