"""The occupancy grid, its map_server file pair, and the shared pose and scan types."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jackson.host.nav.grid import MapFileError, OccupancyGrid
from jackson.host.nav.types import Pose2D, Scan


def test_map_pair_round_trips_and_reads_as_map_server_does(tmp_path: Path) -> None:
    g = OccupancyGrid.empty(1.0, 0.5, 0.05, origin_x_m=-0.5, origin_y_m=-0.25)
    g.data[0, :] = 100  # the lowest row: the bottom of the image
    g.data[3:5, 3:8] = 0
    yaml_path, pgm_path = g.save(tmp_path / "m.yaml")
    assert pgm_path.read_bytes().startswith(b"P5\n20 10\n255\n")
    pixels = pgm_path.read_bytes()[len(b"P5\n20 10\n255\n") :]
    assert pixels[-20:] == bytes([0] * 20)  # image rows run top (high y) to bottom
    h = OccupancyGrid.load(yaml_path)
    assert np.array_equal(h.data, g.data)
    assert (h.origin_x_m, h.origin_y_m, h.resolution_m) == (-0.5, -0.25, 0.05)


def test_cells_and_world_agree() -> None:
    g = OccupancyGrid.empty(2.0, 1.0, 0.05, origin_x_m=-1.0, origin_y_m=0.5)
    row, col = g.world_to_cell([-1.0, 0.99, -1.01], [0.5, 1.49, 0.5])
    assert row.tolist() == [0, 19, 0] and col.tolist() == [0, 39, -1]
    assert g.inside(row, col).tolist() == [True, True, False]
    x, y = g.cell_to_world(19, 39)
    assert (x, y) == pytest.approx((0.975, 1.475))


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("image: m.pgm\nresolution: 0.05\n", "origin: missing"),
        ("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\n", "resolution"),
        ("image: nope.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "nope.pgm"),
        ("[1, 2", "not valid YAML"),
    ],
)
def test_a_bad_map_file_is_one_line(tmp_path: Path, text: str, says: str) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(text)
    with pytest.raises(MapFileError, match=says) as info:
        OccupancyGrid.load(path)
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------ map_server's modes

# Each expected row is worked out by hand from map_server's rule: a pixel's shade is the mean of
# its channels over 255 (alpha counted as a channel in trinary mode), p = 1 - shade (negate:
# shade); trinary 100 above occupied_thresh, 0 below free_thresh, -1 between; scale maps the
# band between linearly onto 0-100 and makes a pixel that is not opaque -1; raw keeps
# round(shade * 255) when it lies in 0-100.


def _pgm(path: Path, row: list[int], maxval: int = 255) -> None:
    body = b"".join(v.to_bytes(2, "big") for v in row) if maxval > 255 else bytes(row)
    path.write_bytes(f"P5\n{len(row)} 1\n{maxval}\n".encode() + body)


def _map(tmp_path: Path, image: str, **fields: object) -> Path:
    lines = [f"image: {image}", "resolution: 0.05", "origin: [0, 0, 0]"]
    lines += [f"{k}: {v}" for k, v in fields.items()]
    path = tmp_path / "m.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _row(path: Path) -> list[int]:
    grid = OccupancyGrid.load(path)
    assert grid.height == 1
    return [int(v) for v in grid.data[0]]


THRESH = {"occupied_thresh": 0.65, "free_thresh": 0.25}


def test_trinary_thresholds_the_grey_level(tmp_path: Path) -> None:
    # p = (255 - v) / 255: 89 -> 0.651 (> 0.65), 90 -> 0.647, 191 -> 0.251, 192 -> 0.247 (< 0.25)
    _pgm(tmp_path / "m.pgm", [0, 89, 90, 191, 192, 255])
    assert _row(_map(tmp_path, "m.pgm", mode="trinary", **THRESH)) == [100, 100, -1, -1, 0, 0]
    assert _row(_map(tmp_path, "m.pgm", mode="Trinary", **THRESH)) == [100, 100, -1, -1, 0, 0]


def test_negate_reads_white_as_occupied(tmp_path: Path) -> None:
    # p = v / 255: 63 -> 0.247 (< 0.25), 64 -> 0.251, 165 -> 0.647, 166 -> 0.651 (> 0.65)
    _pgm(tmp_path / "m.pgm", [0, 63, 64, 165, 166, 255])
    for negate in ("1", "true"):
        path = _map(tmp_path, "m.pgm", negate=negate, **THRESH)
        assert _row(path) == [0, 0, -1, -1, 100, 100]


def test_scale_maps_the_band_between_the_thresholds_onto_0_to_100(tmp_path: Path) -> None:
    # between: rint((p - 0.25) / 0.4 * 100): 90 -> p 0.6471 -> 99.26 -> 99; 128 -> 0.4980 ->
    # 62.01 -> 62; 150 -> 0.4118 -> 40.44 -> 40; 170 -> 0.3333 -> 20.83 -> 21; 191 -> 0.2510 ->
    # 0.25 -> 0
    _pgm(tmp_path / "m.pgm", [0, 89, 90, 128, 150, 170, 191, 192, 255])
    row = _row(_map(tmp_path, "m.pgm", mode="scale", **THRESH))
    assert row == [100, 100, 99, 62, 40, 21, 0, 0, 0]


def test_scale_makes_a_pixel_that_is_not_opaque_unknown(tmp_path: Path) -> None:
    from PIL import Image

    la = np.array([[[150, 255], [150, 254], [0, 0], [255, 255]]], np.uint8)
    Image.fromarray(la, "LA").save(tmp_path / "m.png")
    assert _row(_map(tmp_path, "m.png", mode="scale", **THRESH)) == [40, -1, -1, 0]


def test_trinary_averages_alpha_in_as_map_server_does(tmp_path: Path) -> None:
    from PIL import Image

    # shade = (3 grey + alpha) / 1020: (255, 0) -> 0.75, p 0.25 -> -1; (0, 0) -> 0, p 1 -> 100;
    # (255, 128) -> 0.875, p 0.125 -> 0; (0, 255) -> 0.25, p 0.75 -> 100; (200, 100) -> 0.686,
    # p 0.314 -> -1
    la = np.array([[[255, 0], [0, 0], [255, 255], [255, 128], [0, 255], [200, 100]]], np.uint8)
    Image.fromarray(la, "LA").save(tmp_path / "m.png")
    path = _map(tmp_path, "m.png", occupied_thresh=0.65, free_thresh=0.196)
    assert _row(path) == [-1, 100, 0, 0, 100, -1]


def test_a_colour_pixel_reads_as_the_mean_of_its_channels(tmp_path: Path) -> None:
    from PIL import Image

    # (255, 255, 0): shade 0.667, p 0.333 -> -1; (0, 0, 255): p 0.667 -> 100;
    # (255, 255, 200): p 0.072 -> 0
    rgb = np.array([[[255, 255, 0], [0, 0, 255], [255, 255, 200]]], np.uint8)
    Image.fromarray(rgb, "RGB").save(tmp_path / "m.png")
    assert _row(_map(tmp_path, "m.png", **THRESH)) == [-1, 100, 0]
    # raw: round of the mean: 20.33 -> 20, 100.33 -> 100, 101 -> beyond 100 -> -1, 0.33 -> 0
    rgb = np.array([[[10, 20, 31], [100, 100, 101], [100, 101, 102], [0, 0, 1]]], np.uint8)
    Image.fromarray(rgb, "RGB").save(tmp_path / "m.png")
    assert _row(_map(tmp_path, "m.png", mode="raw")) == [20, 100, -1, 0]


def test_raw_keeps_the_value_and_ignores_negate(tmp_path: Path) -> None:
    _pgm(tmp_path / "m.pgm", [0, 1, 50, 100, 101, 255])
    assert _row(_map(tmp_path, "m.pgm", mode="raw")) == [0, 1, 50, 100, -1, -1]
    assert _row(_map(tmp_path, "m.pgm", mode="RAW", negate=1)) == [0, 1, 50, 100, -1, -1]


def test_a_16_bit_image_reads_over_its_full_scale(tmp_path: Path) -> None:
    # p = (65535 - v) / 65535: 32768 -> 0.49999 -> -1; 16000 -> 0.756 -> 100; 50000 -> 0.237 -> 0
    _pgm(tmp_path / "m.pgm", [0, 65535, 32768, 16000, 50000], maxval=65535)
    assert _row(_map(tmp_path, "m.pgm", **THRESH)) == [100, 0, -1, 100, 0]


def test_the_image_is_found_beside_the_yaml_or_by_absolute_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "maps").mkdir()
    _pgm(tmp_path / "maps" / "m.pgm", [0, 255])
    monkeypatch.chdir(tmp_path)  # not the YAML's folder
    yaml_path = _map(tmp_path / "maps", "m.pgm")
    assert _row(Path("maps") / yaml_path.name) == [100, 0]
    assert _row(_map(tmp_path, str(tmp_path / "maps" / "m.pgm"))) == [100, 0]


@pytest.mark.parametrize(
    "fields",
    [
        {"resolution": 0.001},
        {"resolution": 10},
        {"free_thresh": 0.0, "occupied_thresh": 1.0},
        {"negate": "false"},
        {"origin": "[-1e6, 1e6, -0.0]"},
        {"mode": "SCALE"},
    ],
)
def test_the_bounds_themselves_are_accepted(tmp_path: Path, fields: dict[str, object]) -> None:
    _pgm(tmp_path / "m.pgm", [0, 255])
    yaml_path = _map(tmp_path, "m.pgm")
    text = yaml_path.read_text()
    for key, value in fields.items():
        text = "\n".join(line for line in text.splitlines() if not line.startswith(key))
        text += f"\n{key}: {value}\n"
    yaml_path.write_text(text)
    grid = OccupancyGrid.load(yaml_path)
    assert grid.data.shape == (1, 2)


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        ("resolution: 1e-9", "resolution: expected 0.001 to 10 m per cell, got 1e-09"),
        ("resolution: 10.5", "resolution: expected 0.001 to 10"),
        ("resolution: .inf", "resolution: expected a finite number, got inf"),
        ("resolution: '0.05'", "resolution: expected a finite number"),
        ("resolution: true", "resolution: expected a finite number, got true"),
        ("origin: [1e7, 0, 0]", "origin: x and y must lie within"),
        ("origin: [0, 0, 0.5]", "origin: yaw 0.5 rad: rotated maps are not supported"),
        ("origin: [0, .nan, 0]", "origin: expected [x, y, yaw]"),
        ("origin: [0, 0]", "origin: expected [x, y, yaw]"),
        ("origin: {x: 0}", "origin: expected [x, y, yaw]"),
        ("free_thresh: 0.7", "free_thresh 0.7 must be below occupied_thresh 0.65"),
        ("occupied_thresh: 1.5", "occupied_thresh: expected a number in [0, 1], got 1.5"),
        ("free_thresh: -0.1", "free_thresh: expected a number in [0, 1]"),
        ("negate: 7", "negate: expected 0, 1, true or false, got 7"),
        ("negate: 1.0", "negate: expected 0, 1, true or false, got 1.0"),
        ("mode: bogus", "mode: expected trinary, scale, raw, got 'bogus'"),
        ("mode: 3", "mode: expected trinary, scale, raw, got 3"),
        ("colour: red\nsize: 3", "unknown fields colour, size"),
        ("image: ''", "image: expected a file name"),
        ("image: [a.pgm]", "image: expected a file name"),
    ],
)
def test_a_bad_field_is_refused_by_name(tmp_path: Path, extra: str, says: str) -> None:
    _pgm(tmp_path / "m.pgm", [0, 255])
    path = tmp_path / "m.yaml"
    base = {"image": "m.pgm", "resolution": "0.05", "origin": "[0, 0, 0]"}
    key = extra.split(":")[0]
    base.pop(key, None)
    path.write_text("".join(f"{k}: {v}\n" for k, v in base.items()) + extra + "\n")
    with pytest.raises(MapFileError) as info:
        OccupancyGrid.load(path)
    message = str(info.value)
    assert says in message
    assert message.startswith(f"map {path}: ")
    assert "\n" not in message


@pytest.mark.parametrize(
    ("image", "says"),
    [
        (b"P5\n200000 200000\n255\n\0", "too large to open, a map has at most 20000 x 20000"),
        (b"P5\n30000 2\n255\n\0", "30000 x 2 pixels, a map has at most 20000 x 20000"),
        (b"P5\n12000 9000\n255\n\0", "12000 x 9000 pixels, a map has at most"),
        (b"P5\n20 10\n255\n" + bytes(50), "cannot read it (image file is truncated"),
        (b"hello, not an image\n", "cannot read it (cannot identify image file"),
        (b"", "cannot read it"),
    ],
)
def test_a_bad_image_is_refused_before_it_is_decoded(
    tmp_path: Path, image: bytes, says: str
) -> None:
    (tmp_path / "m.pgm").write_bytes(image)
    path = _map(tmp_path, "m.pgm")
    with pytest.raises(MapFileError) as info:
        OccupancyGrid.load(path)
    assert says in str(info.value)
    assert str(info.value).startswith(f"map {path}: image: m.pgm: ")


def test_the_largest_image_allowed_is_read(tmp_path: Path) -> None:
    _pgm(tmp_path / "m.pgm", [255] * 20000)
    assert OccupancyGrid.load(_map(tmp_path, "m.pgm")).data.shape == (1, 20000)


def test_pose_composition_and_scan_points() -> None:
    a = Pose2D(1.0, 2.0, math.pi / 2)
    b = Pose2D(0.5, 0.0, 0.0)
    assert a.compose(b).x == pytest.approx(1.0) and a.compose(b).y == pytest.approx(2.5)
    ident = a.compose(a.inverse())
    assert (ident.x, ident.y, ident.yaw) == pytest.approx((0.0, 0.0, 0.0))
    scan = Scan(0.0, np.array([0.0, math.pi / 2, 0.1]), np.array([1.0, 2.0, math.inf]))
    pts = scan.points(Pose2D(0.0, 0.0, math.pi / 2))
    assert pts == pytest.approx(np.array([[0.0, 1.0], [-2.0, 0.0]]))
