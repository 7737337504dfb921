# Puts the venv and the built workspace on the current shell:  source env.sh
# Afterwards roslaunch, rosrun, rostest and python3 all use .venv/bin/python, which sees both
# Debian's ROS modules (system site-packages) and the pinned pip packages.
_landing_ws="$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")" && pwd)"
if [ ! -f "$_landing_ws/devel/setup.bash" ] || [ ! -x "$_landing_ws/.venv/bin/python" ]; then
  echo "env.sh: the workspace is not built yet; run 'make build' (or 'make demo') in $_landing_ws first" >&2
else
  export PATH="$_landing_ws/.venv/bin:$PATH"
  # shellcheck disable=SC1091
  source "$_landing_ws/devel/setup.bash"
  export MUJOCO_GL="${MUJOCO_GL:-osmesa}"
  export ROS_PYTHON_VERSION=3
fi
unset _landing_ws
