# Sourced by the repository's own scripts (build, test, demo, benchmarks), not meant for users'
# shells: the environment of scripts/env.sh, plus a sandbox of their own. They build in a catkin
# workspace inside the clone ($NE_WORKSPACE, default .ws/, git-ignored), keep ROS's logs and
# caches there instead of ~/.ros, run their private graphs on localhost, and flush log lines at once.
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WS="${NE_WORKSPACE:-$REPO/.ws}"
source "$REPO/scripts/env.sh"
export ROS_HOME="$WS/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
export ROS_HOSTNAME=localhost
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1

# The package folder of the workspace: a real folder named after the package holding one link per
# top-level entry of the repository (not one link to the repository itself: the workspace lives
# inside the repository, and rosrun's `find -L` would then loop through it).
link_package()
{
  local pkg="$WS/src/networked_estimation" entry name
  mkdir -p "$WS/src"
  [ -L "$pkg" ] && rm "$pkg"   # a link to the repository (older layout): replaced by the folder
  mkdir -p "$pkg"
  for entry in "$pkg"/* "$pkg"/.[!.]*; do
    [ -L "$entry" ] && [ ! -e "$entry" ] && rm "$entry"   # entries removed from the repository
  done
  for entry in "$REPO"/* "$REPO"/.ci; do
    [ -e "$entry" ] || continue
    name="$(basename "$entry")"
    ln -sfn "$entry" "$pkg/$name"
  done
}
