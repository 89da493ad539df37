"""Run folders of a daemon that runs for hours: split points, the core's snapshot a folder's
replay starts from, the recording folder's budget, its cached size."""

from __future__ import annotations

import itertools
import os
import pickle
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.actuation.output import NullOutput
from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.control.navigate import NavigateConfig
from jackson.host.core import HostCore, RunFolderListener
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.host.recording import RecordingError, RunRecorder
from jackson.host.recording.budget import Deleted, DiskUse, folder_bytes, prune
from jackson.host.recording.snapshot import (
    MAGIC,
    SNAPSHOT_NAME,
    encode_snapshot,
    read_snapshot,
    write_snapshot,
)
from jackson.host.recording.split import SplitPolicy, carry_files, part_folder
from jackson.host.replay import replay
from jackson.host.service.goals import GoalBook
from jackson.host.service.navigation import NavigationService
from jackson.host.service.settings import ServiceSettings
from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Frame,
    FrameDecoder,
    Info,
    Message,
    Telemetry,
    TelemetryFlags,
    encode_frame,
)
from jackson.protocol.rplidar import CAPSULE_FORMATS

# ---------------------------------------------------------------------- when a folder starts


def test_goal_split_starts_a_folder_at_the_frame_that_takes_a_goal() -> None:
    p = SplitPolicy("goal", 3600.0)
    assert p.reason(None, 1) is None  # no frame in the folder yet: nothing to split
    p.frame(10.0)
    assert p.reason(10.0, None) is None
    assert p.reason(10.05, 3) == "goal 3"
    p.started()
    assert p.reason(10.05, 4) is None  # the new folder holds no frame yet


def test_duration_split_every_split_s_of_mcu_time() -> None:
    p = SplitPolicy("duration", 60.0)
    p.frame(5.0)
    assert p.reason(64.95, 1) is None  # a goal does not split by duration
    assert p.reason(65.0, None) == "duration"
    p.started()
    p.frame(65.05)
    assert p.reason(125.0, None) is None and p.reason(125.05, None) == "duration"


def test_an_idle_folder_of_goal_split_is_cut_at_split_s_and_none_never_splits() -> None:
    goal = SplitPolicy("goal", 60.0)
    goal.frame(0.0)
    assert goal.reason(60.0, None) == "duration"
    none = SplitPolicy("none", 1.0)
    none.frame(0.0)
    assert none.reason(1e6, 7) is None
    with pytest.raises(ValueError, match="one of goal, duration, none"):
        SplitPolicy("hourly", 1.0)


def test_an_mcu_reset_restarts_the_folders_clock() -> None:
    p = SplitPolicy("duration", 60.0)
    p.frame(500.0)
    p.frame(0.3)  # the MCU rebooted: its clock starts again
    assert p.reason(59.0, None) is None and p.reason(60.3, None) == "duration"


def test_parts_are_named_after_the_first_folder_and_skip_taken_names(tmp_path: Path) -> None:
    first = tmp_path / "20260101-120000-service"
    assert part_folder(first, 2).name == "20260101-120000-service-002"
    (tmp_path / "20260101-120000-service-002").mkdir()
    assert part_folder(first, 2).name == "20260101-120000-service-003"


def test_the_callers_files_are_carried_and_the_recordings_are_not(tmp_path: Path) -> None:
    old, new = tmp_path / "a", tmp_path / "b"
    old.mkdir()
    new.mkdir()
    for name in ("config.yaml", "map.yaml", "map.pgm", "log.jrec", "ekf.csv", "meta.json"):
        (old / name).write_text(name)
    (old / SNAPSHOT_NAME).write_text("x")
    carry_files(old, new)
    assert sorted(p.name for p in new.iterdir()) == ["config.yaml", "map.pgm", "map.yaml"]
    assert (new / "map.pgm").read_text() == "map.pgm"


def test_carried_files_are_stored_once_and_counted_once(tmp_path: Path) -> None:
    folders = [tmp_path / name for name in ("a", "b", "c")]
    folders[0].mkdir()
    (folders[0] / "map.pgm").write_bytes(bytes(180_000))
    for old, new in itertools.pairwise(folders):
        new.mkdir()
        carry_files(old, new)
    assert (folders[2] / "map.pgm").stat().st_ino == (folders[0] / "map.pgm").stat().st_ino
    assert folder_bytes(tmp_path) == 180_000  # one map, however many folders hold it
    shutil.rmtree(folders[0])  # the budget deletes the oldest: the others keep the map
    assert (folders[1] / "map.pgm").read_bytes() == bytes(180_000)
    assert folder_bytes(tmp_path) == 180_000


# ---------------------------------------------------------------------- the budget


def fake_run(root: Path, name: str, size_mb: float, age_s: float) -> Path:
    """A complete run folder of ``size_mb`` (a sparse file) last written ``age_s`` ago."""
    run = root / name
    run.mkdir()
    (run / "meta.json").write_text("{}")
    (run / "log.jrec").write_bytes(b"JREC0001")
    with open(run / "pad.bin", "wb") as f:
        f.truncate(round(size_mb * 1e6))
    t = time.time() - age_s
    os.utime(run / "log.jrec", (t, t))
    return run


def test_the_oldest_complete_run_folders_go_first_until_under_the_budget(tmp_path: Path) -> None:
    for k, name in enumerate(("c", "a", "d", "b")):  # ages 400, 300, 200, 100 s
        fake_run(tmp_path, name, 10.0, 400.0 - 100.0 * k)
    told: list[Deleted] = []
    total = prune(tmp_path, round(25e6), on_delete=told.append)
    assert [d.folder.name for d in told] == ["c", "a"]  # the oldest, not the first by name
    assert all(abs(d.size_bytes - 10e6) < 100 for d in told)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b", "d"]
    assert total == folder_bytes(tmp_path) <= 25e6


def test_under_the_budget_nothing_goes(tmp_path: Path) -> None:
    fake_run(tmp_path, "a", 1.0, 100.0)
    assert prune(tmp_path, round(2e6)) == folder_bytes(tmp_path)
    assert (tmp_path / "a").is_dir()


def test_never_the_folder_being_written_nor_one_another_recorder_holds(tmp_path: Path) -> None:
    held = fake_run(tmp_path, "held", 10.0, 1000.0)
    (held / "log.jrec").unlink()
    rec = RunRecorder(held, {})  # another daemon writing it: its log is locked
    keep = fake_run(tmp_path, "keep", 10.0, 900.0)
    fake_run(tmp_path, "old", 10.0, 500.0)
    os.utime(held / "log.jrec", (0, 0))
    try:
        total = prune(tmp_path, 1, keep=keep)
    finally:
        rec.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["held", "keep"]
    assert total > 20e6  # over the budget: nothing more could go


def test_what_is_not_a_run_folder_counts_but_is_never_deleted(tmp_path: Path) -> None:
    (tmp_path / "notes").mkdir()
    with open(tmp_path / "notes" / "big.bin", "wb") as f:
        f.truncate(round(5e6))
    (tmp_path / "hall.pgm").write_bytes(bytes(1000))
    fake_run(tmp_path, "run", 1.0, 10.0)
    total = prune(tmp_path, round(1e6))
    assert not (tmp_path / "run").exists()
    assert (tmp_path / "notes" / "big.bin").exists() and (tmp_path / "hall.pgm").exists()
    assert total == round(5e6) + 1000


def test_the_disk_use_is_cached_and_the_folder_being_written_measured_live(
    tmp_path: Path,
) -> None:
    fake_run(tmp_path, "old", 2.0, 10.0)
    current = tmp_path / "current"
    current.mkdir()
    use = DiskUse(tmp_path, refresh_s=3600.0)
    before = use.used_bytes(current)
    assert before == folder_bytes(tmp_path)
    fake_run(tmp_path, "someone_elses", 3.0, 1.0)  # not seen until the cache is refreshed
    (current / "log.jrec").write_bytes(bytes(5000))  # seen at once
    assert use.used_bytes(current) == before + 5000
    use.others(folder_bytes(tmp_path), current)  # a prune's total
    assert use.used_bytes(current) == folder_bytes(tmp_path)


# ---------------------------------------------------------------------- the core's snapshot


def room(side_m: float = 6.0, res: float = 0.05) -> OccupancyGrid:
    n = round(side_m / res)
    data = np.zeros((n, n), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyGrid(data, res, 0.0, 0.0)


def service() -> NavigationService:
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=(), seed=3)
    return NavigationService(config, LimiterConfig(), room(), ServiceSettings())


def frame(msg: Message, seq: int) -> Frame:
    (f,) = FrameDecoder().feed(encode_frame(msg, seq))
    return f


INFO = Info(
    protocol_version=PROTOCOL_VERSION,
    schema_hash=SCHEMA_HASH,
    telemetry_rate_hz=20,
    failsafe_ms=600,
    imu_rotation=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    accel_scale=1.0,
    boot_id=7,
)


def telemetry(k: int) -> Frame:
    counts = 3 * max(0, k - 40)
    gyro = (0, 0, 5 if k % 3 else -5)
    return frame(
        Telemetry(
            t_us=50_000 * (k + 1),
            enc_left=counts,
            enc_right=counts + k % 2,
            flags=TelemetryFlags.IMU_OK,
            accel=(0, 0, 16384),
            gyro=gyro,
        ),
        (k + 1) % 256,
    )


def test_a_folder_that_begins_at_a_split_replays_bit_for_bit_from_its_snapshot(
    tmp_path: Path,
) -> None:
    """The daemon's split, by hand: the live core goes on in a second folder, whose replay
    starts from the snapshot and must give the same rows."""
    cfg = load_config(DEFAULT_CONFIG)
    svc = service()
    first = RunRecorder(tmp_path / "run", {"mission": "service"})
    core = HostCore(cfg, NullOutput(), lambda m: None, mission=svc, recorder=first)
    core.on_frame(frame(INFO, 0))
    for k in range(60):
        if k == 30:
            svc.submit_goal(Pose2D(4.0, 2.0))
        core.on_frame(telemetry(k))
    core.submit_velocity(0.1, 0.0)  # submitted, not taken: it belongs to the next folder
    svc.submit_goal(Pose2D(2.0, 4.0))  # so does this goal
    pickled = core.snapshot()
    second = RunRecorder(tmp_path / "run-002", {"mission": "service", "snapshot": SNAPSHOT_NAME})
    write_snapshot(second.folder / SNAPSHOT_NAME, encode_snapshot(pickled, {"frames": 60}))
    (listener,) = (x for x in core.listeners if isinstance(x, RunFolderListener))
    listener.recorder = second
    first.close()
    for k in range(60, 140):
        core.on_frame(telemetry(k))
    second.close()
    assert svc.book.counts["aborted"] == 2  # goals 1 and 2 ended by the velocity command
    result = replay(second.folder, tmp_path / "out")
    assert result.complete and result.differ == [] and result.frames == 80
    assert result.commands == 1 and result.snapshot is not None
    assert result.snapshot["frames"] == 60


def test_the_snapshot_leaves_out_the_io_and_what_was_not_taken() -> None:
    svc = service()
    sent: list[Message] = []
    core = HostCore(load_config(DEFAULT_CONFIG), NullOutput(), sent.append, mission=svc)
    svc.tell = print
    svc.submit_goal(Pose2D(4.0, 2.0))
    core.submit_velocity(0.2, 0.1)
    output, got = NullOutput(), []
    copy = HostCore.restore(core.snapshot(), output, got.append)
    assert copy.output is output and copy.send == got.append and copy.listeners == []
    mission = copy.mission
    assert isinstance(mission, NavigationService) and mission.tell is None
    assert mission.take_requests() == [] and copy.arbiter.take(True) is None
    assert mission.book.get(1) is not None  # the goal's record, pending
    assert svc.take_requests() != [] and core.arbiter.take(True) is not None  # the live ones


def test_a_goal_book_pickles_without_its_lock_and_numbers_on() -> None:
    book = GoalBook(4)
    book.new(Pose2D(1.0, 1.0), "socket")
    copy = pickle.loads(pickle.dumps(book))
    assert copy.new(Pose2D(2.0, 2.0), "socket").goal_id == 2
    assert book.new(Pose2D(2.0, 2.0), "socket").goal_id == 2  # the live book is untouched


def test_a_capsule_format_unpickles_as_the_modules_own() -> None:
    for fmt in CAPSULE_FORMATS.values():
        assert pickle.loads(pickle.dumps(fmt)) is fmt  # the decoder compares by identity


@pytest.mark.parametrize(
    ("damage", "says"),
    [
        (lambda b: b"", "not a core snapshot"),
        (lambda b: b"JSNAP999" + b[8:], "format 999, this jackson reads 001"),
        (lambda b: b[:-20], "damaged"),
        (lambda b: b[:12] + b"[" + b[13:], "damaged"),
    ],
)
def test_a_damaged_snapshot_is_one_line(tmp_path: Path, damage: object, says: str) -> None:
    path = tmp_path / SNAPSHOT_NAME
    good = encode_snapshot(pickle.dumps({"a": 1}), {"frames": 1})
    assert good.startswith(MAGIC)
    path.write_bytes(damage(good))  # type: ignore[operator]
    with pytest.raises(RecordingError, match=says) as err:
        read_snapshot(path)
    assert "\n" not in str(err.value)


def test_a_missing_or_foreign_snapshot_stops_the_replay_with_one_line(tmp_path: Path) -> None:
    run = tmp_path / "run"
    RunRecorder(run, {"mission": None, "snapshot": SNAPSHOT_NAME}).close()
    with pytest.raises(RecordingError, match="cannot read the core's snapshot"):
        replay(run, tmp_path / "out1")
    foreign = pickle.dumps({"a": 1})  # a pickle, but not of a core
    write_snapshot(run / SNAPSHOT_NAME, encode_snapshot(foreign, {}))
    with pytest.raises(RecordingError, match=r"does not load .*not a HostCore") as err:
        replay(run, tmp_path / "out2")
    assert "\n" not in str(err.value)
