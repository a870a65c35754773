# Shared by the benchmark scripts (sourced after workspace.sh): the built workspace's environment, a free
# port for a private master, and stopping a roslaunch cleanly.
if [ ! -f "$WS/devel/setup.bash" ]; then
  echo "no build in $WS: run scripts/build.sh first" >&2
  exit 1
fi
set +u
source "$WS/devel/setup.bash"
set -u
free_port()
{
  python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])'
}

# Stops one roslaunch started by run: SIGINT (it stops its nodes, then its master), then SIGTERM.
stop_launch()
{
  local pid="$1" i
  kill -INT "$pid" 2>/dev/null || true
  for i in $(seq 1 100); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.2
  done
  if kill -0 "$pid" 2>/dev/null; then
    echo "  roslaunch $pid still running 20 s after SIGINT: SIGTERM" >&2
    kill -TERM "$pid" 2>/dev/null || true
    sleep 5
    if kill -0 "$pid" 2>/dev/null; then
      echo "  roslaunch $pid: SIGKILL (its nodes may survive it)" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
  wait "$pid" 2>/dev/null || true
}

