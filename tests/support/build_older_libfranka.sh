#!/bin/sh
# Build an older libfranka's C++ examples for tests/clients/test_libfranka_cpp_older.py (and
# vacuum_object for test_libfranka_cpp_vacuum.py).
#
# Usage: build_older_libfranka.sh SOURCE_DIR BUILD_DIR
#
# SOURCE_DIR is a libfranka checkout the user supplies at a tag (0.9.2, 0.12.1, 0.13.6, 0.14.1,
# 0.15.3, 0.21.2) with its `common` submodule checked out at the commit that tag records, for
# example:
#   git clone --branch 0.13.6 --recurse-submodules https://github.com/frankarobotics/libfranka
# 0.20.5 to 0.21.2 record common 2e090a6, which the public libfranka-common does not hold (the
# submodule update fails). Check out the newest commit it does hold instead, d96c221 (robot
# protocol version 10; the commit 0.18.0 to 0.20.4 record):
#   git clone --branch 0.21.2 https://github.com/frankarobotics/libfranka
#   git clone https://github.com/frankarobotics/libfranka-common libfranka/common
#   git -C libfranka/common checkout d96c221
# The script prints which common commit it builds with beside the one the tag records.
# This script fetches nothing. It needs cmake (3.16 or later from 0.20.5 on), a C++ compiler,
# Poco and Eigen 3 (Debian: apt-get install cmake build-essential libpoco-dev libeigen3-dev).
# From 0.14 on libfranka also needs Pinocchio (its CMake config and what that config asks for:
# urdfdom and its headers, Boost, coal). Where the system has none, the PyPI wheels carry them:
#   python3 -m venv VENV && VENV/bin/pip install pin cmeel-urdfdom-headers
# then pass their prefix in the environment (cmake reads CMAKE_PREFIX_PATH from it):
#   CMAKE_PREFIX_PATH=VENV/lib/pythonX.Y/site-packages/cmeel.prefix build_older_libfranka.sh ...
# The examples then find those libraries by the build tree's RPATH; keep VENV while they run.
# From 0.15 on it also needs fmt (Debian: libfmt-dev); without it libfranka's CMake would
# download fmt, which this script forbids (FETCHCONTENT_FULLY_DISCONNECTED), so it fails.
# BUILD_DIR must lie outside this repository; afterwards it holds examples/<name>, and
#   FRANKA_SIM_LIBFRANKA_BUILDS=BUILD_DIR[:BUILD_DIR...]
# points the tests at it. Only the examples the tests run are built.
set -eu
if [ $# -ne 2 ]; then
    echo "usage: $0 SOURCE_DIR BUILD_DIR" >&2
    exit 2
fi
src=$(cd "$1" && pwd)
if [ ! -f "$src/common/include/research_interface/robot/service_types.h" ]; then
    echo "$src: no common/ submodule checked out (git submodule update --init)" >&2
    exit 1
fi
if recorded=$(git -C "$src" ls-tree HEAD common 2>/dev/null) && [ -n "$recorded" ]; then
    used="not a git checkout"
    if [ -e "$src/common/.git" ]; then
        used=$(git -C "$src/common" rev-parse HEAD)
    fi
    echo "common: $used (the checkout records $(echo "$recorded" | cut -f1 | cut -d' ' -f3))"
fi
mkdir -p "$2"
build=$(cd "$2" && pwd)
if [ -n "${CMAKE_PREFIX_PATH:-}" ]; then
    echo "CMAKE_PREFIX_PATH=$CMAKE_PREFIX_PATH"
fi
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTS=OFF -DBUILD_EXAMPLES=ON \
    -DFETCHCONTENT_FULLY_DISCONNECTED=ON
make -C "$build" -j"${JOBS:-2}" communication_test echo_robot_state generate_joint_position_motion \
    generate_cartesian_pose_motion cartesian_impedance_control grasp_object vacuum_object
