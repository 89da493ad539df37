"""What the ROS tests share: a private ROS domain on the loopback interface."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest


def private_ros_env(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, first: int, count: int
) -> dict[str, str]:
    """Set a private ROS domain (one of ``first`` .. ``first + count - 1``) on the loopback
    interface for this process, and return the environment for its children.

    Parameters
    ----------
    monkeypatch : pytest.MonkeyPatch
        Undoes the settings after the test.
    tmp_path : Path
        The test's folder (ROS's logs go there).
    first, count : int
        The domain ids this test file may use (files apart do not hear each other).

    Returns
    -------
    dict of str to str
        ``os.environ`` with the settings, for subprocesses.
    """
    env = {
        "ROS_DOMAIN_ID": str(first + (os.getpid() + int(time.time())) % count),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",  # Jazzy and later
        # Jazzy: unicast discovery on 127.0.0.1 (ROS_LOCALHOST_ONLY would override both and
        # relies on multicast on the loopback, which containers often lack)
        "ROS_STATIC_PEERS": "127.0.0.1",
        "ROS_LOG_DIR": str(tmp_path / "ros-log"),
    }
    if os.environ.get("ROS_DISTRO") == "humble":
        env["ROS_LOCALHOST_ONLY"] = "1"  # Humble has no discovery range
    else:
        monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    return {**os.environ, **env}
