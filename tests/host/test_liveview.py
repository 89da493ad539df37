"""The live view (docs/host.md, The live view): the daemon's navigation service and the twin's
ground truth over the Foxglove WebSocket protocol, read by a client that speaks the protocol
itself (serverInfo, advertise, subscribe, binary messageData) and decodes each message with the
schema the server advertised (protobuf descriptors, JSON).

foxglove-sdk's server names the protocol ``foxglove.sdk.v1``: the messages of
``foxglove.websocket.v1`` under a new name, the only one it accepts in the handshake.
"""

from __future__ import annotations

import argparse
import base64
import json
import math
import queue
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from jackson.common.args import host_port
from jackson.common.liveview import Every, LiveServer, LiveViewError
from jackson.host.liveview import TOPICS, footprint, map_grid
from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.liveview import TOPICS as TWIN_TOPICS

websockets_sync = pytest.importorskip("websockets.sync.client")
descriptor_pb2 = pytest.importorskip("google.protobuf.descriptor_pb2")
from google.protobuf import descriptor_pool, message_factory  # noqa: E402
from google.protobuf.message import Message  # noqa: E402

JACKSON = str(Path(sys.executable).parent / "jackson")
SUBPROTOCOL = "foxglove.sdk.v1"  # foxglove.websocket.v1, renamed by foxglove-sdk
START = (1.5, 1.5, 0.55)  # hall_15m's start pose
GOAL = (7.5, 5.0)


# ---------------------------------------------------------------------- a Foxglove client


def decoder(schema_name: str, schema_b64: str) -> type[Message]:
    """The protobuf message class of an advertised channel (its FileDescriptorSet)."""
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64))
    pool = descriptor_pool.DescriptorPool()
    for f in files.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


@dataclass
class Received:
    """Messages of one channel: (log time [ns], decoded message)."""

    channel: dict[str, Any]
    messages: list[tuple[int, Any]] = field(default_factory=list)


class FoxgloveClient:
    """Connects, reads the advertised channels, subscribes to every one and decodes what
    arrives (protobuf with the advertised descriptors, JSON as JSON)."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        assert ws.subprotocol == SUBPROTOCOL
        self.info: dict[str, Any] = {}
        self.topics: dict[str, Received] = {}
        self._by_sub: dict[int, Received] = {}
        self._classes: dict[int, type[Message]] = {}

    def read(self, timeout_s: float) -> None:
        """Handle what arrives within ``timeout_s``."""
        try:
            data = self.ws.recv(timeout=timeout_s)
        except TimeoutError:
            return
        if isinstance(data, str):
            msg = json.loads(data)
            if msg["op"] == "serverInfo":
                self.info = msg
            elif msg["op"] == "advertise":
                for ch in msg["channels"]:
                    self.topics[ch["topic"]] = Received(ch)
                    sub = len(self._by_sub) + 1
                    self._by_sub[sub] = self.topics[ch["topic"]]
                    if ch["encoding"] == "protobuf":
                        self._classes[sub] = decoder(ch["schemaName"], ch["schema"])
                    self.ws.send(
                        json.dumps(
                            {
                                "op": "subscribe",
                                "subscriptions": [{"id": sub, "channelId": ch["id"]}],
                            }
                        )
                    )
            return
        assert data[0] == 0x01, data[:1]  # messageData
        sub, log_ns = struct.unpack_from("<IQ", data, 1)
        payload = bytes(data[13:])
        assert payload or self._by_sub[sub].channel["encoding"] == "protobuf"
        cls = self._classes.get(sub)
        value = cls.FromString(payload) if cls is not None else json.loads(payload)
        self._by_sub[sub].messages.append((log_ns, value))

    def got(self, *topics: str) -> bool:
        return all(t in self.topics and self.topics[t].messages for t in topics)

    def last(self, topic: str) -> Any:
        return self.topics[topic].messages[-1][1]


def until(clients: list[FoxgloveClient], condition: Any, timeout_s: float, what: str) -> None:
    """Read every client, in turn, until ``condition()`` holds (a bounded wait)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            got = [{t: len(r.messages) for t, r in c.topics.items()} for c in clients]
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}: {got}")
        for c in clients:
            c.read(0.02)


def connect(url: str) -> Any:
    """A WebSocket to ``url`` offering the protocol (a context manager)."""
    return websockets_sync.connect(
        url, subprotocols=[SUBPROTOCOL], max_size=None, proxy=None, close_timeout=1.0
    )


# ---------------------------------------------------------------------- the processes


class Process:
    """A ``jackson`` command whose stdout lines are collected by a thread."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [JACKSON, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        self.lines: queue.Queue[str] = queue.Queue()
        self.said: list[str] = []
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))

    def wait_line(self, prefix: str, timeout_s: float = 60.0) -> str:
        """The first line (after those already read) starting with ``prefix``."""
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or (self.proc.poll() is not None and self.lines.empty()):
                raise AssertionError(f"no line {prefix!r} in {timeout_s:g} s: {self.said}")
            try:
                line = self.lines.get(timeout=min(left, 0.5))
            except queue.Empty:
                continue
            self.said.append(line)
            if line.startswith(prefix):
                return line

    def stop(self) -> str:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        while not self.lines.empty():
            self.said.append(self.lines.get())
        return "\n".join(self.said)


@dataclass
class Robot:
    twin: Process
    daemon: Process
    socket: Path
    twin_url: str


def url_in(line: str) -> str:
    return next(w for w in line.split() if w.startswith("ws://"))


def start_robot(tmp_path: Path, daemon_live_view: str) -> Iterator[Robot]:
    """``jackson sim --world hall_15m --live-view 0`` and a navigation service daemon with
    ``--live-view daemon_live_view`` against it."""
    from jackson.experiments.stage3 import world_grid
    from jackson.sim.config import load_world

    world_grid(load_world("hall_15m")).save(tmp_path / "hall.yaml")
    twin = Process(
        "sim",
        "--world",
        "hall_15m",
        "--i2c",
        str(tmp_path / "i2c.sock"),
        "--lidar-link",
        str(tmp_path / "lidar"),
        "--link",
        str(tmp_path / "mcu"),
        "--live-view",
        "0",
    )
    daemon = None
    try:
        twin_url = url_in(twin.wait_line("live view: "))
        twin.wait_line("twin: ")
        sock = tmp_path / "daemon.sock"
        daemon = Process(
            "daemon",
            "--port",
            str(tmp_path / "mcu"),
            "--i2c",
            f"unix:{tmp_path / 'i2c.sock'}",
            "--lidar",
            str(tmp_path / "lidar"),
            "--map",
            str(tmp_path / "hall.yaml"),
            "--start",
            ",".join(map(str, START)),
            "--socket",
            str(sock),
            "--no-record",
            "--live-view",
            daemon_live_view,
        )
        yield Robot(twin, daemon, sock, twin_url)
    finally:
        said = daemon.stop() if daemon is not None else ""
        twin.stop()
        print(said)


def goal(robot: Robot, *more: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [JACKSON, "goal", f"{GOAL[0]},{GOAL[1]}", "--socket", str(robot.socket), *more],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[Robot]:
    yield from start_robot(tmp_path, "127.0.0.1:0")


def xy(pose: Any) -> tuple[float, float]:
    return pose.position.x, pose.position.y


def yaw_of(q: Any) -> float:
    return 2.0 * math.atan2(q.z, q.w)


# ---------------------------------------------------------------------- the tests


def test_live_view_address_is_host_port_on_localhost_by_default() -> None:
    assert host_port("8765") == ("127.0.0.1", 8765)
    assert host_port("0.0.0.0:9000") == ("0.0.0.0", 9000)
    assert host_port("[::1]:8765") == ("::1", 8765)
    assert host_port("0") == ("127.0.0.1", 0)
    for bad in ("", "x", "70000", ":8765", "host:", "-1"):
        with pytest.raises(argparse.ArgumentTypeError):
            host_port(bad)


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["daemon", "--live-view", "localhost:"], "argument --live-view: expected [HOST:]PORT"),
        (["sim", "--live-view", "99999"], "argument --live-view: expected [HOST:]PORT"),
        (
            ["daemon", "--live-view", "8765", "--no-record", "--port", "/nonexistent"],
            "--live-view shows the navigation service: give --lidar PORT and --map MAP",
        ),
    ],
)
def test_a_bad_live_view_option_is_one_line(
    argv: list[str], says: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from jackson.main import main

    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse
        rc = exc.code if isinstance(exc.code, int) else 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert rc == 2 and len(lines) == 1 and says in lines[0], lines


def test_a_topic_is_due_once_per_period_of_mcu_time() -> None:
    every = Every(0.1)
    due = [t for t in np.arange(0.0, 1.0001, 0.05) if every.due(float(t))]
    assert len(due) == 11  # 0.0, 0.1, ..., 1.0: 10 Hz on 20 Hz frames
    assert every.due(0.05)  # the clock went back (an MCU reset): due at once


def test_a_port_in_use_is_one_line() -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(LiveViewError) as err:
            LiveServer("test", "127.0.0.1", port).start()
    text = str(err.value)
    assert "\n" not in text and f"127.0.0.1:{port}" in text and "in use" in text, text


def test_the_map_grid_holds_occupancy_and_colours() -> None:
    data = np.full((3, 4), 0, np.int8)
    data[0, 0], data[2, 3] = 100, -1
    grid = OccupancyGrid(data, 0.05, -0.5, -0.25)
    msg = decoder("foxglove.Grid", base64.b64encode(map_grid(grid).get_schema().data).decode())
    g = msg.FromString(map_grid(grid).encode())
    assert (g.frame_id, g.column_count, g.cell_stride, g.row_stride) == ("map", 4, 5, 20)
    assert (g.cell_size.x, g.pose.position.x, g.pose.position.y) == (0.05, -0.5, -0.25)
    assert [f.name for f in g.fields] == ["occupancy", "red", "green", "blue", "alpha"]
    cells = np.frombuffer(g.data, np.uint8).reshape(3, 4, 5)
    assert cells[0, 0, 0].astype(np.int8) == 100 and tuple(cells[0, 0, 1:]) == (0, 0, 0, 255)
    assert cells[2, 3, 0].astype(np.int8) == -1 and cells[2, 3, 4] < 255  # unknown: see-through
    assert tuple(cells[1, 1, 1:]) == (235, 235, 235, 255)  # free: light grey


def test_the_footprint_is_the_robot_radius_around_base_link() -> None:
    update = footprint(0.16, "base_link")
    m = decoder("foxglove.SceneUpdate", base64.b64encode(update.get_schema().data).decode())
    s = m.FromString(update.encode())
    (entity,) = s.entities
    assert entity.frame_id == "base_link" and entity.frame_locked
    ring = entity.lines[0].points
    assert len(ring) == 36
    assert all(math.isclose(math.hypot(p.x, p.y), 0.16) for p in ring)


def service_view(tell: Any) -> tuple[Any, Any]:
    """A navigation service in a walled room (no robot) and its live view, serving on a free
    port."""
    from jackson.host.actuation.limiter import LimiterConfig
    from jackson.host.control.navigate import NavigateConfig
    from jackson.host.liveview import LiveView
    from jackson.host.nav.types import Pose2D
    from jackson.host.service.navigation import NavigationService
    from jackson.host.service.settings import ServiceSettings

    data = np.zeros((120, 120), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=())
    service = NavigationService(
        config, LimiterConfig(), OccupancyGrid(data, 0.05), ServiceSettings()
    )
    live = LiveView(
        service,
        LiveServer("test", "127.0.0.1", 0),
        sensors=lambda: {"imu": "ok"},
        problems=lambda: [],
        tell=tell,
    )
    return service, live


def frame_result(service: Any, t_s: float, k: int) -> Any:
    """The core's result of frame ``k`` at ``t_s``, the service commanded first (as the core
    does)."""
    from jackson.host.control.base import NavState
    from jackson.host.core.results import FrameResult
    from jackson.host.estimation.odometry import OdometryState
    from jackson.protocol import Telemetry

    service.command(NavState(t_s, 0.0, 0.0, 0.0, 0.0, 0.0))
    telemetry = Telemetry(t_us=round(t_s * 1e6), enc_left=0, enc_right=0, flags=0)
    return FrameResult(
        t_s, telemetry, OdometryState(t_s), 0, 0, 0, 0, (0, 0), True, k, None, service
    )


def test_nothing_is_built_without_a_client_and_a_late_client_gets_the_map_at_once() -> None:
    service, live = service_view(print)
    url = live.start()
    try:
        for k in range(20):  # 1 s of frames, nobody watching: nothing built, nothing sent
            live.on_result(frame_result(service, 0.05 * (k + 1), k + 1))
        assert sum(live.published.values()) == 0
        with connect(url) as ws:
            client = FoxgloveClient(ws)
            until([client], lambda: set(TOPICS) <= set(client.topics), 10, "the channels")
            until([client], lambda: live.map_ch.has_sinks(), 10, "the subscriptions")
            k = 20
            latched = ("/map", "/footprint", "/goal", "/plan")

            def step() -> bool:  # one frame (MCU time well before the map's next 10 s)
                nonlocal k
                k += 1
                live.on_result(frame_result(service, 0.05 * k, k))
                return client.got(*latched, "/pose", "/tf", "/health")

            until([client], step, 10, "the latched topics, sent on subscribe")
            assert 0.05 * k < 5.0
            grid = client.last("/map")
            assert (grid.column_count, len(grid.data)) == (120, 120 * 120 * 5)
            assert client.last("/health")["sensors"] == {"imu": "ok"}
            assert len(client.last("/goal").poses) == 0
    finally:
        live.stop()


def test_a_failure_while_publishing_turns_the_view_off_with_one_line() -> None:
    told: list[str] = []
    service, live = service_view(told.append)

    def broken() -> dict[str, str]:
        raise RuntimeError("the monitor went away")

    live.sensors = broken
    url = live.start()
    try:
        with connect(url) as ws:
            client = FoxgloveClient(ws)
            until([client], lambda: live.health_ch.has_sinks(), 10, "a client on /health")
            for k in range(1, 41):  # 2 s of frames: the frame loop never sees the error
                live.on_result(frame_result(service, 0.05 * k, k))
    finally:
        live.stop()
    assert (
        told == ["live view off: publishing failed: RuntimeError: the monitor went away"]
        and live.off == told[0]
    )


def test_daemon_and_twin_serve_every_channel_to_a_foxglove_client(robot: Robot) -> None:
    t0 = time.monotonic()
    robot.daemon.wait_line("daemon: taking goals on ")
    url = url_in(robot.daemon.wait_line("daemon: live view on "))
    assert url.startswith("ws://127.0.0.1:")
    with connect(url) as view_ws, connect(robot.twin_url) as truth_ws:
        view, truth = FoxgloveClient(view_ws), FoxgloveClient(truth_ws)
        # idle: the map, the robot, its scans and health, the (empty) goal and plan
        both = [view, truth]
        until(both, lambda: set(TOPICS) <= set(view.topics), 20, "the advertised channels")
        idle = ("/map", "/scan", "/pose", "/tf", "/footprint", "/health", "/goal", "/plan")
        until(both, lambda: view.got(*idle), 30, "the idle robot's channels")
        assert view.info["name"] == "jackson daemon"
        ads = {t: r.channel for t, r in view.topics.items()}
        schemas = {
            "/map": "foxglove.Grid",
            "/scan": "foxglove.LaserScan",
            "/pose": "foxglove.PoseInFrame",
            "/tf": "foxglove.FrameTransforms",
            "/footprint": "foxglove.SceneUpdate",
            "/plan": "foxglove.PosesInFrame",
            "/local_plan": "foxglove.PosesInFrame",
            "/goal": "foxglove.PosesInFrame",
        }
        for topic, name in schemas.items():
            assert (ads[topic]["encoding"], ads[topic]["schemaEncoding"]) == (
                "protobuf",
                "protobuf",
            )
            assert ads[topic]["schemaName"] == name, topic
        assert (ads["/health"]["encoding"], ads["/health"]["schemaName"]) == (
            "json",
            "jackson.Health",
        )
        health = view.last("/health")
        assert health["state"] == "idle" and health["goal"] is None
        assert set(health["sensors"]) >= {"imu", "lidar"}, health["sensors"]
        assert health["problems"] == [] and health["goals"]["succeeded"] == 0
        assert len(view.last("/goal").poses) == 0 and len(view.last("/plan").poses) == 0

        sent = goal(robot)
        assert sent.returncode == 0, sent.stdout + sent.stderr
        moving = ("/goal", "/plan", "/local_plan")
        until(
            both,
            lambda: view.got(*moving) and all(len(view.last(t).poses) for t in moving),
            60,
            "the goal, the plan and the local plan",
        )
        (g,) = view.last("/goal").poses
        assert xy(g) == GOAL
        plan = view.last("/plan")
        assert plan.frame_id == "map" and len(plan.poses) > 20
        assert math.dist(xy(plan.poses[-1]), GOAL) < 0.1
        until(both, lambda: view.last("/health")["goals"]["succeeded"] == 1, 90, "the goal reached")
        until(both, lambda: truth.got(*TWIN_TOPICS), 20, "the twin's channels")

    # what the payloads hold: the map, the scan, the robot's pose and transforms
    grid = view.last("/map")
    assert grid.frame_id == "map" and math.isclose(grid.cell_size.x, 0.05)
    rows = len(grid.data) // grid.row_stride
    cells = np.frombuffer(grid.data, np.uint8).reshape(rows, grid.column_count, 5)
    occupancy = cells[..., 0].astype(np.int8)
    assert (occupancy == 100).sum() > 500 and (occupancy == 0).sum() > 10_000
    scan = view.last("/scan")
    ranges = np.array(scan.ranges)
    assert scan.frame_id == "laser" and len(ranges) > 500
    assert math.isclose(scan.end_angle - scan.start_angle, 2 * math.pi, abs_tol=0.05)
    assert np.isfinite(ranges).mean() > 0.5 and np.nanmin(ranges) > 0.1
    tf = view.last("/tf").transforms
    assert [(t.parent_frame_id, t.child_frame_id) for t in tf] == [
        ("map", "odom"),
        ("odom", "base_link"),
        ("base_link", "laser"),
    ]
    first_pose = view.topics["/pose"].messages[0][1]
    assert first_pose.frame_id == "map"
    assert math.dist(xy(first_pose.pose), START[:2]) < 0.1
    assert math.isclose(yaw_of(first_pose.pose.orientation), START[2], abs_tol=0.05)
    end = view.last("/health")
    assert end["state"] == "idle" and math.dist((end["pose"]["x"], end["pose"]["y"]), GOAL) < 0.3
    assert len(view.last("/goal").poses) == 0  # cleared when the goal ended
    # stamps are MCU time, the log time of each message its own stamp
    log_ns, p = view.topics["/pose"].messages[-1]
    assert log_ns == p.timestamp.seconds * 10**9 + p.timestamp.nanos

    # the twin's ground truth, on the same clock: the daemon's pose within 0.15 m of it
    ads = {t: r.channel["schemaName"] for t, r in truth.topics.items()}
    assert ads["/world"] == "foxglove.SceneUpdate" and ads["/scan"] == "foxglove.LaserScan"
    (world,) = truth.last("/world").entities
    assert world.frame_id == "world" and len(world.cubes) >= 4
    true_ns = np.array([ns for ns, _ in truth.topics["/pose"].messages])
    true_xy = [xy(m.pose) for _, m in truth.topics["/pose"].messages]
    compared = 0
    for ns, m in view.topics["/pose"].messages:
        k = int(np.argmin(np.abs(true_ns - ns)))
        if abs(int(true_ns[k]) - ns) <= 25_000_000:  # the same instant: both on MCU time
            assert math.dist(xy(m.pose), true_xy[k]) < 0.15, ns / 1e9
            compared += 1
    assert compared > 20, (compared, true_ns[:5], view.topics["/pose"].messages[0][0])
    assert len(truth.last("/scan").ranges) == 1080
    print(f"live view test: {time.monotonic() - t0:.1f} s after the daemon started")


def test_a_daemon_whose_live_view_port_is_taken_goes_on_without_it(tmp_path: Path) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        for robot in start_robot(tmp_path, f"127.0.0.1:{port}"):
            robot.daemon.wait_line("daemon: taking goals on ")
            line = robot.daemon.wait_line("daemon: live view")
            assert line.startswith(f"daemon: live view: cannot serve on 127.0.0.1:{port}: ")
            assert line.endswith("Address already in use (os error 98); going on without it")
            done = goal(robot, "--wait")
            assert done.returncode == 0, done.stdout + done.stderr
            assert "succeeded" in done.stdout
