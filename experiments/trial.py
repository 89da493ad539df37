"""One trial on the twin: the real host daemon drives a mission against the twin over a pty.

The twin runs in a thread of this process in lockstep; the host is the daemon's own classes
(serial transport on the pty, PCA9685 driver on the twin's I2C socket), so a trial exercises
exactly what runs on the robot. A trial writes the daemon's run folder plus the twin's ground
truth (``ground_truth.csv``, every physics step) and returns its metrics.

A trial's faults (``TrialSpec.faults``, injected besides the robot file's:
:mod:`jackson.sim.faults`) ride on the twin into :func:`twin_session`; meta.json lists their
schedule and metrics.json what each injected (``faults``).

A trial's time limit is the mission's own, in simulated (MCU) time (the daemon's mission guard:
square 150 s, figure-eight 300 s, navigation 180 s); the wall clock is only a backstop, ten
times that budget (:func:`wall_backstop_s`), for a host that runs without end. A lockstep that
stands still (:func:`twin_session`) ends the trial after ``TrialSpec.stall_s`` (10 s).
A trial cut either way says so in metrics.json: ``failure`` is ``not ended: lockstep stalled:
...`` or ``not ended: wall-clock backstop: ...`` (:func:`cut_reason`).
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml
from numpy.typing import NDArray

from jackson.common.errors import JacksonError
from jackson.common.threads import Watch, record
from jackson.common.threads import start as start_thread
from jackson.experiments import metrics as m
from jackson.experiments.run_csv import read_csv, write_ground_truth
from jackson.experiments.stall_retry import retry_stalled
from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.output import MotorOutput, Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import HostConfig, dump_config, load_config
from jackson.host.control.guard import MISSION_TIMEOUT_S
from jackson.host.daemon import Daemon
from jackson.host.transport import STALL_S, SerialTransport

if TYPE_CHECKING:
    from jackson.sim.faults import FaultSpec

MISSIONS = ("square", "figure8")
WALL_BACKSTOP_FACTOR = 10.0  # the wall-clock backstop over a mission's MCU-time budget


def wall_backstop_s(mission: str, timeout_s: float | None = None) -> float:
    """The wall-clock backstop of a trial of ``mission`` [s]: ten times its MCU-time limit.

    Parameters
    ----------
    mission : str
        ``square``, ``figure8`` or ``navigate``.
    timeout_s : float or None
        The mission's own limit when it has one (a navigation's route,
        :func:`jackson.host.control.guard.route_timeout_s`) [s of MCU time].

    Returns
    -------
    float
        Wall seconds after which the trial is stopped: 1500 s for the square, 3000 s for the
        figure-eight, 1800 s for a navigation. A run on a machine ten times slower than real
        time still ends on its own limit first.
    """
    return WALL_BACKSTOP_FACTOR * (MISSION_TIMEOUT_S[mission] if timeout_s is None else timeout_s)


def cut_reason(daemon: Daemon, mission: str, twin_stalled: str | None = None) -> str | None:
    """Why a trial was cut before its mission ended, or None when it was not.

    Parameters
    ----------
    daemon : Daemon
        The trial's daemon, after ``run()``.
    mission : str
        The mission's name (its wall-clock backstop, :func:`wall_backstop_s`).
    twin_stalled : str or None
        The twin's stall line, when it gave up (``TwinRunner.stalled``).

    Returns
    -------
    str or None
        ``not ended: lockstep stalled: ...`` (the twin's line when it gave up first, else the
        host's) or ``not ended: wall-clock backstop: ...``.
    """
    stalled = twin_stalled or daemon.stalled
    if stalled is not None:
        return f"not ended: {stalled}"
    if daemon.wall_limit_hit:
        t = daemon.core.t_s
        at = f" at {t:.2f} s of MCU time" if t is not None else " before the first frame"
        return (
            f"not ended: wall-clock backstop: {wall_backstop_s(mission):.0f} s of wall time "
            f"passed{at} (the mission's limit is {MISSION_TIMEOUT_S[mission]:.0f} s of MCU time)"
        )
    return None


@dataclass
class TwinSession:
    """The twin in a thread of this process, in lockstep, and the host's links to it.

    Attributes
    ----------
    runner : TwinRunner
        The twin's loop (MCU, I2C socket, LiDAR pty).
    cfg : HostConfig
        The host configuration with the PCA9685 on the twin's I2C socket.
    transport : SerialTransport
        The daemon's serial link, open on the twin's MCU pty.
    lidar : RplidarDriver or None
        The host's RPLIDAR driver, scanning the twin's emulated sensor (with ``lidar=True``).
    pca : Pca9685
        The PCA9685 driver, initialised.
    """

    runner: Any
    cfg: HostConfig
    transport: SerialTransport
    lidar: Any
    pca: Pca9685

    def output(self, send: Any) -> MotorOutput:
        """The daemon's motor output: the PCA9685 over the twin's I2C socket."""
        p = self.cfg.pca9685
        return Pca9685Output(self.pca, p.left, p.right, p.stby_channel)


@contextmanager
def twin_session(
    twin: Any,
    cfg: HostConfig,
    *,
    lidar: bool = False,
    stall_s: float = STALL_S,
    lidar_mode: str | None = None,
) -> Iterator[TwinSession]:
    """Run ``twin`` in lockstep in a thread and open the host's links to it; all closed at the
    end (the twin stops). The twin's faults (``Twin(..., faults=...)`` and its robot file's)
    act as it runs, the link faults on the MCU's pty the daemon reads.

    The twin waits for its host's HEARTBEAT however long the host works on a frame (no
    wall-clock timeout): a process the machine keeps from running (a busy machine; Ray runs
    its workers niced) must not see its world move on without its host. With a 5 s timeout,
    5 of 180 maze runs on a local Ray instance at load 5 lost their LiDAR that way ("no scan
    for 1.00 s") and failed where the pool's completed.

    What ends a session that stands still is a lockstep stall: both ends waiting for each other
    for ``stall_s`` of wall time (the twin for a HEARTBEAT, the host for a telemetry frame), and
    then doing no work (:mod:`jackson.common.liveness`: the CPU time of the other's thread,
    ``TwinRunner.host_thread``, ``SerialTransport.twin_thread``). Each
    end sees whether the other waits or works (``TwinRunner(host_waiting=...)``,
    ``SerialTransport.peer_waiting``), so a slow or starved end is never taken for a stopped
    one. The twin then gives up (``runner.stalled``) and keeps serving the links without moving
    its clock, and the daemon (which takes the transport's ``stall_s``) aborts on the stall:
    it brakes through the PCA9685 and says SHUTDOWN (:attr:`Daemon.run`'s status 75).

    With ``lidar``, the host's driver starts ``lidar_mode`` (None: the densest, as the daemon
    does; :meth:`~jackson.host.lidar.rplidar.RplidarDriver.start`)."""
    from jackson.host.lidar.rplidar import RplidarDriver
    from jackson.sim.runner import TwinRunner
    from jackson.sim.twin import trial_boot_id

    with tempfile.TemporaryDirectory(prefix="jackson-trial-") as tmp, Watch() as watch:
        sock = Path(tmp) / "i2c.sock"
        runner = TwinRunner(
            twin,
            i2c_path=sock,
            heartbeat_timeout_s=math.inf,
            lidar=lidar,
            stall_s=stall_s,
            boot_id=trial_boot_id(twin.seed),  # the seed's: the same INFO in every run of it
        )
        cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=f"unix:{sock}"))
        transport = SerialTransport(runner.serial_path, cfg.serial.baudrate)
        transport.stall_s = stall_s
        transport.peer_waiting = lambda: runner.waiting_since
        runner.host_waiting = lambda: transport.waiting_since
        stop = threading.Event()

        def twin_loop() -> None:
            try:
                runner.run(None, stop)
            except JacksonError as exc:  # the daemon aborts on it (common/threads.py)
                record("twin", exc)
            runner.serve(stop)  # after a stall or a failure: the host's brake and SHUTDOWN land

        thread = start_thread(twin_loop, "twin")  # its failure ends the daemon's run
        # each end judges the other by its thread's CPU time; the daemon runs in this thread
        assert thread.native_id is not None
        transport.twin_thread(thread.native_id)
        runner.host_thread(threading.get_native_id())
        driver = None
        try:
            pca = Pca9685(open_bus(cfg.pca9685.bus), cfg.pca9685.address)
            pca.init(cfg.pca9685.frequency_hz)
            if lidar:
                assert runner.lidar_path is not None
                driver = RplidarDriver(runner.lidar_path)
                driver.start(lidar_mode)
            transport.open(reader_thread=False)
            yield TwinSession(runner, cfg, transport, driver, pca)
        finally:
            transport.close()
            if driver is not None:
                driver.close()
            stop.set()
            thread.join(timeout=30)
            runner.close()
        watch.check()  # the twin's thread died: one line (ThreadFailedError), exit status 1


@dataclass(frozen=True)
class TrialSpec:
    """One trial: a mission on a robot file in a world, a seed, where to write.

    Attributes
    ----------
    faults : tuple of FaultSpec
        Faults injected besides the robot file's (:mod:`jackson.sim.faults`).
    stall_s : float
        Wall seconds both ends of the lockstep may wait for each other before the trial is cut
        as stalled (:func:`twin_session`).
    """

    mission: str
    index: int
    seed: int
    robot: str
    world: str
    out: Path
    config: Path | None = None
    faults: tuple[FaultSpec, ...] = ()
    stall_s: float = STALL_S


def run_trial(spec: TrialSpec, *, retry_stall: bool = True) -> dict[str, Any]:
    """Drive one mission on the twin and return its metrics (also written to metrics.json);
    a run cut by a lockstep stall is run once more (:mod:`jackson.experiments.stall_retry`)
    unless ``retry_stall`` is False."""
    if not retry_stall:
        return _run_trial_once(spec)
    return retry_stalled(_run_trial_once, spec, spec.out)


def _run_trial_once(spec: TrialSpec) -> dict[str, Any]:
    """One run of :func:`run_trial`."""
    from jackson.sim.config import load_robot, load_world
    from jackson.sim.faults import schedule
    from jackson.sim.twin import Twin

    run_dir = spec.out
    run_dir.mkdir(parents=True, exist_ok=True)
    cfg = load_config(spec.config) if spec.config else HostConfig()
    twin = Twin(
        load_world(spec.world),
        load_robot(spec.robot),
        lidar=False,
        seed=spec.seed,
        faults=spec.faults,
    )
    conditions = trial_conditions(twin.trial)
    faults = twin.faults.faults if twin.faults is not None else ()
    wall0 = time.perf_counter()
    with twin_session(twin, cfg, stall_s=spec.stall_s) as session:
        cfg = session.cfg
        (run_dir / "config.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
        meta = {
            "mission": spec.mission,
            "trial": spec.index,
            "seed": spec.seed,
            "robot": spec.robot,
            "world": spec.world,
            "twin_trial": conditions,
            "faults": schedule(faults),
        }
        daemon = Daemon(
            cfg,
            session.output,
            session.transport,
            mission_name=spec.mission,
            run_folder=run_dir,
            meta=meta,
        )
        daemon.run(max_s=wall_backstop_s(spec.mission))
        wall = time.perf_counter() - wall0
        cut = cut_reason(daemon, spec.mission, session.runner.stalled)
    done = bool(daemon.core.mission is not None and daemon.core.mission.done)
    # the truth up to the host's last frame: the twin may run a few steps more in real time
    # between the host's exit and its own stop, as many as the machine's load allows
    t_host = daemon.core.t_s if daemon.core.t_s is not None else math.inf
    truth = [s for s in twin.truth_log if s.t_s <= t_host + 1e-9]
    write_ground_truth(run_dir / "ground_truth.csv", truth)
    result = trial_metrics(run_dir, spec.mission)
    result.update(
        trial=spec.index,
        seed=spec.seed,
        completed=done,
        failure=None if done else cut or daemon.core.abort_reason,
        wall_s=wall,
        collisions=twin.collisions,
        sim_s=twin.t_s,
        real_time_factor=twin.t_s / wall if wall > 0 else math.inf,
        twin_trial=conditions,
        faults=twin.faults.record() if twin.faults is not None else [],
    )
    (run_dir / "metrics.json").write_text(__import__("json").dumps(result, indent=2) + "\n")
    return result


def trial_conditions(trial: Any) -> dict[str, Any]:
    """A twin's per-trial draws as plain data, for a trial's metrics and meta.

    Parameters
    ----------
    trial : TrialConditions
        ``Twin.trial``: supply voltage, wheel radii, encoder scales, turn-on gyro bias, floor.

    Returns
    -------
    dict
        ``dataclasses.asdict`` of the draws, the friction field's cells (128 x 128 factors)
        summarised by their extremes and SD [1] beside its resolution and origin [m]; ``floor``
        is None on a uniform floor.
    """
    floor = trial.floor
    out = dataclasses.asdict(dataclasses.replace(trial, floor=None))
    if floor is not None:
        cells = np.asarray(floor.cells, dtype=float)
        out["floor"] = {
            "resolution_m": floor.resolution_m,
            "origin_x_m": floor.origin_x_m,
            "origin_y_m": floor.origin_y_m,
            "mu_factor_min": float(cells.min()),
            "mu_factor_max": float(cells.max()),
            "mu_factor_sd": float(cells.std()),
        }
    return out


def _anchor(
    x: NDArray[np.float64], y: NDArray[np.float64], yaw: NDArray[np.float64]
) -> tuple[NDArray[np.float64], ...]:
    """Anchor a trajectory at (0, 0, 0): the paper's alignment of every run."""
    c, s = math.cos(-yaw[0]), math.sin(-yaw[0])
    dx, dy = x - x[0], y - y[0]
    return c * dx - s * dy, s * dx + c * dy, np.unwrap(yaw - yaw[0])


def _at(
    t_src: NDArray[np.float64], values: NDArray[np.float64], t: NDArray[np.float64]
) -> NDArray[np.float64]:
    return np.asarray(np.interp(t, t_src, values), dtype=np.float64)


def trial_metrics(run_dir: Path, mission: str) -> dict[str, Any]:
    """The paper's per-run metrics of a trial folder (ground truth, EKF, raw odometry)."""
    gt = read_csv(run_dir / "ground_truth.csv")
    ekf = read_csv(run_dir / "ekf.csv")
    odo = read_csv(run_dir / "odometry.csv")
    cmd = read_csv(run_dir / "commands.csv")
    # time zero: the first command with v > 0.01 m/s (MCU time = twin time)
    i0 = m.time_zero_index(cmd["t_s"], cmd["v_cmd"])
    t0 = float(cmd["t_s"][i0])
    moving = cmd["t_s"][(np.abs(cmd["v_cmd"]) > 1e-9) | (np.abs(cmd["w_cmd"]) > 1e-9)]
    t_end = float(moving[-1]) if len(moving) else t0
    gx, gy, gyaw = _anchor(gt["x_m"], gt["y_m"], gt["yaw_rad"])
    ex, ey, eyaw = _anchor(ekf["x_m"], ekf["y_m"], ekf["yaw_rad"])
    ox, oy, oyaw = _anchor(odo["x_m"], odo["y_m"], odo["yaw_rad"])
    gxy, exy, oxy = np.c_[gx, gy], np.c_[ex, ey], np.c_[ox, oy]
    # EKF against ground truth on the EKF's 30 Hz samples
    gx_e, gy_e = _at(gt["t_s"], gx, ekf["t_s"]), _at(gt["t_s"], gy, ekf["t_s"])
    gyaw_e = _at(gt["t_s"], gyaw, ekf["t_s"])
    out: dict[str, Any] = {
        "mission": mission,
        "duration_s": t_end - t0,
        "gt_closure_cm": m.closure_error(gxy) * 100,
        "ekf_closure_cm": m.closure_error(exy) * 100,
        "odom_closure_cm": m.closure_error(oxy) * 100,
        "ekf_position_rmse_vs_gt_cm": m.d_trans(exy, np.c_[gx_e, gy_e]) * 100,
        "ekf_yaw_rmse_vs_gt_deg": math.degrees(m.d_rot(eyaw, gyaw_e)),
        "gt_final_heading_deg": math.degrees(abs(m.final_heading_error(gyaw[0], gyaw[-1]))),
        "ekf_final_heading_deg": math.degrees(abs(m.final_heading_error(eyaw[0], eyaw[-1]))),
        "odom_final_heading_deg": math.degrees(abs(m.final_heading_error(oyaw[0], oyaw[-1]))),
    }
    out["optimism_gap_cm"] = (
        m.optimism_gap(out["ekf_closure_cm"] / 100, out["gt_closure_cm"] / 100) * 100
    )
    path = m.square_path() if mission == "square" else m.figure_eight_path()
    out["gt_cross_track_rmse_cm"] = m.cross_track_rmse(gxy, path) * 100
    out["ekf_cross_track_rmse_cm"] = m.cross_track_rmse(exy, path) * 100
    out["odom_cross_track_rmse_cm"] = m.cross_track_rmse(oxy, path) * 100
    out["ekf_max_cross_track_cm"] = m.max_cross_track(exy, path) * 100
    out["ekf_path_m"] = float(np.sum(np.hypot(np.diff(ex), np.diff(ey))))
    if mission == "figure8":
        split = m.figure_eight_split(gyaw)
        ccw, cw = m.loop_diameters(gxy, split)
        out["gt_loop_diameter_ccw_m"], out["gt_loop_diameter_cw_m"] = ccw, cw
        split_e = m.figure_eight_split(eyaw)
        eccw, ecw = m.loop_diameters(exy, split_e)
        out["ekf_loop_diameter_ccw_m"], out["ekf_loop_diameter_cw_m"] = eccw, ecw
    return out
