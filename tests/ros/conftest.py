"""What the ROS tests share: a private ROS domain on the loopback interface."""

from __future__ import annotations

import itertools
import os
import time
from pathlib import Path

import pytest

# where this process starts in its share of a domain range: differs between runs on one machine
_RUN_OFFSET = os.getpid() + int(time.time())
_domains_given = itertools.count()
DISCOVERY_XML = Path(__file__).with_name("fastdds_discovery.xml")


def xdist_worker() -> tuple[int, int]:
    """This process's pytest-xdist worker and the run's number of workers.

    Returns
    -------
    tuple of (int, int)
        The worker's index (``gw1``: 1) and the worker count; ``(0, 1)`` without xdist.
    """
    name = os.environ.get("PYTEST_XDIST_WORKER", "")
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    return (int(name[2:]) if name.startswith("gw") else 0), workers


def private_ros_env(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, first: int, count: int
) -> dict[str, str]:
    """Set a private ROS domain (one of ``first`` .. ``first + count - 1``) on the loopback
    interface for this process, and return the environment for its children.

    Each pytest-xdist worker draws from a slice of the range of its own, so tests running at
    once in two workers never share a domain; within a worker each call takes the slice's next
    domain, so a test never hears the nodes of the test before it.

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
    worker, workers = xdist_worker()
    share = count // workers
    assert share >= 1, f"{count} ROS domains for {workers} pytest workers"
    domain = first + worker * share + (_RUN_OFFSET + next(_domains_given)) % share
    env = {
        "ROS_DOMAIN_ID": str(domain),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",  # Jazzy and later
        # Jazzy: unicast discovery on 127.0.0.1 (ROS_LOCALHOST_ONLY would override both and
        # relies on multicast on the loopback, which containers often lack)
        "ROS_STATIC_PEERS": "127.0.0.1",
        "ROS_LOG_DIR": str(tmp_path / "ros-log"),
        # announcements every 0.25 s, not 3 s: a process started later is heard at once
        "FASTRTPS_DEFAULT_PROFILES_FILE": str(DISCOVERY_XML),  # Fast DDS 2 (Humble, Jazzy)
        "FASTDDS_DEFAULT_PROFILES_FILE": str(DISCOVERY_XML),  # Fast DDS 3
    }
    if os.environ.get("ROS_DISTRO") == "humble":
        env["ROS_LOCALHOST_ONLY"] = "1"  # Humble has no discovery range
    else:
        monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    return {**os.environ, **env}
