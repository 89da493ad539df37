"""Where a campaign's trials run: the local process pool, or a Ray cluster (``--cluster``).

:func:`map_trials` maps a trial function over the trial specs and yields each result as its
trial finishes, with the spec's index so the caller can tell which. Without a cluster it is the
local pool every campaign has always used (``--workers`` processes, ``forkserver``); with one it
submits one Ray task per trial:

``local``
    a Ray instance started on this machine with ``--workers`` CPUs, stopped at the end;
``auto``
    the running cluster this machine belongs to (``ray start --head`` / ``ray start
    --address``), ``ray.init(address="auto")``;
``ray://HOST:PORT``
    a cluster's head reached through Ray Client.

A trial is a pure function of its spec (its seed is in the spec), so a trial gives the same
result on a Ray worker as in a pool process. Run folders: each trial writes its folder where its
spec says, so every node must see the report folder at the same path (one machine, or a shared
filesystem such as NFS mounted at the same path on every node); a task refuses to run on a
node that does not see it (:class:`ClusterError`), rather than writing a report's files where
the driver cannot read them. The trial's metrics come back as the task's return value.

Ray is the optional ``cluster`` extra: ``pip install 'jackson[cluster]'``.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import re
import signal
import socket
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from pathlib import Path
from types import FrameType, ModuleType
from typing import Any, TypeVar

from jackson.common.errors import JacksonError

S = TypeVar("S")
R = TypeVar("R")

CLUSTER_FORMS = ("local", "auto", "ray://HOST:PORT")
INSTALL_HINT = "--cluster needs the cluster extra: pip install 'jackson[cluster]'"
_CLIENT = re.compile(r"^ray://[^\s:/]+:\d{1,5}$")


class ClusterError(JacksonError):
    """A cluster cannot run the campaign: unreachable, or a node without the report folder."""


class RayMissingError(ClusterError):
    """``--cluster`` was asked for but Ray (the ``cluster`` extra) is not installed."""


class ClusterUnreachableError(ClusterError):
    """The cluster's address answers not (no running cluster, a wrong host or port)."""


def parse_cluster(text: str) -> str:
    """Check a ``--cluster`` value: ``local``, ``auto`` or ``ray://HOST:PORT``.

    Parameters
    ----------
    text : str
        The value given.

    Returns
    -------
    str
        ``text`` unchanged.

    Raises
    ------
    ValueError
        Any other form.
    """
    if text in ("local", "auto") or _CLIENT.match(text):
        return text
    raise ValueError(f"{text!r}: give one of {', '.join(CLUSTER_FORMS)}")


def import_ray() -> ModuleType:
    """The ``ray`` module.

    Returns
    -------
    module
        ``ray``.

    Raises
    ------
    RayMissingError
        Ray is not installed.
    """
    try:
        import ray
    except ImportError as exc:
        raise RayMissingError(INSTALL_HINT) from exc
    return ray


@contextmanager
def ray_session(cluster: str, *, num_cpus: int) -> Iterator[ModuleType]:
    """Connect to ``cluster`` (unless this process is already connected to one) for the
    ``with`` block; a connection made here is closed at its end (a ``local`` instance stops).

    Parameters
    ----------
    cluster : str
        ``local``, ``auto`` or ``ray://HOST:PORT`` (:func:`parse_cluster`).
    num_cpus : int
        CPUs of a ``local`` instance, i.e. trials at once; a cluster has its own.

    Yields
    ------
    module
        ``ray``, connected.

    Raises
    ------
    RayMissingError
        Ray is not installed.
    ClusterUnreachableError
        Nothing answers at the address.
    """
    ray = import_ray()
    if ray.is_initialized():
        yield ray
        return
    if cluster == "auto":
        probe_gcs()
    options: dict[str, Any] = {"logging_level": logging.ERROR, "log_to_driver": False}
    try:
        with warnings.catch_warnings():  # Ray Client's timeout warns before it raises
            warnings.simplefilter("ignore")
            if cluster == "local":
                ray.init(num_cpus=num_cpus, include_dashboard=False, **options)
            else:
                ray.init(address=cluster, **options)
    except (ConnectionError, TimeoutError, RuntimeError, ValueError) as exc:
        first = next((line for line in str(exc).splitlines() if line.strip()), type(exc).__name__)
        raise ClusterUnreachableError(
            f"--cluster {cluster}: no Ray cluster there ({first.strip()})"
        ) from exc
    try:
        yield ray
    finally:
        ray.shutdown()


def probe_gcs(timeout_s: float = 5.0) -> None:
    """For ``auto``: open a TCP connection to the cluster's GCS (``RAY_ADDRESS``, or the
    cluster this machine last started) first, since ``ray.init`` retries an address where
    nothing answers for many minutes.

    Parameters
    ----------
    timeout_s : float
        How long the GCS has to accept [s].

    Raises
    ------
    ClusterUnreachableError
        Nothing accepts at the address.
    """
    try:
        from ray._private.services import get_ray_address_from_environment

        address = get_ray_address_from_environment("auto", None)
    except Exception:  # no address known: ray.init says so
        return
    if address is None:
        return
    host, _, port = address.rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s):
            pass
    except (OSError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ClusterUnreachableError(
            f"--cluster auto: no Ray cluster there (nothing answers at {address}: {why})"
        ) from exc


def run_on_node(fn: Callable[[S], R], spec: S, folder: str | None) -> R:
    """One trial in a Ray worker: ``fn(spec)``, once the node is seen to hold the report folder.

    Parameters
    ----------
    fn : callable
        The trial function (importable by name: the worker imports it).
    spec : object
        Its argument.
    folder : str or None
        The report folder (absolute), which must exist on the node; None: no check.

    Returns
    -------
    object
        ``fn(spec)``.

    Raises
    ------
    ClusterError
        The node does not see ``folder``.
    """
    if folder is not None and not Path(folder).is_dir():
        raise ClusterError(
            f"node {socket.gethostname()} does not see the report folder {folder}: every node "
            "needs it at the same path (a shared filesystem)"
        )
    return fn(spec)


def map_trials(
    fn: Callable[[S], R],
    specs: Sequence[S],
    *,
    workers: int = 2,
    cluster: str | None = None,
    folder: Path | None = None,
) -> Iterator[tuple[int, R]]:
    """``fn`` over ``specs`` in parallel; each result as soon as its trial is done.

    Parameters
    ----------
    fn : callable
        The trial function, a module-level function (worker processes import it by name).
    specs : sequence
        One argument per trial; paths in them must be absolute with a ``cluster``.
    workers : int
        Worker processes of the local pool, or CPUs of a ``local`` Ray instance.
    cluster : str or None
        None: the local pool; else ``local``, ``auto`` or ``ray://HOST:PORT`` (one Ray task
        per trial, :func:`ray_session`).
    folder : Path or None
        The report folder every Ray node must see (:func:`run_on_node`).

    Yields
    ------
    tuple of (int, object)
        The spec's index in ``specs`` and ``fn``'s result, in the order trials finish.

    Raises
    ------
    RayMissingError, ClusterUnreachableError, ClusterError
        With a cluster: Ray missing, nothing at the address, a node without ``folder``.
    """
    with _terminate_raises():
        if cluster is None:
            yield from _map_pool(fn, specs, workers)
        else:
            yield from _map_ray(fn, specs, workers, cluster, folder)


class Terminated(SystemExit):
    """SIGTERM reached a campaign: raised in its main thread so the trials are stopped."""


@contextmanager
def _terminate_raises() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` (exit status 143) in the main thread for the block,
    so the pool's workers and Ray's tasks are stopped on the way out, not left running."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_term(signum: int, frame: FrameType | None) -> None:
        for pool in list(_RUNNING_POOLS):  # before anything else can run: their trials die now
            _stop_workers(pool)
        raise Terminated(128 + signal.SIGTERM)

    previous = signal.signal(signal.SIGTERM, on_term)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _map_pool(fn: Callable[[S], R], specs: Sequence[S], workers: int) -> Iterator[tuple[int, R]]:
    """:func:`map_trials` on the local pool. Leaving early (an error, Ctrl-C, SIGTERM, the
    caller closing the generator) stops the workers at once: their trials die with them, none
    is left writing into the report folder."""
    ctx = mp.get_context("forkserver")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
    _RUNNING_POOLS.add(pool)
    done = False
    try:
        futures = {pool.submit(fn, s): k for k, s in enumerate(specs)}
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
        done = True
    finally:
        _RUNNING_POOLS.discard(pool)
        if not done:
            _stop_workers(pool)
        pool.shutdown(wait=True)


_RUNNING_POOLS: set[ProcessPoolExecutor] = set()


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Cancel the pool's queued trials and terminate its worker processes (their trials with
    them), waiting for each to end."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # no public handle
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        proc.terminate()
    for proc in procs:
        proc.join(timeout=10)


def _map_ray(
    fn: Callable[[S], R],
    specs: Sequence[S],
    workers: int,
    cluster: str,
    folder: Path | None,
) -> Iterator[tuple[int, R]]:
    """:func:`map_trials` on a Ray cluster: one task per trial; tasks still pending when the
    caller leaves are cancelled."""
    with ray_session(cluster, num_cpus=workers) as ray:
        task = ray.remote(num_cpus=1, max_retries=0)(run_on_node)
        where = str(folder.resolve()) if folder is not None else None
        refs = {task.remote(fn, s, where): k for k, s in enumerate(specs)}
        pending = list(refs)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayTaskError as exc:
                        if isinstance(exc.cause, ClusterError):
                            raise ClusterError(str(exc.cause)) from None
                        raise
                    yield refs[ref], result
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)
