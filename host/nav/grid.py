"""A 2-D occupancy grid and the map_server file pair (PGM + YAML) Nav2 loads.

The grid follows ``nav_msgs/OccupancyGrid``: ``data[row, col]`` with row 0 at the lowest y,
values -1 (unknown) or 0-100 (probability of occupancy in percent), the cell (0, 0)'s lower-left
corner at ``origin``. The file pair follows map_server's ``trinary`` mode: a binary PGM (P5)
whose top row is the highest y, 0 for occupied, 254 for free, 205 for unknown, and a YAML with
``image``, ``mode``, ``resolution``, ``origin``, ``negate``, ``occupied_thresh`` and
``free_thresh``. Reading applies map_server's rule, p = (255 - pixel) / 255: occupied above
``occupied_thresh``, free below ``free_thresh``, unknown between; saving writes map_saver's
thresholds (0.65, 0.196), so the unknown grey reads back as unknown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import yaml
from PIL import Image

UNKNOWN = -1
FREE = 0
OCCUPIED = 100
PGM_OCCUPIED = 0
PGM_FREE = 254
PGM_UNKNOWN = 205
OCCUPIED_THRESH = 0.65  # map_server's default
FREE_THRESH = 0.196  # map_saver's: the unknown grey 205 reads p = 0.19608, not below it

IntArray = npt.NDArray[np.int_]


class MapFileError(ValueError):
    """A map file pair cannot be read or written (one line naming the file)."""


@dataclass
class OccupancyGrid:
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

    def world_to_cell(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> tuple[IntArray, IntArray]:
        """(row, col) of the cells holding map-frame points (may lie outside the grid)."""
        col = np.floor((np.asarray(x_m, np.float64) - self.origin_x_m) / self.resolution_m)
        row = np.floor((np.asarray(y_m, np.float64) - self.origin_y_m) / self.resolution_m)
        return row.astype(np.int_), col.astype(np.int_)

    def cell_to_world(
        self, row: npt.ArrayLike, col: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Map-frame centres of cells [m]."""
        x = self.origin_x_m + (np.asarray(col, np.float64) + 0.5) * self.resolution_m
        y = self.origin_y_m + (np.asarray(row, np.float64) + 0.5) * self.resolution_m
        return x, y

    def inside(self, row: npt.ArrayLike, col: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Which (row, col) lie on the grid."""
        r, c = np.asarray(row), np.asarray(col)
        return (r >= 0) & (r < self.height) & (c >= 0) & (c < self.width)

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
        """Read a map_server pair (``trinary`` or ``scale`` mode, origin yaw 0).

        Raises
        ------
        MapFileError
            A missing file, a YAML without the fields map_server needs, or an unreadable image.
        """
        yaml_path = Path(yaml_path)
        where = f"map {yaml_path}"
        try:
            meta = yaml.safe_load(yaml_path.read_text(encoding="utf-8"))
        except OSError as exc:
            raise MapFileError(f"{where}: cannot read: {exc.strerror or exc}") from exc
        except yaml.YAMLError as exc:
            raise MapFileError(f"{where}: not YAML ({str(exc).splitlines()[0]})") from exc
        if not isinstance(meta, dict):
            raise MapFileError(f"{where}: expected a mapping with image, resolution, origin")
        for key in ("image", "resolution", "origin"):
            if key not in meta:
                raise MapFileError(f"{where}: {key}: missing")
        try:
            resolution = float(meta["resolution"])
            origin = [float(v) for v in meta["origin"]]
            occ = float(meta.get("occupied_thresh", OCCUPIED_THRESH))
            free = float(meta.get("free_thresh", 0.25))
            negate = int(meta.get("negate", 0))
        except (TypeError, ValueError) as exc:
            raise MapFileError(
                f"{where}: resolution, origin and thresholds must be numbers"
            ) from exc
        if len(origin) != 3 or origin[2] != 0.0:
            raise MapFileError(f"{where}: origin: expected [x, y, 0], got {meta['origin']}")
        if not 0.0 < resolution < math.inf:
            raise MapFileError(f"{where}: resolution: expected a number > 0, got {resolution}")
        image = yaml_path.parent / str(meta["image"])
        try:
            with Image.open(image) as im:
                pixels = np.asarray(im.convert("L"), np.float64)
        except (OSError, ValueError) as exc:
            raise MapFileError(f"{where}: image {image.name}: cannot read ({exc})") from exc
        p = pixels / 255.0 if negate else (255.0 - pixels) / 255.0
        data = np.full(p.shape, UNKNOWN, np.int8)
        data[p > occ] = OCCUPIED
        data[p < free] = FREE
        return cls(np.flipud(data).copy(), resolution, origin[0], origin[1])
