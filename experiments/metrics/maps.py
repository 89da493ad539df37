"""Map similarity: SSIM of 8-bit occupancy maps (Eq. 15 / A19)."""

from __future__ import annotations

from collections.abc import Callable
from typing import cast

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import MetricInputError

SSIM_DATA_RANGE = 255  # L, 8-bit maps (Eq. A19)
SSIM_K1 = 0.01  # C1 = (K1 L)^2
SSIM_K2 = 0.03  # C2 = (K2 L)^2
SSIM_WIN_SIZE = 7  # [px] side of the local window


def _ssim(*args: object, **kwargs: object) -> float:
    """scikit-image's ``structural_similarity``, imported on first use (as :func:`stats`)."""
    from skimage.metrics import structural_similarity

    return cast(Callable[..., float], structural_similarity)(*args, **kwargs)


# ---- map similarity (Eq. 15 / A19) -------------------------------------------------------------


def occupancy_ssim(
    map_a: npt.NDArray[np.uint8],
    map_b: npt.NDArray[np.uint8],
    gaussian_weights: bool = False,
    win_size: int = SSIM_WIN_SIZE,
) -> float:
    """Structural similarity of two 8-bit occupancy maps (Eq. 15 / A19).

        SSIM = (2 mu_a mu_b + C1)(2 sigma_ab + C2)
               / ((mu_a^2 + mu_b^2 + C1)(sigma_a^2 + sigma_b^2 + C2))

    with C1 = (0.01 L)^2, C2 = (0.03 L)^2 and L = 255, evaluated on local windows ("localized
    spatial mean and variance", App. D.1) and averaged over the map (scikit-image's
    structural_similarity, K1 and K2 passed explicitly). The paper names no weighting, so the
    default is a uniform win_size x win_size window with sample (co)variances, scikit-image's
    own default; ``gaussian_weights=True`` gives Wang et al.'s Gaussian window (sigma 1.5 px).

    Parameters
    ----------
    map_a, map_b : numpy.ndarray of uint8, shape (H, W)
        Rasterised maps of the same size (e.g. map_saver's 254 free / 0 occupied / 205
        unknown), H and W at least ``win_size``.
    gaussian_weights : bool
        Gaussian instead of uniform local window.
    win_size : int
        Side of the uniform window [px], odd; ignored with Gaussian weights.

    Returns
    -------
    float
        Mean SSIM, 1 for identical maps.
    """
    a = np.asarray(map_a)
    b = np.asarray(map_b)
    for name, arr in (("map_a", a), ("map_b", b)):
        if arr.dtype != np.uint8 or arr.ndim != 2:
            raise MetricInputError(f"{name} must be a 2-D uint8 map, got {arr.dtype} {arr.shape}")
    if a.shape != b.shape:
        raise MetricInputError(f"maps differ in size: {a.shape} and {b.shape}")
    side = 11 if gaussian_weights else win_size
    if min(a.shape) < side:
        raise MetricInputError(f"maps of {a.shape} px are smaller than the {side} px window")
    if gaussian_weights:
        value = _ssim(
            a,
            b,
            data_range=SSIM_DATA_RANGE,
            K1=SSIM_K1,
            K2=SSIM_K2,
            gaussian_weights=True,
            sigma=1.5,
            use_sample_covariance=False,
        )
    else:
        value = _ssim(a, b, data_range=SSIM_DATA_RANGE, K1=SSIM_K1, K2=SSIM_K2, win_size=win_size)
    return float(value)


def map_ssim(estimate: npt.ArrayLike, truth: npt.ArrayLike) -> float:
    """SSIM of an estimated occupancy map against a reference map (Eq. 15 / A19).

    Both maps become the 8-bit image map_saver writes and map_server reads (trinary mode):
    occupied 0 where p > 0.65, free 254 where p < 0.196, unknown 205 otherwise and where the
    value is -1; the images are compared by :func:`occupancy_ssim` with its defaults (L = 255,
    C1 = (0.01 L)^2, C2 = (0.03 L)^2, uniform 7 x 7 window), i.e. scikit-image's
    structural_similarity with data_range=255.

    The caller puts both maps on one grid: same resolution, same origin, same shape. The
    twin's truth lands on the estimate's grid with ``jackson.sim.raster.raster(world,
    grid.resolution_m, bounds=(x0, y0, x0 + width * res, y0 + height * res))`` when the
    estimate's origin is a multiple of the resolution (the mapper's always is); to score a
    fixed extent (e.g. the world plus a margin), slice both arrays to the same window, padding
    the estimate with -1 where it does not reach. A truth made of free space everywhere off the
    obstacles scores the unobservable outside of a room as free against the estimate's
    unknown; ``jackson.sim.raster.reachable_free`` gives the free space a map can hold, the
    rest of the truth is then -1.

    Parameters
    ----------
    estimate : array_like, shape (H, W)
        Occupancy in ``nav_msgs/OccupancyGrid`` values: -1 unknown, 0-100 [%]
        (``OccupancyGrid.data``).
    truth : array_like, shape (H, W)
        The reference on the same grid: the same values, or bool (True occupied, False free).

    Returns
    -------
    float
        Mean SSIM, 1 for maps of the same classes everywhere.
    """
    from jackson.host.nav.grid import (
        FREE_THRESH,
        OCCUPIED_THRESH,
        PGM_FREE,
        PGM_OCCUPIED,
        PGM_UNKNOWN,
    )

    def image(name: str, value: npt.ArrayLike) -> npt.NDArray[np.uint8]:
        arr = np.asarray(value)
        if arr.ndim != 2:
            raise MetricInputError(f"{name} must be a 2-D occupancy map, got shape {arr.shape}")
        if arr.dtype == np.bool_:
            arr = np.where(arr, 100, 0)
        p = arr.astype(np.float64) / 100.0
        known = arr >= 0
        out = np.full(arr.shape, PGM_UNKNOWN, np.uint8)
        out[known & (p > OCCUPIED_THRESH)] = PGM_OCCUPIED
        out[known & (p < FREE_THRESH)] = PGM_FREE
        return out

    return occupancy_ssim(image("estimate", estimate), image("truth", truth))
