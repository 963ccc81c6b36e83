# Sourced by the VIMS scripts: a ROS environment that works with Debian's ROS packages even
# when `python3` on PATH is a pyenv interpreter without the ROS modules.
export PATH=/usr/bin:/bin:$PATH
export PYENV_VERSION=system
export ROS_HOSTNAME=127.0.0.1
VIMS_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export VIMS_ROOT
export VIMS_BUILD="${VIMS_BUILD:-$VIMS_ROOT/_build}"
export ROS_HOME="${ROS_HOME:-$VIMS_BUILD/ros_home}"
