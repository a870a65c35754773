# Sourced by the other scripts: a clean environment for Debian's ROS 1 (see README "Environment").
# Strips pyenv from PATH (its python lacks Debian's ROS modules) and keeps ROS's files in the
# workspace instead of the home folder.
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WS="${NE_WORKSPACE:-$REPO/.ws}"
PATH="$(printf %s "$PATH" | tr ':' '\n' | grep -v '/\.pyenv/' | paste -sd:)"
export PATH
export PYENV_VERSION=system
export ROS_HOME="$WS/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
export ROS_HOSTNAME=localhost
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1
