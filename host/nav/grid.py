"""A 2-D occupancy grid and the map_server file pair (image + YAML) Nav2 loads.

The grid follows ``nav_msgs/OccupancyGrid``: ``data[row, col]`` with row 0 at the lowest y,
values -1 (unknown) or 0-100 (probability of occupancy in percent), the cell (0, 0)'s lower-left
corner at ``origin``.

Reading follows map_server (``nav2_map_server``): the YAML holds ``image`` (relative to the
YAML's folder, or absolute), ``resolution``, ``origin`` [x, y, yaw], ``occupied_thresh``,
``free_thresh``, ``negate`` and ``mode``; the image's top row is the highest y. A pixel's shade
is the mean of its colour channels over the channel maximum (a grey pixel ``v``: ``v / 255``);
its occupancy p is ``1 - shade``, or ``shade`` with ``negate``. Then, per ``mode``:

- ``trinary`` (the default): p > ``occupied_thresh`` is 100, p < ``free_thresh`` is 0, else -1.
  An alpha channel is averaged into the shade as a fourth channel, as map_server does.
- ``scale``: as trinary outside the thresholds; between them p maps linearly onto 0-100
  (rounded to nearest); a pixel that is not fully opaque is -1.
- ``raw``: the shade times 255, rounded, is the cell's value when it lies in 0-100, else -1;
  ``negate`` and alpha play no part.

Everything else map_server would take on trust is checked, and each problem is one
:class:`MapFileError` line naming the file and the field: unknown fields, thresholds outside
[0, 1] or not ordered, a non-finite or far origin, a rotated origin (the grid is not rotated), a
resolution outside [:data:`RESOLUTION_MIN_M`, :data:`RESOLUTION_MAX_M`], an image larger than
:data:`MAX_SIDE` pixels a side or :data:`MAX_CELLS` cells (read from its header, before it is
decoded), a missing, unreadable or corrupt image.

Saving writes map_saver's ``trinary`` pair: a binary PGM (P5), 0 for occupied, 254 for free,
205 for unknown, with map_saver's thresholds (0.65, 0.196), so the unknown grey reads back as
unknown.
"""

from __future__ import annotations

import math
import stat
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml
from PIL import Image

from jackson.common.errors import JacksonError
from jackson.common.fields import ConfigError, read_yaml, show
from jackson.common.geometry import GridCells

UNKNOWN = -1
FREE = 0
OCCUPIED = 100
PGM_OCCUPIED = 0
PGM_FREE = 254
PGM_UNKNOWN = 205
OCCUPIED_THRESH = 0.65  # map_server's default
FREE_THRESH = 0.196  # map_saver's: the unknown grey 205 reads p = 0.19608, not below it
FREE_THRESH_DEFAULT = 0.25  # what a YAML without free_thresh reads with (map_saver's default)

MODES = ("trinary", "scale", "raw")
"""map_server's modes (case-insensitive in the YAML)."""
MAP_KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode")
"""The fields map_server documents; any other field is refused."""
RESOLUTION_MIN_M = 0.001
RESOLUTION_MAX_M = 10.0
ORIGIN_LIMIT_M = 1e6
"""|x| and |y| of the origin at most this [m]."""
MAX_SIDE = 20_000
"""Pixels a side at most."""
MAX_CELLS = 10_000_000
"""Pixels (cells) in all at most: what the navigation stack holds in bounded memory. Its peak
resident memory grows by :data:`BYTES_PER_CELL` a cell of the map (the global costmap and its
inflation, the planner's arrays, the likelihood field and distance maps of the particle filter,
copies while they are built): ``jackson run maze`` peaked at 1.5 GB on a 3162 x 3162 map and
on a 10000 x 1000 one; a 5000 x 5000 map took it past 4 GiB."""
BYTES_PER_CELL = 150
"""Peak resident memory of ``jackson run maze --map`` per map cell [bytes], rounded up from
synthetic maps of 0.25 to 10 million cells (110-150 bytes a cell, about 230 MB besides)."""
MAX_YAML_BYTES = 1 << 20

IntArray = npt.NDArray[np.int_]


class MapFileError(JacksonError, ValueError):
    """A map file pair cannot be read or written (one line naming the file)."""


@dataclass
class OccupancyGrid(GridCells):
    """An occupancy grid in the map frame.

    Attributes
    ----------
    data : ndarray of int8, shape (height, width)
        -1 unknown, 0-100 occupancy [%]; row 0 is the lowest y.
    resolution_m : float
        Cell edge [m].
    origin_x_m, origin_y_m : float
        Map-frame position of the lower-left corner of cell (0, 0) [m].
    """

    data: npt.NDArray[np.int8]
    resolution_m: float
    origin_x_m: float = 0.0
    origin_y_m: float = 0.0

    def __post_init__(self) -> None:
        if self.data.ndim != 2 or self.data.size == 0:
            raise ValueError(
                f"OccupancyGrid: data must be a non-empty 2-D array, got {self.data.shape}"
            )
        if not 0.0 < self.resolution_m < math.inf:
            raise ValueError(f"OccupancyGrid: resolution must be > 0, got {self.resolution_m}")

    @classmethod
    def empty(
        cls,
        width_m: float,
        height_m: float,
        resolution_m: float,
        origin_x_m: float = 0.0,
        origin_y_m: float = 0.0,
        fill: int = UNKNOWN,
    ) -> OccupancyGrid:
        """A grid covering ``width_m`` x ``height_m`` from the origin, every cell ``fill``."""
        cols = max(1, math.ceil(width_m / resolution_m - 1e-9))
        rows = max(1, math.ceil(height_m / resolution_m - 1e-9))
        return cls(np.full((rows, cols), fill, np.int8), resolution_m, origin_x_m, origin_y_m)

    @property
    def height(self) -> int:
        """Rows."""
        return int(self.data.shape[0])

    @property
    def width(self) -> int:
        """Columns."""
        return int(self.data.shape[1])

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) (world <-> cell: :class:`~jackson.common.geometry.GridCells`)."""
        return (self.height, self.width)

    def occupied(self, threshold: int = 50) -> npt.NDArray[np.bool_]:
        """Cells at or above ``threshold`` percent."""
        return self.data >= threshold

    # ------------------------------------------------------------------ map_server files

    def save(self, yaml_path: str | Path) -> tuple[Path, Path]:
        """Write ``<name>.yaml`` and ``<name>.pgm`` beside it; returns both paths.

        Raises
        ------
        MapFileError
            The folder cannot be written.
        """
        yaml_path = Path(yaml_path)
        pgm_path = yaml_path.with_suffix(".pgm")
        pixels = np.full(self.data.shape, PGM_UNKNOWN, np.uint8)
        known = self.data >= 0
        p = self.data.astype(np.float64) / 100.0
        pixels[known & (p > OCCUPIED_THRESH)] = PGM_OCCUPIED
        pixels[known & (p < FREE_THRESH)] = PGM_FREE
        meta = {
            "image": pgm_path.name,
            "mode": "trinary",
            "resolution": float(self.resolution_m),
            "origin": [float(self.origin_x_m), float(self.origin_y_m), 0.0],
            "negate": 0,
            "occupied_thresh": OCCUPIED_THRESH,
            "free_thresh": FREE_THRESH,
        }
        try:
            Image.fromarray(np.flipud(pixels), mode="L").save(pgm_path, format="PPM")
            yaml_path.write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf-8")
        except OSError as exc:
            raise MapFileError(f"map {yaml_path}: cannot write: {exc.strerror or exc}") from exc
        return yaml_path, pgm_path

    @classmethod
    def load(cls, yaml_path: str | Path) -> OccupancyGrid:
        """Read a map_server pair (any of its three modes; origin yaw 0).

        Parameters
        ----------
        yaml_path : str or Path
            The map's YAML; its ``image`` is relative to the YAML's folder unless absolute.

        Returns
        -------
        OccupancyGrid
            The map, row 0 at the lowest y.

        Raises
        ------
        MapFileError
            One line naming the file and the field: a missing or unreadable file, a YAML that
            is not a mapping of map_server's fields, a field out of its bounds, an image too
            large, unreadable or corrupt.
        """
        meta = _read_meta(Path(yaml_path))
        total, full, alpha = _read_pixels(meta)
        if alpha is None:
            data = _occupancy_table(meta, full)[total]
        elif meta.mode == "trinary":  # map_server averages alpha in as one more channel
            data = _occupancy_table(meta, full + 255)[total + alpha]
        else:
            data = _occupancy_table(meta, full)[total]
            if meta.mode == "scale":
                data[alpha != 255] = UNKNOWN
        return cls(np.flipud(data).copy(), meta.resolution_m, meta.origin_x_m, meta.origin_y_m)


# ---------------------------------------------------------------------- reading the YAML


@dataclass(frozen=True)
class _MapMeta:
    where: str  # "map <yaml path>", the start of every message
    image_name: str  # as the YAML gives it
    image: Path
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    occupied_thresh: float
    free_thresh: float
    negate: bool
    mode: str


def _brief(value: Any) -> str:
    text = show(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _finite(value: Any) -> float | None:
    """``value`` as a finite float, or None (text, a bool, inf, nan, an int too large)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        v = float(value)
    except OverflowError:
        return None
    return v if math.isfinite(v) else None


def _number(data: Mapping[Any, Any], key: str, default: float | None, where: str) -> float:
    if key not in data:
        if default is None:
            raise MapFileError(f"{where}: {key}: missing")
        return default
    v = _finite(data[key])
    if v is None:
        raise MapFileError(f"{where}: {key}: expected a finite number, got {_brief(data[key])}")
    return v


def _read_meta(yaml_path: Path) -> _MapMeta:
    where = f"map {yaml_path}"
    try:
        st = yaml_path.stat()
    except OSError:
        pass  # read_yaml says why it cannot be read
    else:
        if not stat.S_ISREG(st.st_mode):
            raise MapFileError(f"{where}: not a file")
        if st.st_size > MAX_YAML_BYTES:
            raise MapFileError(
                f"{where}: {st.st_size} bytes, too long for a map YAML (at most {MAX_YAML_BYTES})"
            )
    try:
        _, data = read_yaml(yaml_path, "map")
    except ConfigError as exc:
        raise MapFileError(str(exc)) from exc
    unknown = [str(k)[:60] for k in data if k not in MAP_KEYS]
    if unknown:
        raise MapFileError(
            f"{where}: unknown field{'s' if len(unknown) > 1 else ''} {', '.join(unknown)} "
            f"(a map_server YAML has {', '.join(MAP_KEYS)})"
        )
    for key in ("image", "resolution", "origin"):
        if key not in data:
            raise MapFileError(f"{where}: {key}: missing")

    image = data["image"]
    if not isinstance(image, str) or not image.strip() or "\0" in image:
        raise MapFileError(f"{where}: image: expected a file name, got {_brief(image)}")

    resolution = _number(data, "resolution", None, where)
    if not RESOLUTION_MIN_M <= resolution <= RESOLUTION_MAX_M:
        raise MapFileError(
            f"{where}: resolution: expected {RESOLUTION_MIN_M:g} to {RESOLUTION_MAX_M:g} m per "
            f"cell, got {resolution:g}"
        )

    origin = data["origin"]
    xyz = [_finite(v) for v in origin] if isinstance(origin, list) and len(origin) == 3 else []
    if len(xyz) != 3 or any(v is None for v in xyz):
        raise MapFileError(
            f"{where}: origin: expected [x, y, yaw], three finite numbers, got {_brief(origin)}"
        )
    x, y, yaw = (float(v) for v in xyz if v is not None)
    if abs(x) > ORIGIN_LIMIT_M or abs(y) > ORIGIN_LIMIT_M:
        raise MapFileError(
            f"{where}: origin: x and y must lie within ±{ORIGIN_LIMIT_M:g} m, got {x:g}, {y:g}"
        )
    if yaw != 0.0:
        raise MapFileError(
            f"{where}: origin: yaw {yaw:g} rad: rotated maps are not supported; rotate the "
            "image and give yaw 0"
        )

    occ = _number(data, "occupied_thresh", OCCUPIED_THRESH, where)
    free = _number(data, "free_thresh", FREE_THRESH_DEFAULT, where)
    for key, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= v <= 1.0:
            raise MapFileError(f"{where}: {key}: expected a number in [0, 1], got {v:g}")
    if not free < occ:
        raise MapFileError(f"{where}: free_thresh {free:g} must be below occupied_thresh {occ:g}")

    negate = data.get("negate", 0)
    if not (isinstance(negate, bool) or (isinstance(negate, int) and negate in (0, 1))):
        raise MapFileError(f"{where}: negate: expected 0, 1, true or false, got {_brief(negate)}")

    mode = data.get("mode", "trinary")
    if not isinstance(mode, str) or mode.lower() not in MODES:
        raise MapFileError(f"{where}: mode: expected {', '.join(MODES)}, got {_brief(mode)}")

    return _MapMeta(
        where,
        image,
        yaml_path.parent / image,  # an absolute image path stays as it is
        resolution,
        x,
        y,
        occ,
        free,
        bool(negate),
        mode.lower(),
    )


# ---------------------------------------------------------------------- reading the image


_LIMITS = (
    f"at most {MAX_SIDE} x {MAX_SIDE} pixels and {MAX_CELLS:,} in all (navigating needs about "
    f"{BYTES_PER_CELL} bytes of memory a cell): crop it, or save it at a coarser resolution"
)
_ALPHA_MODES = ("LA", "La", "PA", "RGBA", "RGBa")

U16Array = npt.NDArray[np.uint16]


def _read_pixels(meta: _MapMeta) -> tuple[U16Array, int, U16Array | None]:
    """The image's summed colour channels, their full scale, and alpha (0-255) if it has one.

    A grey pixel is one channel (full scale 255, or 65535 for 16 bits), a colour pixel the sum
    of red, green and blue (full scale 765). The size is checked from the header, before the
    pixels are decoded.
    """
    path = meta.image
    what = f"{meta.where}: image: {meta.image_name}"
    # PIL warns on stderr (DecompressionBombWarning, some damaged files): the size check
    # below takes the place of its warning, and what it raises is reported as one line
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            with Image.open(path) as im:
                width, height = im.size
                if not (0 < width <= MAX_SIDE and 0 < height <= MAX_SIDE) or (
                    width * height > MAX_CELLS
                ):
                    raise MapFileError(f"{what}: {width} x {height} pixels, a map has {_LIMITS}")
                return _decode(im, what)
        except MapFileError:
            raise
        except FileNotFoundError as exc:
            raise MapFileError(
                f"{what}: no file {path} (the image is relative to the YAML's folder)"
            ) from exc
        except Image.DecompressionBombError as exc:
            raise MapFileError(f"{what}: too large to open, a map has {_LIMITS} ({exc})") from exc
        except OSError as exc:  # a folder, not an image, truncated
            reason = exc.strerror or str(exc) or type(exc).__name__
            raise MapFileError(f"{what}: cannot read it ({reason})") from exc
        except Exception as exc:  # PIL's decoders raise many kinds on a corrupt file
            raise MapFileError(f"{what}: corrupt image ({type(exc).__name__}: {exc})") from exc


def _channel_sum(pixels: npt.NDArray[np.uint8], channels: int) -> U16Array:
    total = pixels[..., 0].astype(np.uint16)
    for k in range(1, channels):
        total += pixels[..., k]
    return total


def _decode(im: Image.Image, what: str) -> tuple[U16Array, int, U16Array | None]:
    im.load()
    if im.mode.startswith("I"):  # 16-bit grey (PGM, PNG); 32-bit integers must fit 16 bits
        grey = np.asarray(im)
        if grey.min() < 0 or grey.max() > 65535:
            raise MapFileError(f"{what}: pixel values beyond 16 bits are not a map")
        return grey.astype(np.uint16), 65535, None
    if im.mode == "F":
        raise MapFileError(f"{what}: floating-point pixels are not a map image")
    if im.mode in _ALPHA_MODES or im.info.get("transparency") is not None:
        rgba = np.asarray(im.convert("RGBA"))
        return _channel_sum(rgba, 3), 765, rgba[..., 3].astype(np.uint16)
    if im.mode in ("1", "L"):
        return np.asarray(im.convert("L")).astype(np.uint16), 255, None
    return _channel_sum(np.asarray(im.convert("RGB")), 3), 765, None


def _occupancy_table(meta: _MapMeta, full: int) -> npt.NDArray[np.int8]:
    """The cell value of every channel sum 0..``full`` (``full``: a white, opaque pixel)."""
    t = np.arange(full + 1, dtype=np.float64)
    if meta.mode == "raw":
        value = np.floor(t * 255.0 / full + 0.5)
        return np.where((value >= FREE) & (value <= OCCUPIED), value, UNKNOWN).astype(np.int8)
    p = t / full if meta.negate else (full - t) / full
    occ, free = meta.occupied_thresh, meta.free_thresh
    between = np.rint((p - free) / (occ - free) * 100.0) if meta.mode == "scale" else UNKNOWN
    cells = np.where(p > occ, OCCUPIED, np.where(p < free, FREE, between))
    return np.asarray(cells).astype(np.int8)
