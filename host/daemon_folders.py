"""The daemon's run folders (docs/recording.md): the one being written with its recorder and
its rosbag2, the split into the next one, the recording folder kept under its budget, and the
unfinished bags of earlier runs repaired beside the running daemon.

The slow work (a snapshot compressed and written, files copied, a folder closed, old folders
deleted, old bags repaired) runs on threads of its own, never on the frame loop: the robot's
READY, its watchdog's pings and its frames must not wait for a disk.
"""

from __future__ import annotations

import datetime as dt
import shutil
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from jackson.common.threads import guard
from jackson.host.config import HostConfig
from jackson.host.recording import RunRecorder, run_in_progress, write_json
from jackson.host.recording.budget import Deleted, DiskUse, folder_bytes, prune
from jackson.host.recording.snapshot import SNAPSHOT_NAME, encode_snapshot, write_snapshot
from jackson.host.recording.split import FolderWorker, SplitPolicy, carry_files, part_folder

if TYPE_CHECKING:  # the bag and the ROS messages load when a run folder or --ros needs them
    from jackson.host.core import HostCore
    from jackson.host.ros.bag import BagRecorder
    from jackson.host.ros.messages import RosOutput, RosSettings, StampClock
    from jackson.host.service.navigation import NavigationService


class RunFolders:
    """The run folder being written (its recorder and bag) and the recording folder around it.

    Parameters
    ----------
    cfg : HostConfig
        The host config: the bag's size limit and compression, the recording folder and budget.
    run_folder : Path or None
        The first run folder (None: no recording).
    meta : dict
        Its meta.json.
    rotate : bool
        Keep the recording folder under ``recording.budget_mb`` (a daemon that runs for hours);
        False: delete nothing.
    say : callable
        One line for the operator from another thread (printed, kept for health.json).
    """

    def __init__(
        self,
        cfg: HostConfig,
        run_folder: Path | None,
        meta: dict[str, Any],
        rotate: bool,
        say: Callable[[str], None],
    ) -> None:
        self.cfg = cfg
        self.run_folder = run_folder
        self.recorder = RunRecorder(run_folder, meta) if run_folder is not None else None
        self.bag: BagRecorder | None = None
        self.disk_use = DiskUse(run_folder.parent if run_folder else cfg.recording_folder)
        self.budget_bytes = round(cfg.recording_budget_mb * 1e6) if rotate else 0
        self._room_bytes = 0  # kept free for the folder being written: the largest closed one
        self.worker = FolderWorker(say)  # the split's and the budget's slow work
        self._say = say
        # earlier runs' unfinished bags are repaired beside the running daemon: READY and
        # the watchdog's pings must not wait for a long repair
        self._repairer = (
            None
            if run_folder is None
            else threading.Thread(
                target=guard(self._repair_earlier_runs, "bag-repair"),
                args=(run_folder,),
                name="bag-repair",
                daemon=True,
            )
        )

    def start_bag(self, settings: RosSettings, clock: StampClock | None) -> None:
        """Open the run folder's rosbag2, flushed with its other files."""
        assert self.run_folder is not None and self.recorder is not None
        self.bag = self.open_bag(self.run_folder, settings, clock)
        self.recorder.flush_with.append(self.bag)

    def open_bag(
        self, folder: Path, settings: RosSettings, clock: StampClock | None
    ) -> BagRecorder:
        """The rosbag2 (MCAP) of the run folder ``folder``, with the node's names, offsets and
        clock (``clock`` None: MCU time)."""
        from jackson.host.ros.bag import BagRecorder

        cfg = self.cfg
        return BagRecorder(
            folder / "bag",
            settings,
            odometry=cfg.odometry,
            clock=clock,
            max_bytes=int(cfg.bag_max_mb * 1e6) if cfg.bag_max_mb > 0 else None,
            compression=cfg.bag_compression,
            topic_hz=cfg.bag_topic_hz,
            flush_interval_s=None,  # flushed with the run folder's files, on MCU time
        )

    def start(self) -> None:
        """The frame loop starts: earlier runs' bags repaired, then the budget kept."""
        if self._repairer is not None and not self._repairer.is_alive():
            self._repairer.start()
        if self.budget_bytes > 0:  # at start-up, once the earlier runs' bags are repaired
            self.worker.submit("the recording folder's budget", self._keep_budget_at_start)

    def close(self, health: Callable[[], dict[str, Any]]) -> None:
        """The daemon stops: the threads' work done, health.json (the document ``health``
        returns) written, the bag finished, the recorder closed."""
        if self._repairer is not None and self._repairer.is_alive():
            self._repairer.join()  # a repair replaces the bag only once complete
        self.worker.join()  # earlier run folders closed, snapshots written
        if self.recorder is not None:
            self._write_health(health)
        # the bag is finished before the recorder lets go of the run's lock: until then
        # another daemon in the same recording folder (a campaign's next trial) must not
        # take the closing bag for a killed run's and repair it under the writer's feet
        if self.bag is not None:
            try:
                self.bag.close()
            except Exception as exc:
                print(f"daemon: the run's bag did not close cleanly: {exc}", flush=True)
        if self.recorder is not None:
            self.recorder.close()

    def _write_health(self, health: Callable[[], dict[str, Any]]) -> None:
        assert self.run_folder is not None
        try:
            write_json(self.run_folder / "health.json", health())
        except OSError as exc:
            print(f"daemon: cannot write health.json: {exc.strerror}", flush=True)

    def disk(self) -> dict[str, Any]:
        """The recording folder's use and budget [MB] and the free space on its disk [MB]. Cheap
        (:class:`~jackson.host.recording.budget.DiskUse`): the folder is walked after each split
        and once a minute, the run folder being written at each call."""
        folder = self.disk_use.root
        used = self.disk_use.used_bytes(self.run_folder)
        try:
            free = shutil.disk_usage(folder).free
        except OSError:
            free = 0
        budget = self.budget_bytes / 1e6
        return {
            "folder": str(folder),
            "recording": self.run_folder is not None,
            "used_mb": used / 1e6,
            "budget_mb": budget,
            "left_mb": max(0.0, budget - used / 1e6) if budget > 0 else None,
            "free_mb": free / 1e6,
        }

    def _keep_budget_at_start(self) -> None:
        if self._repairer is not None:
            self._repairer.join()
        self.keep_budget(self.run_folder)

    def keep_budget(self, keep: Path | None, closed_bytes: int = 0) -> None:
        """Delete the oldest complete run folders until the recording folder is under
        ``recording.budget_mb`` (on :attr:`worker`'s thread), one line each. After a split the
        folder just closed (``closed_bytes``) is room kept free for the new one to grow into, up
        to half the budget: the folder stays under its budget while the next folder is written,
        not only at the splits."""
        budget = self.budget_bytes
        if budget <= 0 or keep is None:
            return
        self._room_bytes = max(self._room_bytes, min(closed_bytes, budget // 2))

        def told(d: Deleted) -> None:
            self._say(
                f"recording: deleted {d.folder.name} ({d.size_bytes / 1e6:.0f} MB) to stay "
                f"under the {budget / 1e6:g} MB budget"
            )

        total = prune(keep.parent, budget - self._room_bytes, keep, told)
        self.disk_use.others(total, keep)

    def _repair_earlier_runs(self, run_folder: Path) -> None:
        """Bags of earlier runs in the recording folder that a kill or a power loss left
        unfinished are repaired now (as ``jackson bag repair``); a failure is reported, never
        fatal."""
        from jackson.host.ros.bag import bag_folders, needs_repair, repair_bag

        root = run_folder.parent
        if not root.is_dir():
            return
        for run in sorted(p for p in root.iterdir() if p.is_dir() and p != run_folder):
            if run_in_progress(run):
                continue  # another daemon (a campaign's other trial) is recording it now
            for bag in bag_folders(run):
                if not needs_repair(bag):
                    continue
                try:
                    n = repair_bag(bag)
                except Exception as exc:  # a damaged old bag must not keep the robot down
                    self._say(f"could not repair the unfinished bag {bag}: {exc}")
                else:
                    self._say(f"repaired the unfinished bag {bag}: {n} messages recovered")


class FolderSplit:
    """The next run folder started between two telemetry frames when ``recording.split`` says
    (:mod:`jackson.host.recording.split`).

    Parameters
    ----------
    policy : SplitPolicy
        When a folder ends.
    folders : RunFolders
        The run folder being written (swapped at each split).
    core : HostCore
        The core: its snapshot (the new folder's replay starts from it), its time and its
        run-folder listeners.
    ros : RosOutput or None
        The ROS messages, whose sinks hold the bag being written.
    service : NavigationService or None
        The navigation service: its goals (a split per goal) and its map (in each bag).
    report : callable
        health.json of the folder being written.
    events : deque of str
        What the operator was told in the folder being written (emptied for the next).
    tell : callable
        One line for the operator (printed and in the run's log).
    """

    def __init__(
        self,
        policy: SplitPolicy,
        folders: RunFolders,
        core: HostCore,
        ros: RosOutput | None,
        service: NavigationService | None,
        report: Callable[[], dict[str, Any]],
        events: deque[str],
        tell: Callable[[str], None],
    ) -> None:
        self.policy = policy
        self.folders = folders
        self.core = core
        self.ros = ros
        self.service = service
        self.report = report
        self.events = events
        self.tell = tell
        self.first = folders.run_folder
        self.part = 1  # the run folder's number (1: the first)

    def due(self) -> str | None:
        """Before a telemetry frame (and its LiDAR bytes): why the next run folder starts now,
        or None."""
        policy = self.policy
        goal = self.service.stage() if self.service is not None and policy.by_goal else None
        return policy.reason(self.core.t_s, goal)

    def frame(self, t_s: float | None) -> None:
        """A telemetry frame of MCU time ``t_s`` went into the folder being written."""
        self.policy.frame(t_s)

    def split(self, reason: str) -> None:
        """Start the next run folder between two telemetry frames (docs/recording.md). Here,
        on the frame loop: the core's snapshot pickled, the new folder's recorder and bag
        swapped in. On the folders' worker thread: the snapshot compressed and written, the
        config and the map copied, the previous folder closed, the budget kept."""
        from jackson.host.core import RunFolderListener

        t0, cpu0 = time.perf_counter(), time.thread_time()
        core, folders = self.core, self.folders
        old_rec, old_bag, first = folders.recorder, folders.bag, self.first
        assert old_rec is not None and first is not None
        pickled = core.snapshot()
        pickle_ms = (time.perf_counter() - t0) * 1e3
        old = old_rec.folder
        new = part_folder(first, self.part + 1)
        at = {"reason": reason, "part": self.part + 1, "t_s": core.t_s, "frames": core.frames}
        meta = {k: v for k, v in old_rec.meta.items() if k not in ("next", "split")}
        meta.update(
            started=dt.datetime.now().isoformat(),
            previous=old.name,
            split=at,
            snapshot=SNAPSHOT_NAME,
        )
        rec = RunRecorder(new, meta)
        try:
            bag = (
                None
                if old_bag is None
                else folders.open_bag(new, old_bag.settings, old_bag.builder.clock)
            )
            if bag is not None and self.ros is not None and self.service is not None:
                # the latched /map again (/tf_static: the bag itself): each bag plays alone
                t_s = core.t_s or 0.0
                grid = self.service.nav.static_map
                bag.write("map", t_s, self.ros.builder.occupancy(t_s, grid))
        except Exception:
            rec.close()
            shutil.rmtree(new, ignore_errors=True)
            raise
        # nothing fails from here on: the new folder takes over
        self.part += 1
        health = self.report()
        self.events.clear()
        for listener in core.listeners:
            if isinstance(listener, RunFolderListener):
                listener.recorder = rec
        folders.recorder, folders.run_folder = rec, new
        if bag is not None:
            folders.bag = bag
            rec.flush_with.append(bag)
            if self.ros is not None:
                self.ros.sinks = [bag if s is old_bag else s for s in self.ros.sinks]
        self.policy.started()
        old_rec.meta["next"] = new.name
        old_rec.link(time.monotonic_ns(), f"recording: continued in {new.name} ({reason})")
        data = {"frames": core.frames, "t_s": core.t_s, "reason": reason}
        worker = folders.worker
        worker.submit(
            f"the snapshot of {new}",
            lambda: write_snapshot(new / SNAPSHOT_NAME, encode_snapshot(pickled, data)),
        )
        worker.submit(f"copying {old}'s files", lambda: carry_files(old, new))
        worker.submit(f"closing {old}", lambda: close_folder(old_rec, old_bag, health))
        worker.submit(
            "the recording folder's budget", lambda: folders.keep_budget(new, folder_bytes(old))
        )
        ms, cpu_ms = (time.perf_counter() - t0) * 1e3, (time.thread_time() - cpu0) * 1e3
        self.tell(
            f"recording: {new} ({reason}), after {old.name}; split in {ms:.1f} ms on the "
            f"frame loop ({cpu_ms:.1f} ms CPU; snapshot {len(pickled) / 1e6:.1f} MB pickled in "
            f"{pickle_ms:.1f} ms)"
        )


def close_folder(rec: RunRecorder, bag: BagRecorder | None, health: dict[str, Any]) -> None:
    """A split's previous folder finished (on the folders' worker thread): its bag,
    health.json, meta.json with ``next``, its log's end record."""
    try:
        if bag is not None:
            bag.close()
    finally:  # a bag that did not finish (jackson bag repair) leaves the rest complete
        try:
            write_json(rec.folder / "health.json", health)
            rec.write_meta()
        finally:
            rec.close()  # complete now: its lock released
