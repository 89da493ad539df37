"""The twin's RPLIDAR emulator with the compiled ultra ranging (jackson.protocol.native's
``ultra_ranged``) against its numpy: the same distances and edge dropouts bit for bit, and the
same bytes on the wire revolution after revolution, in every scan mode."""

from __future__ import annotations

import numpy as np
import pytest

from jackson.protocol import native
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles
from jackson.sim.rplidar import A1M8_SCAN_MODES, _SampleStream

pytestmark = pytest.mark.skipif(native.LIB is None, reason=f"no compiled build: {native.REASON}")


def _room() -> Obstacles:
    """A room with a pillar and a thin wall edge-on: edges, near and far returns."""
    walls = Obstacles()
    walls.add_polygon([(-3.0, -2.0), (4.0, -2.0), (4.0, 2.5), (-3.0, 2.5)])
    walls.add_circle(0.6, 0.3, 0.2)
    walls.add_segment(-1.0, 0.04, -1.0, 1.5)
    walls.add_circle(0.05, -0.1, 0.03)  # a cable 5 cm away: below 50 mm's offset step
    return walls


def _revolutions(rng: np.random.Generator, spec: LidarSpec) -> list[np.ndarray]:
    lidar = Lidar(spec, rng)
    room = lidar.true_ranges(0.0, 0.0, 0.3, _room())
    noisy = rng.uniform(0.02, 30.0, spec.beams)
    noisy[rng.random(spec.beams) < 0.1] = np.inf
    noisy[rng.random(spec.beams) < 0.03] = np.nan
    noisy[rng.random(spec.beams) < 0.03] = 0.0
    noisy[rng.random(spec.beams) < 0.03] = -1.0
    steps = np.repeat(rng.uniform(0.01, 9.0, spec.beams // 30 + 1), 30)[: spec.beams]
    # narrow plateaus: samples the far field's search cannot place and the near one can
    narrow = np.repeat(rng.uniform(0.05, 9.0, spec.beams // 10 + 1), 10)[: spec.beams]
    # 10 and 11 mm side by side: a sample 1 mm off is exactly at the edge fraction's bound
    near = np.tile(np.repeat([0.010, 0.011, 0.020, 0.022], 3), spec.beams // 12 + 1)[: spec.beams]
    return [room, noisy, steps, narrow, near, np.full(spec.beams, np.inf)]


@pytest.mark.parametrize("seed", range(3))
def test_ultra_samples_are_ranged_as_numpy_ranges_them(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = LidarSpec(noise_sigma_m=0.0)
    rng = np.random.default_rng(seed)
    stream = _SampleStream(spec, A1M8_SCAN_MODES[3], 0.0)
    raw = np.concatenate((rng.uniform(-720.0, 1080.0, 3000), np.arange(-1.0, 361.0, 0.25)))
    for ranges in _revolutions(rng, spec):
        got = []
        for lib in (native.LIB, None):
            monkeypatch.setattr(native, "LIB", lib)
            stream.edge_dropouts = 0
            mm = stream._parallax_ranged(ranges, raw)
            got.append((mm.tobytes(), str(mm.dtype), stream.edge_dropouts))
        assert got[0] == got[1]
    assert got[0][2] == 0  # the last revolution, no return anywhere


@pytest.mark.parametrize("mode", [0, 1, 2, 3, 4])
def test_the_emulators_bytes_are_the_same_compiled_and_interpreted(
    mode: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = LidarSpec(noise_sigma_m=0.0)
    rng = np.random.default_rng(mode)
    turns = _revolutions(rng, spec)
    wire = []
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        stream = _SampleStream(spec, A1M8_SCAN_MODES[mode], 0.0)
        data = b""
        for k in range(1, 9):
            ranges = turns[k % len(turns)]
            ahead = turns[(k + 1) % len(turns)] if k % 3 else None
            data += stream.revolution(k * spec.scan_period_s, ranges, ahead)
        wire.append((data, stream.samples, stream.edge_dropouts))
    assert wire[0] == wire[1]
    assert len(wire[0][0]) > 5000
    if mode >= 2:  # ultra: the edges drop samples
        assert wire[0][2] > 0
