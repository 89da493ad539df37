"""Every subcommand fed bad input as users feed it: one line on stderr that names what was
wrong, exit status 2, no traceback, and nothing left behind (no half-written run folder, no
deleted file).

Each case runs the real ``jackson`` entry point (``jackson.main.main``) in this process, in a
fresh working folder holding the damaged files of :func:`corpus`; the folder's tree is compared
before and after. A few cases run as subprocesses too, to check the installed script.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from jackson.host.recording import RunRecorder
from jackson.main import main
from jackson.protocol import Info, Telemetry, encode_frame

JACKSON = [str(Path(sys.executable).parent / "jackson")]

GOOD_ROBOT = "robots/good.yaml"
GOOD_WORLD = "worlds/good.yaml"


# ------------------------------------------------------------------------- the corpus


def _telemetry_run(folder: Path, frames: int = 40, *, mission: str | None = "square") -> None:
    """A small, real run folder: telemetry frames through the recorder, then replayable."""
    from jackson.host.actuation.output import NullOutput
    from jackson.host.config import DEFAULT_CONFIG, load_config
    from jackson.host.control import MISSIONS
    from jackson.host.core import HostCore
    from jackson.protocol import Frame

    cfg = load_config(DEFAULT_CONFIG)
    rec = RunRecorder(folder, {"mission": mission, "config": "default"})
    core = HostCore(
        cfg,
        NullOutput(),
        lambda m: None,
        mission=MISSIONS[mission]() if mission else None,
        recorder=rec,
    )
    for k in range(frames):
        msg = Telemetry(t_us=5000 * k, enc_left=3 * k, enc_right=3 * k, flags=1 << 3)
        frame = Frame(msg.TYPE, k & 0xFF, msg.pack())
        core.on_frame(frame, k * 5_000_000)
    rec.close()
    (folder / "config.yaml").write_text(DEFAULT_CONFIG.read_text())


def _log(run: Path, kind: int, payload: bytes) -> None:
    """Replace the run's log by one record."""
    header = bytes((kind,)) + (0).to_bytes(8, "little") + len(payload).to_bytes(2, "little")
    (run / "log.jrec").write_bytes(b"JREC0001" + header + payload)


def _write(root: Path, rel: str, text: str | bytes) -> None:
    p = root / rel
    p.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)


ROBOT = """\
name: corpus
wheel_radius_m: {r}
wheel_separation_m: {b}
"""

WORLD = """\
name: corpus
walls:
{walls}
start_pose: {start}
"""

ROOM = "  - [-2, -2, 2, -2]\n  - [2, -2, 2, 2]\n  - [2, 2, -2, 2]\n  - [-2, 2, -2, -2]\n"


MAP_FIELDS = {
    "image": "free.pgm",
    "resolution": "0.05",
    "origin": "[0, 0, 0]",
    "occupied_thresh": "0.65",
    "free_thresh": "0.196",
    "negate": "0",
    "mode": "trinary",
}


def _map_yaml(**damage: str) -> str:
    """map_server's YAML with every field map_server documents, ``damage`` replacing some."""
    return "".join(f"{k}: {v}\n" for k, v in {**MAP_FIELDS, **damage}.items())


MAP_IMAGES: dict[str, bytes] = {  # headers only, or broken: nothing here may be decoded
    "huge.pgm": b"P5\n200000 200000\n255\n\0",
    "wide.pgm": b"P5\n30000 2\n255\n\0",
    "many_cells.pgm": b"P5\n12000 9000\n255\n\0",
    "truncated.pgm": b"P5\n20 10\n255\n" + bytes(50),
    "text.pgm": b"this is a text file, not an image\n",
}

# maps/<name>.yaml -> (its text, what the one line must name after "<name>.yaml: ")
BAD_MAPS: dict[str, tuple[str | bytes, str]] = {
    "huge_image": (_map_yaml(image="huge.pgm"), "image: huge.pgm"),
    "wide_image": (_map_yaml(image="wide.pgm"), "image: wide.pgm"),
    "image_cells": (_map_yaml(image="many_cells.pgm"), "image: many_cells.pgm"),
    "truncated_image": (_map_yaml(image="truncated.pgm"), "image: truncated.pgm"),
    "text_image": (_map_yaml(image="text.pgm"), "image: text.pgm"),
    "missing_image": (_map_yaml(image="nowhere.pgm"), "image: nowhere.pgm"),
    "image_folder": (_map_yaml(image="."), "image: "),
    "res_zero": (_map_yaml(resolution="0"), "resolution"),
    "res_negative": (_map_yaml(resolution="-0.05"), "resolution"),
    "res_tiny": (_map_yaml(resolution="1e-9"), "resolution"),
    "res_huge": (_map_yaml(resolution="1e300"), "resolution"),
    "res_inf": (_map_yaml(resolution=".inf"), "resolution"),
    "res_nan": (_map_yaml(resolution=".nan"), "resolution"),
    "res_text": (_map_yaml(resolution="fine"), "resolution"),
    "origin_inf": (_map_yaml(origin="[.inf, 0, 0]"), "origin"),
    "origin_nan": (_map_yaml(origin="[0, .nan, 0]"), "origin"),
    "origin_far": (_map_yaml(origin="[1e308, 0, 0]"), "origin"),
    "origin_short": (_map_yaml(origin="[0, 0]"), "origin"),
    "origin_long": (_map_yaml(origin="[0, 0, 0, 0]"), "origin"),
    "origin_yaw": (_map_yaml(origin="[0, 0, 0.3]"), "origin"),
    "thresh_reversed": (_map_yaml(occupied_thresh="0.2", free_thresh="0.6"), "free_thresh"),
    "thresh_above_one": (_map_yaml(occupied_thresh="1.5"), "occupied_thresh"),
    "thresh_negative": (_map_yaml(free_thresh="-0.1"), "free_thresh"),
    "mode_bogus": (_map_yaml(mode="bogus"), "mode"),
    "negate_7": (_map_yaml(negate="7"), "negate"),
    "unknown_key": (_map_yaml(colour="red"), "unknown field colour"),
    "duplicate_key": (_map_yaml() + "mode: raw\n", "line 8: not valid YAML (duplicate field"),
    "list": ("- image: good.pgm\n- resolution: 0.05\n", "expected a mapping"),
    "empty": ("", "expected a mapping"),
    "binary": (b"\xff\xfe\x00image: good.pgm\x00", "not UTF-8"),
}


@pytest.fixture(scope="module")
def corpus(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    root = tmp_path_factory.mktemp("corpus")
    w = lambda rel, text: _write(root, rel, text)  # noqa: E731
    # robots
    w(GOOD_ROBOT, ROBOT.format(r=0.033, b=0.198))
    w("robots/nan.yaml", ROBOT.format(r=".nan", b=0.198))
    w("robots/inf.yaml", ROBOT.format(r=0.033, b=".inf"))
    w("robots/negative.yaml", ROBOT.format(r=-0.033, b=0.198))
    w("robots/text.yaml", ROBOT.format(r="thirty", b=0.198))
    w("robots/unknown_field.yaml", ROBOT.format(r=0.033, b=0.198) + "wheel_count: 3\n")
    w("robots/syntax.yaml", "name: [unclosed\n")
    w("robots/list.yaml", "- 1\n- 2\n")
    w("robots/empty.yaml", "")
    w("robots/binary.yaml", b"\xff\xfe\x00garbage\x00")
    # worlds
    w(GOOD_WORLD, WORLD.format(walls=ROOM, start="[0, 0, 0]"))
    w("worlds/nan_wall.yaml", WORLD.format(walls="  - [0, .nan, 1, 1]\n", start="[0, 0, 0]"))
    w("worlds/inf_wall.yaml", WORLD.format(walls="  - [0, 0, .inf, 1]\n", start="[0, 0, 0]"))
    w("worlds/zero_wall.yaml", WORLD.format(walls="  - [1, 1, 1, 1]\n", start="[0, 0, 0]"))
    w("worlds/short_wall.yaml", WORLD.format(walls="  - [1, 1, 2]\n", start="[0, 0, 0]"))
    w("worlds/text_wall.yaml", WORLD.format(walls="  - [a, 1, 2, 3]\n", start="[0, 0, 0]"))
    w("worlds/nan_start.yaml", WORLD.format(walls=ROOM, start="[.nan, 0, 0]"))
    w("worlds/start_in_wall.yaml", WORLD.format(walls=ROOM, start="[2.0, 0, 0]"))
    w("worlds/start_outside.yaml", WORLD.format(walls="  - [0.1, -1, 0.1, 1]\n", start="[0, 0, 0]"))
    w(
        "worlds/start_in_cylinder.yaml",
        WORLD.format(walls=ROOM, start="[0, 0, 0]")
        + "cylinders:\n  - {x: 0.05, y: 0, radius: 0.2}\n",
    )
    w(
        "worlds/nan_cylinder.yaml",
        WORLD.format(walls=ROOM, start="[0, 0, 0]")
        + "cylinders:\n  - {x: 1, y: .nan, radius: 0.2}\n",
    )
    w("worlds/mu.yaml", "floor:\n  mu_static: 0.5\n  mu_dynamic: 0.9\n")
    w("worlds/syntax.yaml", "walls: [[0, 0, 1\n")
    # maps
    w("maps/good.yaml", "image: good.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    w("maps/good.pgm", b"P5\n2 2\n255\n" + bytes([254, 0, 205, 254]))
    w("maps/garbage.yaml", "image: [unclosed\n")
    w("maps/no_image.yaml", "image: nope.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    w("maps/free.pgm", b"P5\n40 40\n255\n" + bytes([254] * 1600))  # 2 m x 2 m, all free
    w("maps/full.yaml", _map_yaml())  # what the bad maps below damage
    for name, data in MAP_IMAGES.items():
        w(f"maps/{name}", data)
    for name, (text, _) in BAD_MAPS.items():
        w(f"maps/{name}.yaml", text)
    # host configs
    w("configs/syntax.yaml", "serial: {port: \n")
    w("configs/nan.yaml", "robot:\n  wheel_radius_m: .nan\n")
    w("configs/unknown.yaml", "robto:\n  wheel_radius_m: 0.033\n")
    w("configs/pca_address.yaml", "pca9685:\n  address: 0x99\n")
    # captures
    w("captures/garbage.bin", os.urandom(4096))
    w("captures/empty.bin", b"")
    same_t = encode_frame(Telemetry(t_us=7), 0) + encode_frame(Telemetry(t_us=7), 1)
    w("captures/equal_times.bin", same_t)
    w("captures/info.bin", encode_frame(Info(), 0) + encode_frame(Telemetry(t_us=1), 1))
    # a serial port with no robot behind it (the pty stays open while the module runs)
    master, slave = os.openpty()
    os.symlink(os.ttyname(slave), root / "robot_tty")
    # files where folders are expected and the reverse
    w("a_file", "user data\n")
    (root / "a_folder").mkdir()
    # run folders: a good one and damaged copies
    good = root / "runs/good"
    _telemetry_run(good)
    damaged: dict[str, Callable[[Path], None]] = {
        "no_meta": lambda p: (p / "meta.json").unlink(),
        "meta_garbage": lambda p: (p / "meta.json").write_text("{not json"),
        "meta_list": lambda p: (p / "meta.json").write_text("[1, 2]"),
        "meta_mission": lambda p: (p / "meta.json").write_text('{"mission": "zigzag"}'),
        "meta_mission_type": lambda p: (p / "meta.json").write_text('{"mission": 7}'),
        "meta_lidar": lambda p: (p / "meta.json").write_text('{"lidar": {"answer_type": 153}}'),
        "no_log": lambda p: (p / "log.jrec").unlink(),
        "log_magic": lambda p: (p / "log.jrec").write_bytes(b"NOTAJREC" + b"\0" * 64),
        "log_empty": lambda p: (p / "log.jrec").write_bytes(b""),
        "log_cut": lambda p: (p / "log.jrec").write_bytes((p / "log.jrec").read_bytes()[:777]),
        "log_short_payload": lambda p: _log(p, 1, bytes((Telemetry.TYPE,))),
        "log_unknown_type": lambda p: _log(p, 1, bytes((0xEE, 0, 0))),
        "log_unknown_kind": lambda p: _log(p, 9, b""),
        "log_bad_command": lambda p: _log(p, 3, b"abc"),
        "no_odometry": lambda p: (p / "odometry.csv").unlink(),
        "odometry_folder": lambda p: ((p / "odometry.csv").unlink(), (p / "odometry.csv").mkdir()),
        "config_syntax": lambda p: (p / "config.yaml").write_text("robot: [\n"),
        "config_nan": lambda p: (p / "config.yaml").write_text("robot:\n  wheel_radius_m: .nan\n"),
    }
    for name, damage in damaged.items():
        shutil.copytree(good, root / f"runs/{name}")
        damage(root / f"runs/{name}")
    (root / "runs/empty").mkdir()
    yield root
    os.close(master)
    os.close(slave)


# ------------------------------------------------------------------------- the cases


@dataclass(frozen=True)
class Case:
    argv: tuple[str, ...]
    says: str  # a fragment the one line must contain (the file, the field, the option)
    status: int = 2  # 1: hardware that does not answer (yet), which a restart may cure


def c(argv: str, says: str, status: int = 2) -> Case:
    return Case(tuple(argv.split()), says, status)


MISSING = "nowhere/missing.yaml"

CASES: dict[str, Case] = {
    # the parser itself
    "no_command": c("", "COMMAND"),
    "unknown_command": c("fly", "fly"),
    "unknown_option": c("decode --colour x", "--colour"),
    # decode
    "decode_missing": c("decode nowhere.bin", "nowhere.bin"),
    "decode_folder": c("decode a_folder", "a_folder"),
    # bench
    "bench_suite": c("bench --suite warp", "warp"),
    "bench_out_in_file": c("bench --quick --suite protocol --out a_file/b.json", "a_file"),
    "bench_out_folder": c("bench --quick --suite protocol --out a_folder", "a_folder"),
    # run
    "run_mission": c("run zigzag", "zigzag"),
    "run_robot_missing": c(f"run square --robot {MISSING}", "missing.yaml"),
    "run_robot_unknown_name": c("run square --robot no_such_robot", "no_such_robot"),
    "run_robot_nan": c("run square --robot robots/nan.yaml", "wheel_radius_m"),
    "run_robot_inf": c("run square --robot robots/inf.yaml", "wheel_separation_m"),
    "run_robot_negative": c("run square --robot robots/negative.yaml", "wheel_radius_m"),
    "run_robot_text": c("run square --robot robots/text.yaml", "wheel_radius_m"),
    "run_robot_field": c("run square --robot robots/unknown_field.yaml", "wheel_count"),
    "run_robot_syntax": c("run square --robot robots/syntax.yaml", "syntax.yaml"),
    "run_robot_list": c("run square --robot robots/list.yaml", "list.yaml"),
    "run_robot_empty": c("run square --robot robots/empty.yaml", "empty.yaml"),
    "run_robot_binary": c("run square --robot robots/binary.yaml", "binary.yaml"),
    "run_robot_folder": c("run square --robot a_folder", "a_folder"),
    "run_world_missing": c(f"run square --world {MISSING}", "missing.yaml"),
    "run_world_nan_wall": c("run square --world worlds/nan_wall.yaml", "walls[0]"),
    "run_world_inf_wall": c("run square --world worlds/inf_wall.yaml", "walls[0]"),
    "run_world_zero_wall": c("run square --world worlds/zero_wall.yaml", "walls[0]"),
    "run_world_short_wall": c("run square --world worlds/short_wall.yaml", "walls[0]"),
    "run_world_text_wall": c("run square --world worlds/text_wall.yaml", "walls[0]"),
    "run_world_nan_start": c("run square --world worlds/nan_start.yaml", "start_pose"),
    "run_world_start_in_wall": c("run square --world worlds/start_in_wall.yaml", "start_pose"),
    "run_world_start_at_wall": c("run square --world worlds/start_outside.yaml", "start_pose"),
    "run_world_start_in_cyl": c("run square --world worlds/start_in_cylinder.yaml", "start_pose"),
    "run_world_nan_cylinder": c("run square --world worlds/nan_cylinder.yaml", "cylinders[0].y"),
    "run_world_mu": c("run square --world worlds/mu.yaml", "mu_dynamic"),
    "run_world_syntax": c("run square --world worlds/syntax.yaml", "syntax.yaml"),
    "run_seed_text": c("run square --seed one", "--seed"),
    "run_seed_negative": c("run square --seed -1", "--seed"),
    "run_out_file": c("run square --out a_file", "a_file"),
    "run_out_in_file": c("run square --out a_file/run", "a_file"),
    "run_out_not_empty": c("run square --out runs/good", "runs/good"),
    "run_lidar_mode": c("run maze --lidar-mode turbo", "--lidar-mode: 'turbo'"),
    "run_square_lidar_mode": c("run square --lidar-mode express", "--lidar-mode is for the maze"),
    # campaign
    "campaign_trials_zero": c("campaign square --trials 0", "--trials"),
    "campaign_trials_negative": c("campaign square --trials -3", "--trials"),
    "campaign_trials_text": c("campaign square --trials many", "--trials"),
    "campaign_workers_zero": c("campaign square --workers 0", "--workers"),
    "campaign_workers_negative": c("campaign square --workers -1", "--workers"),
    "campaign_robot_missing": c(f"campaign square --robot {MISSING}", "missing.yaml"),
    "campaign_robot_nan": c("campaign square --robot robots/nan.yaml", "wheel_radius_m"),
    "campaign_world_zero_wall": c("campaign square --world worlds/zero_wall.yaml", "walls[0]"),
    "campaign_world_start": c("campaign square --world worlds/start_in_wall.yaml", "start_pose"),
    "campaign_out_file": c("campaign square --out a_file", "a_file"),
    "campaign_fidelity_out_file": c("campaign fidelity --out a_file", "a_file"),
    "campaign_fidelity_trials": c("campaign fidelity --trials 0", "--trials"),
    "campaign_fidelity_robot": c(f"campaign fidelity --robot {MISSING}", "missing.yaml"),
    "campaign_fidelity_stages": c("campaign fidelity --stages square,zigzag", "--stages"),
    "campaign_fidelity_stages_empty": c("campaign fidelity --stages ,", "--stages"),
    "campaign_fidelity_world": c("campaign fidelity --world maze", "--world"),
    "campaign_fidelity_notes_missing": c("campaign fidelity --notes nowhere/notes.md", "--notes"),
    "campaign_fidelity_notes_folder": c("campaign fidelity --notes a_folder", "a_folder"),
    "campaign_fidelity_docs_not_md": c("campaign fidelity --docs a_file", "ending in .md"),
    "campaign_fidelity_docs_no_folder": c("campaign fidelity --docs nowhere/f.md", "nowhere"),
    "campaign_square_docs": c("campaign square --docs f.md", "--docs is for jackson campaign fid"),
    "campaign_square_ablation": c("campaign figure8 --ablation", "--ablation is for"),
    "campaign_fidelity_ablation_zero": c("campaign fidelity --ablation 0", "--ablation"),
    "campaign_fidelity_ablation_over": c(
        "campaign fidelity --trials 3 --ablation 4", "--ablation 4: at most the 3 trials"
    ),
    "campaign_maze_stages": c("campaign maze --stages maze", "--stages is for"),
    # replay
    "replay_missing": c("replay runs/nowhere", "runs/nowhere"),
    "replay_file": c("replay a_file", "a_file"),
    "replay_empty": c("replay runs/empty", "runs/empty"),
    "replay_no_meta": c("replay runs/no_meta", "meta.json"),
    "replay_meta_garbage": c("replay runs/meta_garbage", "meta.json"),
    "replay_meta_list": c("replay runs/meta_list", "meta.json"),
    "replay_meta_mission": c("replay runs/meta_mission", "zigzag"),
    "replay_meta_mission_type": c("replay runs/meta_mission_type", "mission"),
    "replay_meta_lidar": c("replay runs/meta_lidar", "lidar.answer_type 153"),
    "replay_no_log": c("replay runs/no_log", "log.jrec"),
    "replay_log_magic": c("replay runs/log_magic", "log.jrec"),
    "replay_log_empty": c("replay runs/log_empty", "log.jrec"),
    "replay_log_short_payload": c("replay runs/log_short_payload", "log.jrec"),
    "replay_log_unknown_type": c("replay runs/log_unknown_type", "log.jrec"),
    "replay_log_unknown_kind": c("replay runs/log_unknown_kind", "log.jrec"),
    "replay_log_bad_command": c("replay runs/log_bad_command", "log.jrec"),
    "replay_no_odometry": c("replay runs/no_odometry", "odometry.csv"),
    "replay_odometry_folder": c("replay runs/odometry_folder", "odometry.csv"),
    "replay_config_syntax": c("replay runs/config_syntax", "config.yaml"),
    "replay_config_nan": c("replay runs/config_nan", "wheel_radius_m"),
    "replay_out_file": c("replay runs/good --out a_file", "a_file"),
    "replay_out_is_run": c("replay runs/good --out runs/good", "runs/good"),
    # daemon
    "daemon_config_missing": c(f"daemon --config {MISSING} --port /dev/null", "missing.yaml"),
    "daemon_config_syntax": c("daemon --config configs/syntax.yaml", "syntax.yaml"),
    "daemon_config_nan": c("daemon --config configs/nan.yaml", "wheel_radius_m"),
    "daemon_config_unknown": c("daemon --config configs/unknown.yaml", "robto"),
    "daemon_port_missing": c("daemon --port nowhere/tty --no-record", "nowhere/tty"),
    "daemon_port_file": c("daemon --port a_file --no-record", "a_file"),
    "daemon_i2c_missing": c(
        "daemon --port robot_tty --i2c unix:nowhere/sock --no-record", "nowhere/sock", 1
    ),
    "daemon_i2c_bad": c("daemon --port robot_tty --i2c floppy --no-record", "floppy"),
    "daemon_run_dir_file": c("daemon --run-dir a_file --port nowhere/tty", "a_file"),
    "daemon_run_dir_in_file": c("daemon --run-dir a_file/run --port nowhere/tty", "a_file"),
    "daemon_max_seconds": c("daemon --max-seconds -1 --no-record", "--max-seconds"),
    "daemon_max_seconds_nan": c("daemon --max-seconds nan --no-record", "--max-seconds"),
    "daemon_timeout_zero": c("daemon --mission-timeout 0 --no-record", "--mission-timeout"),
    "daemon_timeout_inf": c("daemon --mission-timeout inf --no-record", "--mission-timeout"),
    "daemon_mission": c("daemon --mission zigzag", "zigzag"),
    "daemon_goal_no_lidar": c("daemon --goal 1,0 --no-record", "--lidar"),
    "daemon_lidar_mode_no_lidar": c("daemon --lidar-mode express --no-record", "--lidar PORT"),
    "daemon_goal_text": c("daemon --goal one,two --lidar robot_tty --no-record", "--goal"),
    "daemon_goal_nan": c("daemon --goal nan,0 --lidar robot_tty --no-record", "--goal"),
    "daemon_goal_and_mission": c(
        "daemon --goal 1,0 --mission square --lidar robot_tty --no-record", "--mission"
    ),
    "daemon_start_short": c("daemon --goal 1,0 --lidar robot_tty --start 1 --no-record", "--start"),
    "daemon_map_no_lidar": c("daemon --map maps/good.yaml --no-record", "--lidar"),
    "daemon_start_no_map": c("daemon --start 1,0 --no-record", "--start"),
    "daemon_service_map_missing": c(
        f"daemon --lidar robot_tty --map {MISSING} --no-record", "missing.yaml"
    ),
    "daemon_service_start_in_wall": c(
        "daemon --lidar robot_tty --map maps/good.yaml --start 1000,0 --no-record", "outside"
    ),
    "goal_no_daemon": c("goal 1,2 --socket nowhere.sock", "no jackson daemon"),
    "goal_bad_pose": c("goal 1,x --socket nowhere.sock", "pose"),
    "cancel_no_daemon": c("cancel --socket nowhere.sock", "no jackson daemon"),
    "status_no_daemon": c("status --socket nowhere.sock", "no jackson daemon"),
    "localise_bad_pose": c("localise nan,0 --socket nowhere.sock", "pose"),
    "daemon_map_missing": c(
        f"daemon --goal 1,0 --lidar robot_tty --map {MISSING} --no-record", "missing.yaml"
    ),
    "daemon_map_garbage": c(
        "daemon --goal 1,0 --lidar robot_tty --map maps/garbage.yaml --no-record", "garbage.yaml"
    ),
    "daemon_map_no_image": c(
        "daemon --goal 1,0 --lidar robot_tty --map maps/no_image.yaml --no-record", "nope.pgm"
    ),
    "daemon_goal_huge": c(
        "daemon --goal 1e308,1e308 --lidar nowhere/lidar --port nowhere/tty --no-record",
        "--goal: x and y must lie within",
    ),
    "daemon_start_huge": c(
        "daemon --goal 1,0 --start 0,-2e4 --lidar nowhere/lidar --port nowhere/tty --no-record",
        "--start: x and y must lie within",
    ),
    "daemon_route_too_wide_to_map": c(
        "daemon --goal 10000,10000 --start=-10000,-10000 --lidar nowhere/lidar "
        "--port nowhere/tty --no-record",
        "mapping as it goes covers at most",
    ),
    "daemon_good_map_then_lidar": c(
        "daemon --goal 1,0 --lidar nowhere/lidar --port nowhere/tty --no-record "
        "--map maps/full.yaml",
        "nowhere/lidar",
    ),
    "daemon_lidar_missing": c(
        "daemon --goal 1,0 --lidar nowhere/lidar --port robot_tty --no-record", "nowhere/lidar"
    ),
    "daemon_lidar_silent": c(
        "daemon --goal 1,0 --lidar robot_tty --port robot_tty --no-record", "GET_HEALTH"
    ),
    # Stage 3 on the twin
    "map_world_missing": c(f"map --world {MISSING}", "missing.yaml"),
    "map_waypoint_text": c(f"map --world {GOOD_WORLD} --waypoint a,b", "--waypoint"),
    "map_seed": c("map --seed -1", "--seed"),
    "map_out_file": c(f"map --world {GOOD_WORLD} --out a_file", "a_file"),
    "patrol_map_missing": c(f"patrol --map {MISSING}", "missing.yaml"),
    "patrol_map_garbage": c("patrol --map maps/garbage.yaml", "garbage.yaml"),
    "patrol_map_not_of_the_world": c("patrol --map maps/full.yaml", "not a map of this world"),
    "run_ofat": c("run ofat", "ofat"),
    "run_maze_map_missing": c(f"run maze --map {MISSING}", "missing.yaml"),
    "run_square_map": c("run square --map maps/good.yaml", "--map"),
    "campaign_ofat_map_file": c("campaign ofat --map a_file", "a_file"),
    "run_maze_goal_huge": c("run maze --goal 1e308,1e308", "--goal: x and y must lie within"),
    "run_maze_goal_far": c("run maze --goal 0,-1e5", "--goal: x and y must lie within"),
    "run_maze_goal_inf": c("run maze --goal inf,0", "--goal"),
    "run_maze_good_map_bad_world": c(f"run maze --map maps/full.yaml --world {MISSING}", MISSING),
    "map_waypoint_huge": c(f"map --world {GOOD_WORLD} --waypoint 1e308,0", "--waypoint"),
    "campaign_robustness_trials": c("campaign robustness --trials 0", "--trials"),
    "calibrate_step_duty": c("calibrate step --duty 1.5", "--duty"),
    "calibrate_step_runs_missing": c("calibrate step --runs nowhere/run", "nowhere/run"),
    # monitor
    "monitor_port_missing": c("monitor --port nowhere/tty", "nowhere/tty"),
    "monitor_port_folder": c("monitor --port a_folder", "a_folder"),
    "monitor_duration": c("monitor --port nowhere/tty --duration -2", "--duration"),
    "monitor_duration_nan": c("monitor --port nowhere/tty --duration nan", "--duration"),
    "monitor_baudrate": c("monitor --port nowhere/tty --baudrate 0", "--baudrate"),
    "monitor_no_port": c("monitor", "--port"),
    # sim
    "sim_world_missing": c(f"sim --world {MISSING}", "missing.yaml"),
    "sim_world_nan_wall": c("sim --world worlds/nan_wall.yaml", "walls[0]"),
    "sim_world_zero_wall": c("sim --world worlds/zero_wall.yaml", "walls[0]"),
    "sim_world_start": c("sim --world worlds/start_in_wall.yaml", "start_pose"),
    "sim_robot_nan": c("sim --robot robots/nan.yaml", "wheel_radius_m"),
    "sim_robot_syntax": c("sim --robot robots/syntax.yaml", "syntax.yaml"),
    "sim_link_file": c("sim --link a_file --duration 1", "a_file"),
    "sim_link_folder": c("sim --link a_folder --duration 1", "a_folder"),
    "sim_link_in_missing": c("sim --link nowhere/robot --duration 1", "nowhere"),
    "sim_i2c_file": c("sim --i2c a_file --duration 1", "a_file"),
    "sim_i2c_in_missing": c("sim --i2c nowhere/i2c.sock --duration 1", "nowhere"),
    "sim_duration": c("sim --duration -1", "--duration"),
    "sim_duration_nan": c("sim --duration nan", "--duration"),
    "sim_boot_id": c("sim --boot-id 0", "--boot-id"),
    "sim_heartbeat": c("sim --heartbeat-timeout 0", "--heartbeat-timeout"),
    "sim_spin": c("sim --spin-us -5", "--spin-us"),
    "sim_seed": c("sim --seed x", "--seed"),
    # bag
    "bag_no_action": c("bag", "ACTION"),
    "bag_repair_missing": c("bag repair runs/nowhere", "runs/nowhere"),
    "bag_repair_file": c("bag repair a_file", "a_file"),
    "bag_repair_no_bag": c("bag repair a_folder", "a_folder"),
    "bag_info_no_bag": c("bag info runs/good", "runs/good"),
    # brake
    "brake_address": c("brake --address 0x99", "--address"),
    "brake_config_missing": c(f"brake --config {MISSING}", "missing.yaml"),
    # the brake reads only the motor output's sections (a broken estimator section still
    # brakes: tests/host/test_brake.py); a broken PCA9685 section is refused
    "brake_config_pca": c("brake --config configs/pca_address.yaml", "pca9685.address"),
    # faults
    "faults_out_file": c("faults --short --out a_file", "a_file"),
    # calibrate
    "cal_no_procedure": c("calibrate", "PROCEDURE"),
    "cal_encoders_neither": c("calibrate encoders", "--port"),
    "cal_encoders_both": c("calibrate encoders --port x --runs runs/good", "--runs"),
    "cal_encoders_count": c("calibrate encoders --runs runs/good --count 0", "--count"),
    "cal_encoders_length_nan": c("calibrate encoders --runs runs/good --length nan", "--length"),
    "cal_encoders_distance_nan": c(
        "calibrate encoders --runs runs/good --distance nan", "--distance"
    ),
    "cal_encoders_runs_missing": c("calibrate encoders --runs runs/nowhere", "runs/nowhere"),
    "cal_encoders_runs_file": c("calibrate encoders --runs a_file", "a_file"),
    "cal_encoders_runs_empty": c("calibrate encoders --runs runs/empty", "runs/empty"),
    "cal_encoders_runs_damaged": c("calibrate encoders --runs runs/no_log", "log.jrec"),
    "cal_encoders_port_missing": c("calibrate encoders --port nowhere/tty", "nowhere/tty"),
    "cal_encoders_config": c(
        f"calibrate encoders --runs runs/good --config {MISSING}", "missing.yaml"
    ),
    "cal_encoders_write_folder": c(
        "calibrate encoders --runs runs/good --distance 1 --write a_folder", "a_folder"
    ),
    "cal_track_rate": c("calibrate track --runs runs/good --rate -1", "--rate"),
    "cal_track_true_turns": c("calibrate track --runs runs/good --true-turns nan", "--true-turns"),
    "cal_imu_rotation": c("calibrate imu --runs runs/good --rotation 1,2,3", "--rotation"),
    "cal_imu_rotation_nan": c(
        "calibrate imu --runs runs/good --rotation nan,0,0,0,1,0,0,0,1", "--rotation"
    ),
    "cal_imu_still": c("calibrate imu --runs runs/good --still 0", "--still"),
    "cal_deadband_duty": c("calibrate deadband --runs runs/good --max-duty 2", "--max-duty"),
    "cal_deadband_persist": c("calibrate deadband --runs runs/good --persist 0", "--persist"),
    "cal_char_duty": c("calibrate characterise --runs runs/good --duty 0", "--duty"),
    "cal_char_rate": c("calibrate characterise --port nowhere/tty --rate 9999", "--rate"),
    "cal_char_seconds_nan": c("calibrate characterise --runs runs/good --seconds nan", "--seconds"),
    "cal_fit_reference": c(
        "calibrate twin-fit --runs runs/good --reference nowhere.csv", "nowhere.csv"
    ),
    "cal_fit_reference_garbage": c(
        "calibrate twin-fit --runs runs/good --reference captures/garbage.bin", "garbage.bin"
    ),
    "cal_fit_yaw_weight": c("calibrate twin-fit --runs runs/good --yaw-weight nan", "--yaw-weight"),
    "cal_fit_heading": c("calibrate twin-fit --runs runs/good --heading compass", "compass"),
}

# every bad map through both commands that take one; the daemon checks it before it opens the
# LiDAR or the serial port (both missing here: were the map accepted, the line would name them)
CASES.update(
    {
        f"run_maze_map_{name}": c(f"run maze --map maps/{name}.yaml", f"{name}.yaml: {field}")
        for name, (_, field) in BAD_MAPS.items()
    }
)
CASES.update(
    {
        f"daemon_map_{name}": c(
            "daemon --goal 1,0 --lidar nowhere/lidar --port nowhere/tty --no-record "
            f"--map maps/{name}.yaml",
            f"{name}.yaml: {field}",
        )
        for name, (_, field) in BAD_MAPS.items()
    }
)


def _tree(root: Path) -> dict[str, tuple[bool, int, int]]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st = p.lstat()
            out[str(p.relative_to(root))] = (p.is_dir(), st.st_size, st.st_mtime_ns)
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input_is_one_line_and_its_exit_status(
    name: str,
    corpus: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    case = CASES[name]
    work = tmp_path / "work"
    shutil.copytree(corpus, work, symlinks=True)
    monkeypatch.chdir(work)
    before = _tree(work)
    try:
        rc = main(list(case.argv))
    except SystemExit as exc:  # argparse
        rc = exc.code if isinstance(exc.code, int) else 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert rc == case.status, f"exit {rc}, stderr: {err!r}"
    assert len(lines) == 1, f"expected one line on stderr, got {lines!r}"
    assert lines[0].startswith("jackson"), lines[0]
    assert case.says in lines[0], f"{case.says!r} not in {lines[0]!r}"
    assert _tree(work) == before, "the command left something behind or changed a file"


def test_the_corpus_is_large() -> None:
    assert len(CASES) >= 80


# ------------------------------------------------------------------------- as a user runs it


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "square", "--robot", MISSING],
        ["replay", "runs/meta_mission"],
        ["sim", "--world", "worlds/nan_wall.yaml"],
        ["campaign", "square", "--workers", "0"],
        ["run", "maze", "--map", "maps/huge_image.yaml"],
        ["run", "maze", "--goal", "1e308,1e308"],
        ["daemon", "--goal", "1,0", "--lidar", "x", "--map", "maps/res_tiny.yaml", "--no-record"],
        ["daemon", "--goal", "1e308,1e308", "--lidar", "x", "--no-record"],
    ],
)
def test_the_installed_command_answers_in_one_line(
    argv: list[str], corpus: Path, tmp_path: Path
) -> None:
    work = tmp_path / "work"
    shutil.copytree(corpus, work, symlinks=True)  # robot_tty: a pty, not a file to copy
    before = _tree(work)
    out = subprocess.run([*JACKSON, *argv], cwd=work, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert "Traceback" not in out.stderr
    assert _tree(work) == before


def test_sim_link_never_deletes_the_users_file(corpus: Path, tmp_path: Path) -> None:
    target = tmp_path / "notes.txt"
    target.write_text("precious\n")
    out = subprocess.run(
        [*JACKSON, "sim", "--link", str(target), "--duration", "0.1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2, out.stderr
    assert target.read_text() == "precious\n"
    assert str(target) in out.stderr


def test_the_good_files_of_the_corpus_are_accepted(
    corpus: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The damage is what the cases above refuse: the undamaged run replays bit for bit, and a
    capture of two frames with equal MCU times is summarised."""
    monkeypatch.chdir(corpus)
    assert main(["replay", "runs/good", "--out", str(tmp_path / "replayed")]) == 0
    assert main(["decode", "--summary", "captures/equal_times.bin"]) == 0
    assert main(["decode", "--summary", "captures/garbage.bin"]) == 0
    assert main(["decode", "--summary", "captures/empty.bin"]) == 0
    out = capsys.readouterr().out
    assert "frames_ok=2" in out


def test_bench_without_its_peer_library_says_what_to_install(tmp_path: Path) -> None:
    """A user without the dev extra: the protocol suite's peer (pymavlink) is missing."""
    shadow = tmp_path / "shadow" / "pymavlink"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text(
        "raise ModuleNotFoundError(\"No module named 'pymavlink'\", name='pymavlink')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(shadow.parent)}
    out = subprocess.run(
        [*JACKSON, "bench", "--quick", "--suite", "protocol", "--out", str(tmp_path / "b.json")],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    assert "pymavlink" in out.stderr and "make setup" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "b.json").exists()


# ------------------------------------------------------------------------- hostile numbers
# Every number a user types, on every subcommand: NaN, infinities, -0, 1e309, huge, negative
# where it is not allowed, empty, two numbers for one, units; negative coordinates that are
# values, not options; YAML numbers of every spelling and fields of the wrong type.

SPEED_CONFIGS: dict[str, tuple[str, str]] = {  # configs/<name>.yaml -> (its text, the line)
    "square_v_1000": (
        "square:\n  v_max_m_s: 1000\n",
        "square.v_max_m_s: expected a number in (0, 10], got 1000",
    ),
    "square_v_1e9": (
        "square:\n  v_max_m_s: 1e9\n",
        "square.v_max_m_s: expected a number in (0, 10], got 1e+09",
    ),
    "square_vmin_e": (
        "square:\n  v_min_m_s: 2.0e3\n",
        "square.v_min_m_s: expected a number in (0, 10], got 2000",
    ),
    "square_w_e": (
        "square:\n  w_max_rad_s: 1.0e+3\n",
        "square.w_max_rad_s: expected a number in (0, 100], got 1000",
    ),
    "square_v_text": (
        "square:\n  v_max_m_s: fast\n",
        "square.v_max_m_s: expected a number > 0, got 'fast'",
    ),
    "square_v_units": (
        "square:\n  v_max_m_s: 0.15 m/s\n",
        "square.v_max_m_s: expected a number > 0, got '0.15 m/s'",
    ),
    "square_v_comma": (
        "square:\n  v_max_m_s: 0,15\n",
        "square.v_max_m_s: expected a number > 0, got '0,15'",
    ),
    "square_v_list": (
        "square:\n  v_max_m_s: [0.1, 0.2]\n",
        "square.v_max_m_s: expected a number > 0, got [0.1, 0.2]",
    ),
    "square_v_bool": (
        "square:\n  v_max_m_s: true\n",
        "square.v_max_m_s: expected a number > 0, got true",
    ),
    "square_v_null": (
        "square:\n  v_max_m_s: null\n",
        "square.v_max_m_s: expected a number > 0, got null",
    ),
    "square_v_inf": (
        "square:\n  v_max_m_s: .inf\n",
        "square.v_max_m_s: expected a number > 0, got inf",
    ),
    "square_v_nan": (
        "square:\n  v_max_m_s: .nan\n",
        "square.v_max_m_s: expected a number > 0, got nan",
    ),
    "square_v_minus_zero": (
        "square:\n  v_max_m_s: -0.0\n",
        "square.v_max_m_s: expected a number > 0, got -0.0",
    ),
    "square_v_hex": (
        "square:\n  v_max_m_s: 0xff\n",
        "square.v_max_m_s: expected a number in (0, 10], got 255",
    ),
    "square_side_text": (
        "square:\n  side_m: one\n",
        "square.side_m: expected a number > 0, got 'one'",
    ),
    "square_list": (
        "square:\n  - v_max_m_s\n",
        "square: expected a mapping of fields",
    ),
    "figure8_v_1000": (
        "figure8:\n  v_m_s: 1000\n",
        "figure8.v_m_s: expected a number in (0, 10], got 1000",
    ),
    "figure8_v_e": (
        "figure8:\n  v_m_s: 1.0e9\n",
        "figure8.v_m_s: expected a number in (0, 10], got 1e+09",
    ),
    "figure8_w_huge": (
        "figure8:\n  w_rad_s: 1e300\n",
        "figure8.w_rad_s: expected a number in (0, 100], got 1e+300",
    ),
    "figure8_v_1e309": (
        "figure8:\n  v_m_s: 1e309\n",
        "figure8.v_m_s: expected a number > 0, got inf",
    ),
    "figure8_scalar": (
        "figure8: 0.08\n",
        "figure8: expected a mapping of fields",
    ),
    "nav_v_1000": (
        "navigation:\n  max_vel_x_m_s: 1000\n",
        "navigation.max_vel_x_m_s: expected a number in (0, 10], got 1000",
    ),
    "nav_v_e": (
        "navigation:\n  max_vel_x_m_s: 1.0e6\n",
        "navigation.max_vel_x_m_s: expected a number in (0, 10], got 1e+06",
    ),
    "nav_v_negative": (
        "navigation:\n  max_vel_x_m_s: -0.1\n",
        "navigation.max_vel_x_m_s: expected a number > 0 or null, got -0.1",
    ),
    "nav_v_text": (
        "navigation:\n  max_vel_x_m_s: max\n",
        "navigation.max_vel_x_m_s: expected a number > 0 or null, got 'max'",
    ),
    "limits_v_e": (
        "limits:\n  max_v_m_s: 3.0e2\n",
        "limits.max_v_m_s: expected a number in (0, 10], got 300",
    ),
    "limits_w_huge": (
        "limits:\n  max_w_rad_s: 1e6\n",
        "limits.max_w_rad_s: expected a number in (0, 100], got 1e+06",
    ),
    "robot_radius_e": (
        "robot:\n  wheel_radius_m: 3.3e-2\n  wheel_separation_m: 1.98e9\n",
        "robot.wheel_separation_m: expected a number in (0, 5], got 1980000000.0",
    ),
}


def _flip(run: Path, what: str) -> None:
    """Damage the log of a copy of runs/good: a record's length or kind, as a flipped bit."""
    data = bytearray((run / "log.jrec").read_bytes())
    offsets, pos = [], 8
    while pos + 11 <= len(data):
        offsets.append(pos)
        pos += 11 + int.from_bytes(data[pos + 9 : pos + 11], "little")
    at = offsets[len(offsets) // 2]
    if what == "length":  # runs past the end of a log that goes on to its end record
        data[at + 9 : at + 11] = (0xF000).to_bytes(2, "little")
    else:
        data[at] = 0x7F
    (run / "log.jrec").write_bytes(bytes(data))


def _hostile_files(root: Path) -> None:
    """The files the hostile cases name, beside the corpus's."""
    for name, (text, _) in SPEED_CONFIGS.items():
        _write(root, f"configs/{name}.yaml", text)
    for name in ("length", "kind"):
        shutil.copytree(root / "runs/good", root / f"runs/flip_{name}")
        _flip(root / f"runs/flip_{name}", name)
    _write(root, "bags/garbage/bag/bag_0.mcap", bytes(range(256)) * 16)
    _write(root, "bags/garbage_meta/bag/bag_0.mcap", b"PK\x03\x04" + bytes(4000))
    _write(
        root,
        "bags/garbage_meta/bag/metadata.yaml",
        "rosbag2_bagfile_information:\n  version: 5\n  relative_file_paths: [bag_0.mcap]\n",
    )


def h(argv: str | list[str], says: str, status: int = 2) -> Case:
    """A case whose arguments may hold an empty one or spaces (a list, as the shell passes)."""
    return Case(tuple(argv.split() if isinstance(argv, str) else argv), says, status)


NO_REC = "--no-record --port nowhere/tty"
CAL = "calibrate encoders --runs runs/good"

HOSTILE: dict[str, Case] = {
    # negative coordinates are values: each line names what is wrong after them, not the option
    "neg_run_goal_far": h("run maze --goal -0.5,1e308", "--goal: x and y must lie within"),
    "neg_run_goal_huge": h("run maze --goal -1e308,0", "--goal: x and y must lie within"),
    "neg_run_goal_square": h("run square --goal -0.5,1", "--map and --goal are for the maze"),
    "neg_run_goal_inf": h("run maze --goal -inf,0", "argument --goal: expected x,y"),
    "neg_run_goal_nan": h("run maze --goal -nan,0", "argument --goal: expected x,y"),
    "neg_run_goal_one": h("run maze --goal -0.5", "argument --goal: expected x,y"),
    "neg_run_goal_four": h("run maze --goal -1,-2,-3,-4", "argument --goal: expected x,y"),
    "neg_map_waypoint_far": h(f"map --world {GOOD_WORLD} --waypoint -1e308,0", "--waypoint"),
    "neg_map_waypoint_text": h("map --waypoint -1,y", "argument --waypoint: expected x,y"),
    "neg_daemon_goal": h("daemon --goal -1,0 --no-record", "--goal needs --lidar"),
    "neg_daemon_start": h("daemon --start -0.69,-0.04,0 --no-record", "--start needs --lidar"),
    "neg_daemon_start_far": h(
        f"daemon --goal 1,0 --start -0.5,-2e4 --lidar nowhere/lidar {NO_REC}",
        "--start: x and y must lie within",
    ),
    "neg_daemon_stage3_doc": h(
        f"daemon --lidar nowhere/lidar --start -0.69,-0.04,0 --goal 1.21,-0.04 {NO_REC}",
        "nowhere/lidar",
    ),
    "neg_goal": h("goal -1,2 --socket nowhere.sock", "no jackson daemon"),
    "neg_goal_yaw": h("goal -1,-2,-3.1 --socket nowhere.sock", "no jackson daemon"),
    "neg_goal_text": h("goal -1,x --socket nowhere.sock", "pose"),
    "neg_localise": h("localise -0.5,-1e308 --socket nowhere.sock", "pose"),
    "neg_rotation_short": h("calibrate imu --runs runs/good --rotation -1,0,0", "--rotation"),
    "neg_rotation_nan": h(
        "calibrate imu --runs runs/good --rotation -nan,0,0,0,1,0,0,0,1", "--rotation"
    ),
    "neg_step_duty_e": h("calibrate step --duty -7e-1 --runs nowhere/run", "argument --duty"),
    # --start, --goal, --waypoint: two or three finite numbers, named where parsed
    "daemon_start_one": h("daemon --start 1 --no-record", "argument --start"),
    "daemon_start_four": h("daemon --start 1,2,3,4 --no-record", "argument --start"),
    "daemon_start_empty": h(["daemon", "--start", "", "--no-record"], "argument --start"),
    "daemon_start_units": h("daemon --start 1m,2m --no-record", "argument --start"),
    "daemon_start_semicolon": h("daemon --start 1;2 --no-record", "argument --start"),
    "daemon_start_inf": h("daemon --start inf,0 --no-record", "argument --start"),
    "daemon_start_1e309": h("daemon --start 1e309,0 --no-record", "argument --start"),
    "daemon_goal_space": h(["daemon", "--goal", "1, 2, x", "--no-record"], "argument --goal"),
    "daemon_goal_empty": h(["daemon", "--goal", "", "--no-record"], "argument --goal"),
    "run_goal_double_comma": h("run maze --goal 1,,2", "argument --goal"),
    "map_waypoint_units": h("map --waypoint 1m,0", "argument --waypoint"),
    # --i2c names the option, whatever the serial port
    "daemon_i2c_banana": h("daemon --i2c banana --no-record", "argument --i2c"),
    "daemon_i2c_unix_empty": h("daemon --i2c unix: --no-record", "argument --i2c"),
    "daemon_i2c_dev_text": h("daemon --i2c /dev/i2c-x --no-record", "argument --i2c"),
    "daemon_i2c_negative": h("daemon --i2c -1 --no-record", "argument --i2c"),
    # the daemon's numbers
    "daemon_max_seconds_inf": h("daemon --max-seconds inf --no-record", "--max-seconds"),
    "daemon_max_seconds_1e309": h("daemon --max-seconds 1e309 --no-record", "--max-seconds"),
    "daemon_max_seconds_huge": h("daemon --max-seconds 1e300 --no-record", "--max-seconds"),
    "daemon_max_seconds_minus_zero": h("daemon --max-seconds -0 --no-record", "--max-seconds"),
    "daemon_max_seconds_empty": h(["daemon", "--max-seconds", "", "--no-record"], "--max-seconds"),
    "daemon_max_seconds_units": h("daemon --max-seconds 10s --no-record", "--max-seconds"),
    "daemon_max_seconds_comma": h("daemon --max-seconds 1,5 --no-record", "--max-seconds"),
    "daemon_timeout_negative": h("daemon --mission-timeout -5 --no-record", "--mission-timeout"),
    "daemon_timeout_nan": h("daemon --mission-timeout nan --no-record", "--mission-timeout"),
    "daemon_timeout_units": h("daemon --mission-timeout 5min --no-record", "--mission-timeout"),
    "daemon_stall_zero": h("daemon --stall-timeout 0 --no-record", "--stall-timeout"),
    "daemon_stall_minus_zero": h("daemon --stall-timeout -0.0 --no-record", "--stall-timeout"),
    "daemon_stall_inf": h("daemon --stall-timeout -inf --no-record", "--stall-timeout"),
    "daemon_live_view_negative": h("daemon --live-view -1 --no-record", "--live-view"),
    "daemon_live_view_big": h("daemon --live-view 65536 --no-record", "--live-view"),
    "daemon_live_view_nan": h("daemon --live-view nan --no-record", "--live-view"),
    "daemon_live_view_no_host": h("daemon --live-view :8765 --no-record", "--live-view"),
    # the twin's runs and campaigns
    "run_seed_nan": h("run square --seed nan", "--seed"),
    "run_seed_1e309": h("run square --seed 1e309", "--seed"),
    "run_seed_fraction": h("run square --seed 1.5", "--seed"),
    "run_seed_empty": h(["run", "square", "--seed", ""], "--seed"),
    "run_seed_comma": h("run square --seed 1,2", "--seed"),
    "run_fault_lidar_garbage": h("run square --fault lidar_garbage@1", "--fault lidar_garbage"),
    "run_fault_lidar_closed": h("run figure8 --fault lidar_closed@0", "--fault lidar_closed"),
    "run_fault_lidar_noise": h("run square --fault lidar_noise@0", "--fault lidar_noise"),
    "run_fault_lidar_dropout": h("run figure8 --fault lidar_dropout@2+1", "--fault lidar_dropout"),
    "run_fault_at_nan": h("run square --fault wheel_slip@nan", "--fault"),
    "run_fault_at_negative": h("run square --fault wheel_slip@-1", "--fault"),
    "campaign_trials_nan": h("campaign square --trials nan", "--trials"),
    "campaign_trials_inf": h("campaign square --trials inf", "--trials"),
    "campaign_trials_1e309": h("campaign square --trials 1e309", "--trials"),
    "campaign_trials_huge": h("campaign square --trials 1e12", "--trials"),
    "campaign_trials_fraction": h("campaign square --trials 2.5", "--trials"),
    "campaign_trials_minus_zero": h("campaign square --trials -0", "--trials"),
    "campaign_trials_empty": h(["campaign", "square", "--trials", ""], "--trials"),
    "campaign_trials_units": h("campaign square --trials 10x", "--trials"),
    "campaign_workers_huge": h("campaign square --workers 1e6", "--workers"),
    "campaign_workers_comma": h("campaign square --workers 2,3", "--workers"),
    "campaign_workers_neg_inf": h("campaign square --workers -inf", "--workers"),
    "patrol_goals_zero": h("patrol --goals 0", "--goals"),
    "patrol_goals_negative": h("patrol --goals -3", "--goals"),
    "patrol_goals_nan": h("patrol --goals nan", "--goals"),
    "patrol_seed_negative": h("patrol --seed -1", "--seed"),
    "map_seed_inf": h("map --seed inf", "--seed"),
    # the twin alone
    "sim_duration_inf": h("sim --duration inf", "--duration"),
    "sim_duration_1e309": h("sim --duration 1e309", "--duration"),
    "sim_duration_minus_zero": h("sim --duration -0", "--duration"),
    "sim_boot_id_negative": h("sim --boot-id -1", "--boot-id"),
    "sim_boot_id_huge": h("sim --boot-id 1e10", "--boot-id"),
    "sim_heartbeat_nan": h("sim --heartbeat-timeout nan", "--heartbeat-timeout"),
    "sim_stall_negative": h("sim --stall-timeout -1", "--stall-timeout"),
    "sim_spin_inf": h("sim --spin-us inf", "--spin-us"),
    "sim_seed_fraction": h("sim --seed 0.5", "--seed"),
    # the serial monitor, the brake, the navigation service's clients
    "monitor_baudrate_negative": h("monitor --port nowhere/tty --baudrate -9600", "--baudrate"),
    "monitor_baudrate_fraction": h("monitor --port nowhere/tty --baudrate 9600.5", "--baudrate"),
    "monitor_baudrate_units": h("monitor --port nowhere/tty --baudrate 9600baud", "--baudrate"),
    "monitor_duration_inf": h("monitor --port nowhere/tty --duration inf", "--duration"),
    "monitor_duration_empty": h(["monitor", "--port", "x", "--duration", ""], "--duration"),
    "brake_address_negative": h("brake --address -1", "--address"),
    "brake_address_nan": h("brake --address nan", "--address"),
    "brake_address_big": h("brake --address 0x100", "--address"),
    "cancel_id_negative": h("cancel --id -1 --socket nowhere.sock", "--id"),
    "cancel_id_fraction": h("cancel --id 0.5 --socket nowhere.sock", "--id"),
    # calibration
    "cal_count_negative": h(f"{CAL} --count -1", "--count"),
    "cal_count_1e309": h(f"{CAL} --count 1e309", "--count"),
    "cal_length_zero": h(f"{CAL} --length 0", "--length"),
    "cal_length_huge": h(f"{CAL} --length 51", "--length"),
    "cal_length_units": h(f"{CAL} --length 1m", "--length"),
    "cal_length_inf": h(f"{CAL} --length inf", "--length"),
    "cal_distance_negative": h(f"{CAL} --distance -1", "--distance"),
    "cal_speed_huge": h(f"{CAL} --speed 3", "--speed"),
    "cal_speed_negative": h(f"{CAL} --speed -0.15", "--speed"),
    "cal_track_turns_zero": h("calibrate track --runs runs/good --turns 0", "--turns"),
    "cal_track_turns_huge": h("calibrate track --runs runs/good --turns 1e9", "--turns"),
    "cal_track_rate_neg_inf": h("calibrate track --runs runs/good --rate -inf", "--rate"),
    "cal_imu_still_huge": h("calibrate imu --runs runs/good --still 3601", "--still"),
    "cal_imu_spin_negative": h("calibrate imu --runs runs/good --spin -4", "--spin"),
    "cal_deadband_duty_negative": h(
        "calibrate deadband --runs runs/good --max-duty -0.5", "--max-duty"
    ),
    "cal_deadband_duty_percent": h(
        "calibrate deadband --runs runs/good --max-duty 60%", "--max-duty"
    ),
    "cal_char_duty_nan": h("calibrate characterise --runs runs/good --duty nan", "--duty"),
    "cal_char_duty_negative": h("calibrate characterise --runs runs/good --duty -1.5", "--duty"),
    "cal_char_seconds_minus_zero": h(
        "calibrate characterise --runs runs/good --seconds -0", "--seconds"
    ),
    "cal_step_seconds_huge": h("calibrate step --runs runs/good --seconds 601", "--seconds"),
    "cal_fit_yaw_weight_inf": h(
        "calibrate twin-fit --runs runs/good --yaw-weight inf", "--yaw-weight"
    ),
    # replay of a damaged log: damaged, where, never "cut"
    "replay_flip_length": h("replay runs/flip_length", "the log is damaged"),
    "replay_flip_kind": h("replay runs/flip_kind", "the log is damaged"),
    # a garbage file where a bag goes: not a bag, and no advice to repair it
    "bag_repair_garbage": h("bag repair bags/garbage", "so not a bag"),
    "bag_repair_garbage_meta": h("bag repair bags/garbage_meta", "so not a bag"),
    "bag_info_garbage": h("bag info bags/garbage", "so not a bag"),
}
HOSTILE.update(
    {  # the host config's numbers, as the daemon and the twin read them
        f"config_{name}": h(f"daemon --config configs/{name}.yaml {NO_REC}", f"{name}.yaml: {says}")
        for name, (_, says) in SPEED_CONFIGS.items()
    }
)
HOSTILE.update(
    {
        "run_config_square_speed": h(
            "run square --config configs/square_v_1000.yaml", "square.v_max_m_s"
        ),
        "run_config_figure8_speed": h(
            "run figure8 --config configs/figure8_v_e.yaml", "figure8.v_m_s"
        ),
        "map_config_nav_speed": h("map --config configs/nav_v_e.yaml", "navigation.max_vel_x_m_s"),
    }
)


@pytest.mark.parametrize("name", list(HOSTILE))
def test_hostile_numbers_are_one_line_naming_the_option_or_field(
    name: str,
    corpus: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    case = HOSTILE[name]
    work = tmp_path / "work"
    shutil.copytree(corpus, work, symlinks=True)
    _hostile_files(work)
    monkeypatch.chdir(work)
    before = _tree(work)
    try:
        rc = main(list(case.argv))
    except SystemExit as exc:  # argparse
        rc = exc.code if isinstance(exc.code, int) else 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err, err
    assert rc == case.status, f"exit {rc}, stderr: {err!r}"
    assert len(lines) == 1, f"expected one line on stderr, got {lines!r}"
    assert lines[0].startswith("jackson"), lines[0]
    assert case.says in lines[0], f"{case.says!r} not in {lines[0]!r}"
    assert "jackson bag repair" not in lines[0] or "bag info" in " ".join(case.argv)
    assert _tree(work) == before, "the command left something behind or changed a file"


def test_the_hostile_cases_are_new_and_many() -> None:
    assert len(HOSTILE) >= 100
    assert not set(HOSTILE) & set(CASES)


def test_replay_never_counts_below_zero(
    corpus: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A run file emptied by a crash holds 0 rows, not -1."""
    run = tmp_path / "run"
    shutil.copytree(corpus / "runs/good", run)
    (run / "odometry.csv").write_text("")
    assert main(["replay", str(run), "--out", str(tmp_path / "out")]) == 1
    out = capsys.readouterr().out
    assert "odometry.csv: 0 rows in the run" in out
    assert not re.search(r"-\d+ rows|-\d+ replayed|-\d+ more", out), out


# -------------------------------------------------- physical bounds (robot, world and map files)

_PHYSICAL_ROBOT = (Path(__file__).parent.parent / "sim/robots/jackson_physical.yaml").read_text()
_PHYSICAL_ROOM = (
    "walls:\n  - [-3, -3, 3, -3]\n  - [3, -3, 3, 3]\n  - [3, 3, -3, 3]\n  - [-3, 3, -3, -3]\n"
)
PHYSICAL: dict[str, tuple[str, str, str, str]] = {
    # name: (file, its text, the command line, what the one line names)
    "robot_mass_1e30": (
        "heavy.yaml",
        _PHYSICAL_ROBOT.replace("mass_kg: 2.0", "mass_kg: 1.0e+30", 1),
        "run square --robot heavy.yaml",
        "heavy.yaml: mass_kg: expected a number in [0.1, 100]",
    ),
    "sim_robot_mass_1e30": (
        "heavy.yaml",
        _PHYSICAL_ROBOT.replace("mass_kg: 2.0", "mass_kg: 1.0e+30", 1),
        "sim --robot heavy.yaml",
        "heavy.yaml: mass_kg: expected a number in [0.1, 100]",
    ),
    "robot_wheel_1mm": (
        "r.yaml",
        "wheel_radius_m: 0.001\n",
        "run square --robot r.yaml",
        "r.yaml: wheel_radius_m: expected a number in [0.005, 0.5]",
    ),
    "robot_separation_1km": (
        "r.yaml",
        "wheel_separation_m: 1000\n",
        "run figure8 --robot r.yaml",
        "r.yaml: wheel_separation_m",
    ),
    "robot_inertia_huge": (
        "r.yaml",
        "inertia_kg_m2: 1.0e+12\n",
        "sim --robot r.yaml",
        "r.yaml: inertia_kg_m2",
    ),
    "robot_rpm_1e9": (
        "r.yaml",
        "motor:\n  no_load_rpm: 1.0e+9\n",
        "run square --robot r.yaml",
        "r.yaml: motor.no_load_rpm",
    ),
    "robot_torque_1e6": (
        "r.yaml",
        "motor:\n  stall_torque_nm: 1.0e+6\n",
        "run square --robot r.yaml",
        "r.yaml: motor.stall_torque_nm",
    ),
    "robot_battery_1kv": (
        "r.yaml",
        "motor:\n  battery_v: 1000\n",
        "run square --robot r.yaml",
        "r.yaml: motor.battery_v",
    ),
    "robot_lidar_mount_far": (
        "r.yaml",
        "lidar:\n  mount_x_m: 1000\n",
        "run maze --robot r.yaml",
        "r.yaml: lidar.mount_x_m",
    ),
    "world_friction_50": (
        "w.yaml",
        "floor: {mu_static: 50, mu_dynamic: 0.7}\n" + _PHYSICAL_ROOM,
        "run square --world w.yaml",
        "w.yaml: floor.mu_static",
    ),
    "world_cylinder_1e6": (
        "w.yaml",
        _PHYSICAL_ROOM + "cylinders:\n  - {x: 2, y: 2, radius: 1.0e+6}\n",
        "run square --world w.yaml",
        "w.yaml: cylinders[0].radius",
    ),
    "world_trigger_radius_1e6": (
        "w.yaml",
        _PHYSICAL_ROOM
        + "triggers:\n  - when_moved_m: 0.5\n    add_cylinder: {x: 2, y: 2, radius: 1.0e+6}\n",
        "run maze --world w.yaml",
        "w.yaml: triggers[0].add_cylinder.radius",
    ),
    "world_trigger_on_the_robot": (
        "w.yaml",
        _PHYSICAL_ROOM
        + "triggers:\n  - when_moved_m: 0.3\n    add_cylinder: {x: 0.1, y: 0, radius: 1.5}\n",
        "run square --world w.yaml",
        "w.yaml: triggers[0].add_cylinder: the cylinder",
    ),
    "world_wall_far": (
        "w.yaml",
        "walls:\n  - [0, 0, 1.0e+7, 0]\n",
        "run square --world w.yaml",
        "w.yaml: walls[0]",
    ),
    "world_goal_far": (
        "w.yaml",
        _PHYSICAL_ROOM + "goal: [1.0e+7, 0]\n",
        "run maze --world w.yaml",
        "w.yaml: goal",
    ),
}


@pytest.mark.parametrize("name", list(PHYSICAL))
def test_a_file_outside_the_physical_bounds_is_one_line(
    name: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    filename, text, argv, says = PHYSICAL[name]
    (tmp_path / filename).write_text(text)
    monkeypatch.chdir(tmp_path)
    rc = main(argv.split())
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert "Traceback" not in err, err
    assert rc == 2, f"exit {rc}, stderr: {err!r}"
    assert len(lines) == 1 and lines[0].startswith("jackson"), lines
    assert says in lines[0], f"{says!r} not in {lines[0]!r}"
    assert sorted(p.name for p in tmp_path.iterdir()) == [filename]  # nothing left behind


@pytest.mark.parametrize("side", [5000, 10000])
def test_a_map_over_the_memory_bound_is_one_line(
    side: int,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """10 000 x 10 000 and 5 000 x 5 000 maps took ``jackson run maze`` past 4 GiB."""
    (tmp_path / "big.pgm").write_bytes(f"P5\n{side} {side}\n255\n".encode() + b"\0")
    (tmp_path / "big.yaml").write_text(
        "image: big.pgm\nresolution: 0.05\norigin: [-100, -100, 0]\noccupied_thresh: 0.65\n"
        "free_thresh: 0.196\nnegate: 0\n"
    )
    monkeypatch.chdir(tmp_path)
    rc = main(["run", "maze", "--map", "big.yaml"])
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert rc == 2
    assert len(lines) == 1 and f"{side} x {side} pixels" in lines[0], lines
    assert "10,000,000 in all" in lines[0] and "bytes of memory a cell" in lines[0]
