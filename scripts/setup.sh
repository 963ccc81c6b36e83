#!/bin/bash
# Installs everything VIMS needs from Debian bookworm's own packages (ROS 1 included; there
# is no /opt/ros). Idempotent: when every package is already installed it does nothing.
set -eo pipefail

PACKAGES=(
  build-essential cmake git clang-format
  ros-core-dev rosbash
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev libcv-bridge-dev libimage-transport-dev
  libnav-msgs-dev libvisualization-msgs-dev
  libceres-dev libopencv-dev libeigen3-dev libyaml-cpp-dev
  googletest libgtest-dev libgmock-dev libbenchmark-dev
  python3-rosbag python3-roslaunch python3-rostest python3-rostopic python3-rosnode python3-rosservice
  python3-geometry-msgs python3-sensor-msgs python3-nav-msgs python3-visualization-msgs
  rviz xvfb xauth imagemagick
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "[setup] all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" != "0" ]; then
  command -v sudo >/dev/null || { echo "[setup] need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
echo "[setup] installing ${#missing[@]} Debian packages: ${missing[*]}"
$SUDO apt-get update -q
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
