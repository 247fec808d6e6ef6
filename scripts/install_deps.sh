#!/usr/bin/env bash
# Installs hetslam's build and test dependencies from Debian 12 packages (as root, or with sudo).
set -euo pipefail
packages=(
  cmake g++ make pkg-config
  libceres-dev libeigen3-dev libsuitesparse-dev
  libopencv-dev libapriltag-dev
  libgflags-dev libgoogle-glog-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  time  # /usr/bin/time -v: peak memory in tests/bench/run_real_logs.sh
  # ROS 1 bags (core/ros_bag.h): Debian's rosbag_storage and the message headers, no ROS install.
  librosbag-storage-dev libroscpp-core-dev
  libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev libtf2-msgs-dev
  clang libclang-rt-14-dev  # libFuzzer targets of tests/fuzz (scripts/fuzz.sh, CI smoke run)
)
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install_deps.sh: run as root or install sudo" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps.sh: all ${#packages[@]} packages already installed"
  exit 0
fi
echo "install_deps.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
