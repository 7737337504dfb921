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
  # Network: the ROS master and every node listen on this machine only (loopback), unless ROS_IP or ROS_HOSTNAME
  # is set before this file is sourced (docs/reliability.md, "Security"). roscpp's XML-RPC server ignores ROS_IP: the
  # preloaded liblanding_loopback_bind.so keeps it on loopback too (landing_msgs/src/loopback_bind.c).
  if [ -z "${ROS_IP:-}${ROS_HOSTNAME:-}" ] || [ "${LANDING_ROS_LOOPBACK:-}" = 1 ]; then
    export ROS_IP=127.0.0.1 LANDING_ROS_LOOPBACK=1
    unset ROS_HOSTNAME
    _landing_shim="$_landing_ws/devel/lib/liblanding_loopback_bind.so"
    case ":${LD_PRELOAD:-}:" in
      *":$_landing_shim:"*) ;;
      *) [ -f "$_landing_shim" ] && export LD_PRELOAD="$_landing_shim${LD_PRELOAD:+:$LD_PRELOAD}" ;;
    esac
    unset _landing_shim
    [ "${ROS_MASTER_URI:-}" = http://localhost:11311 ] && export ROS_MASTER_URI=http://127.0.0.1:11311  # no DNS
  else
    export LANDING_ROS_LOOPBACK=0
  fi
  export ROS_MASTER_URI="${ROS_MASTER_URI:-http://127.0.0.1:11311}"
fi
unset _landing_ws
