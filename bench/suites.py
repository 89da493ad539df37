"""The suites of ``jackson bench``: each suite's name and the function that runs it.

:data:`SUITES` is the registry, in the order the suites run. Each entry imports its suite's
module when it is called, so naming the suites (``jackson bench --help``, the parser's choices)
costs no import of the code they measure. A suite that measures one layer on its own sits
beside that layer's code (``protocol/bench.py``, ``sim/bench.py``, ``sim/bench_lidar.py``,
``experiments/bench.py``, ``experiments/bench_stage3.py``, ``experiments/bench_mapping.py``);
one that runs several layers together, or the command's own processes, sits in this package.
A new suite adds its module with ``run(quick: bool) -> list[BenchResult]`` and one entry here.
"""

from __future__ import annotations

from collections.abc import Callable

from jackson.common.bench import BenchResult

Suite = Callable[[bool], list[BenchResult]]
"""A suite's entry point: ``quick`` asks for smaller workloads; it returns the suite's figures."""


def _protocol(quick: bool) -> list[BenchResult]:
    """The wire codec against pymavlink (:mod:`jackson.protocol.bench`)."""
    from jackson.protocol.bench import run

    return run(quick)


def _firmware(quick: bool) -> list[BenchResult]:
    """The firmware core built natively: CPU, code size (:mod:`jackson.bench.firmware`)."""
    from jackson.bench.firmware import run

    return run(quick)


def _twin(quick: bool) -> list[BenchResult]:
    """The twin against bare pymunk stepping the same bodies (:mod:`jackson.sim.bench`)."""
    from jackson.sim.bench import run

    return run(quick)


def _lidar(quick: bool) -> list[BenchResult]:
    """The LiDAR model against pymunk's ray queries (:mod:`jackson.sim.bench_lidar`)."""
    from jackson.sim.bench_lidar import run

    return run(quick)


def _lockstep(quick: bool) -> list[BenchResult]:
    """The lockstep over the pty against the twin alone (:mod:`jackson.bench.lockstep`)."""
    from jackson.bench.lockstep import run

    return run(quick)


def _host(quick: bool) -> list[BenchResult]:
    """The host's CPU per frame and command latency (:mod:`jackson.bench.host`)."""
    from jackson.bench.host import run

    return run(quick)


def _daemon(quick: bool) -> list[BenchResult]:
    """The ``jackson daemon`` process's CPU on the twin (:mod:`jackson.bench.daemon`)."""
    from jackson.bench.daemon import run

    return run(quick)


def _sil(quick: bool) -> list[BenchResult]:
    """``jackson run`` as a user runs it (:mod:`jackson.bench.sil`)."""
    from jackson.bench.sil import run

    return run(quick)


def _soak(quick: bool) -> list[BenchResult]:
    """Resident memory over a patrol (:mod:`jackson.bench.soak`)."""
    from jackson.bench.soak import run

    return run(quick)


def _campaign(quick: bool) -> list[BenchResult]:
    """The paper's campaigns' wall time on the twin (:mod:`jackson.experiments.bench`)."""
    from jackson.experiments.bench import run

    return run(quick)


def _stage3(quick: bool) -> list[BenchResult]:
    """The Stage 3 cycles against their periods (:mod:`jackson.experiments.bench_stage3`)."""
    from jackson.experiments.bench_stage3 import run

    return run(quick)


def _mapping(quick: bool) -> list[BenchResult]:
    """Robot-seconds mapped per CPU-second (:mod:`jackson.experiments.bench_mapping`)."""
    from jackson.experiments.bench_mapping import run

    return run(quick)


def _ros(quick: bool) -> list[BenchResult]:
    """The ROS 2 bridge's latency (:mod:`jackson.bench.ros`)."""
    from jackson.bench.ros import run

    return run(quick)


SUITES: dict[str, Suite] = {
    "protocol": _protocol,
    "firmware": _firmware,
    "twin": _twin,
    "lidar": _lidar,
    "lockstep": _lockstep,
    "host": _host,
    "daemon": _daemon,
    "sil": _sil,
    "soak": _soak,
    "campaign": _campaign,
    "stage3": _stage3,
    "mapping": _mapping,
    "ros": _ros,
}
"""Suite name -> the function that runs it, in the order ``jackson bench`` runs them."""
