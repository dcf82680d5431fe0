"""Where a ring's transducers are and which grid cells each beam cone covers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray, IntArray
from bayesmap.errors import ConfigError, InputError
from bayesmap.geometry import wrap_angle
from bayesmap.grid import OccupancyGrid

__all__ = ["ConeCells", "SonarGeometry", "cone_cells"]


@dataclass(frozen=True)
class SonarGeometry:
    """The ring as the mapping code knows it (no truth, no simulator).

    Parameters
    ----------
    angles
        Bearing of each transducer's axis from the robot heading [rad], in ring order; the
        neighbours of transducer ``k`` are ``k - 1`` and ``k + 1``.
    beam_width
        Full cone width [rad].
    max_range
        Maximum range [m]; a reading at or above it (or not finite) means no echo.
    sigma
        Standard deviation of the range error [m] (eq. 1).
    radius
        Distance of the transducers from the robot centre [m], each on its own axis (used
        when ``offsets`` is not given).
    offsets
        Each transducer's position ``(x, y)`` [m] in the robot frame (x forward, y left),
        e.g. from a ring file (:mod:`bayesmap.sonar.ring`); overrides ``radius``.
    min_range
        Shortest range the transducer reports [m].
    closed
        Whether the first and last transducers are neighbours. ``None``: decide from the
        angles (closed when the gap from the last back to the first is at most 1.5 times
        the largest gap between consecutive transducers).
    """

    angles: tuple[float, ...]
    beam_width: float = math.radians(25.0)
    max_range: float = 5.0
    sigma: float = 0.02
    radius: float = 0.0
    closed: bool | None = None
    offsets: tuple[tuple[float, float], ...] | None = None
    min_range: float = 0.0

    def __post_init__(self) -> None:
        if len(self.angles) < 2:
            raise ConfigError(f"a sonar ring needs at least 2 transducers, got {len(self.angles)}")
        if not all(math.isfinite(a) for a in self.angles):
            raise ConfigError("transducer angles must be finite radians")
        if not 0.0 < self.beam_width < math.pi:
            raise ConfigError(f"beam width must be in (0, pi) rad, got {self.beam_width}")
        if not (math.isfinite(self.max_range) and self.max_range > 0):
            raise ConfigError(
                f"max range must be a positive number of metres, got {self.max_range}"
            )
        if not (self.sigma > 0 and self.radius >= 0):
            raise ConfigError(
                f"need sigma > 0 and radius >= 0 [m], got {self.sigma}, {self.radius}"
            )
        if not 0.0 <= self.min_range < self.max_range:
            raise ConfigError(
                f"need 0 <= min range < max range [m], got {self.min_range}, {self.max_range}"
            )
        if self.offsets is not None and (
            len(self.offsets) != len(self.angles)
            or not all(len(o) == 2 and all(math.isfinite(v) for v in o) for o in self.offsets)
        ):
            raise ConfigError(
                f"need one finite (x, y) offset [m] per transducer ({len(self.angles)})"
            )

    @property
    def n(self) -> int:
        """Number of transducers."""
        return len(self.angles)

    @property
    def is_closed(self) -> bool:
        """Whether transducer 0 and ``n - 1`` are neighbours (see ``closed``)."""
        if self.closed is not None:
            return self.closed
        a = np.unwrap(np.asarray(self.angles))
        gaps = np.abs(np.diff(a))
        wrap = 2.0 * math.pi - abs(a[-1] - a[0])
        return bool(wrap <= 1.5 * gaps.max())

    def neighbours(self) -> tuple[IntArray, IntArray]:
        """Indices of the left (``k - 1``) and right (``k + 1``) neighbour; −1 where none."""
        k = np.arange(self.n)
        left, right = k - 1, k + 1
        if self.is_closed:
            return left % self.n, right % self.n
        right[-1] = -1
        return left, right

    def one_ring(self, pose: npt.ArrayLike, ranges: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """``pose`` ``(x, y, heading)`` and one ring of ``ranges`` as float arrays of shapes
        (3,) and (n,); :class:`InputError` naming the wrong shape otherwise."""
        p = np.asarray(pose, dtype=np.float64)
        r = np.asarray(ranges, dtype=np.float64)
        if p.shape != (3,):
            raise InputError(f"a pose must be 3 numbers (x, y, heading), got shape {p.shape}")
        if r.shape != (self.n,):
            raise InputError(f"a ring has {self.n} readings, got shape {r.shape}")
        return p, r

    def sensors(self, pose: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Transducer positions ``(n, 2)`` [m] and axis bearings ``(n,)`` [rad] at ``pose``."""
        p = np.asarray(pose, dtype=np.float64)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InputError(f"a pose must be 3 finite numbers (x, y, heading), got {p!r}")
        centres, axis = self.sensors_many(p[None])
        return centres[0], axis[0]

    def sensors_many(self, poses: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Transducer positions ``(m, n, 2)`` [m] and bearings ``(m, n)`` [rad] at ``poses``.

        ``poses`` is ``(m, 3)``, each ``(x, y, heading)``; all rings are placed at once.
        """
        p = np.asarray(poses, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
            raise InputError(f"poses must be finite (m, 3) rows (x, y, heading), got {p.shape}")
        axis = p[:, 2:3] + np.asarray(self.angles)[None, :]
        if self.offsets is None:
            offset = self.radius * np.stack([np.cos(axis), np.sin(axis)], axis=-1)
        else:
            off = np.asarray(self.offsets)[None]
            c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
            offset = np.stack(
                [c * off[..., 0] - s * off[..., 1], s * off[..., 0] + c * off[..., 1]], axis=-1
            )
        return p[:, None, :2] + offset, axis

    @property
    def reach(self) -> float:
        """Farthest a transducer sits from the robot centre [m]."""
        if self.offsets is None:
            return self.radius
        return float(max(math.hypot(x, y) for x, y in self.offsets))

    def echo(self, ranges: FloatArray) -> np.ndarray:
        """``True`` where a reading reports an obstacle (finite and below the max range)."""
        r = np.asarray(ranges, dtype=np.float64)
        return np.asarray(np.isfinite(r) & (r < self.max_range))

    def measured_nothing(self, ranges: FloatArray) -> np.ndarray:
        """``True`` where a reading is 0, negative or below the min range: a driver's code for
        "too close" or "no reading" (REP 117's −inf), which no map takes as evidence."""
        r = np.asarray(ranges, dtype=np.float64)
        return np.asarray((r <= 0.0) | (r < self.min_range))


class ConeCells(NamedTuple):
    """Grid cells inside beam cones, flattened over the readings of one ring.

    ``rows``, ``cols``: the cells; ``rho``: distance of each cell centre from its transducer
    [m]; ``theta``: bearing off its beam axis [rad]; ``reading``: index of the reading.
    """

    rows: IntArray
    cols: IntArray
    rho: FloatArray
    theta: FloatArray
    reading: IntArray


def cone_cells(
    grid: OccupancyGrid,
    centres: FloatArray,
    axis: FloatArray,
    reach: FloatArray,
    half_width: float,
) -> ConeCells:
    """Cells whose centres lie in each cone ``|theta| <= half_width``, ``rho <= reach``.

    Parameters
    ----------
    grid
        The map (geometry only).
    centres
        ``(n, 2)`` transducer positions [m].
    axis
        ``(n,)`` beam bearings [rad].
    reach
        ``(n,)`` how far each cone extends [m]; readings with ``reach <= 0`` are skipped.
    half_width
        Half the cone width [rad].
    """
    res = grid.resolution
    ny, nx = grid.shape
    x0, y0 = grid.origin
    ks = np.flatnonzero(np.asarray(reach) > 0)
    empty_i = np.zeros(0, dtype=np.int64)
    if len(ks) == 0:
        return ConeCells(empty_i, empty_i, np.zeros(0), np.zeros(0), empty_i)
    cx, cy, ax, rk = centres[ks, 0], centres[ks, 1], axis[ks], np.asarray(reach)[ks]
    # The bounding box of each sector: its apex, the two edge ends and the arc's extreme
    # points, i.e. the compass directions (clipped into the cone when they fall outside).
    offsets = (np.arange(4) * (math.pi / 2))[None, :] - ax[:, None]
    offsets = np.clip(wrap_angle(offsets), -half_width, half_width)
    offsets = np.column_stack([offsets, np.full((len(ks), 2), [-half_width, half_width])])
    ang = ax[:, None] + offsets
    xs = np.column_stack([cx, cx[:, None] + rk[:, None] * np.cos(ang)])
    ys = np.column_stack([cy, cy[:, None] + rk[:, None] * np.sin(ang)])
    c0 = np.clip(np.floor((xs.min(axis=1) - x0) / res).astype(np.int64) - 1, 0, nx)
    c1 = np.clip(np.floor((xs.max(axis=1) - x0) / res).astype(np.int64) + 2, 0, nx)
    r0 = np.clip(np.floor((ys.min(axis=1) - y0) / res).astype(np.int64) - 1, 0, ny)
    r1 = np.clip(np.floor((ys.max(axis=1) - y0) / res).astype(np.int64) + 2, 0, ny)
    # Each row of a sector's box is one run of candidate cells: the columns whose centres
    # lie on that row's stretch of the sector (its two edges and its arc, each widened by
    # _SPAN_MARGIN so that rounding cannot drop a cell the exact test keeps).
    height = np.maximum(r1 - r0, 0)
    run_sector = np.repeat(np.arange(len(ks)), height)
    run_row = r0[run_sector] + _ragged_arange(height)
    dy = y0 + (run_row + 0.5) * res - cy[run_sector]
    ux, uy = np.cos(ax), np.sin(ax)
    lo, hi = _sector_span(dy, ux[run_sector], uy[run_sector], rk[run_sector], half_width)
    x = cx[run_sector] - x0
    col_lo = np.clip(np.ceil((x + lo) / res - 0.5), c0[run_sector], c1[run_sector])
    col_hi = np.clip(np.floor((x + hi) / res - 0.5) + 1.0, c0[run_sector], c1[run_sector])
    count = np.maximum(col_hi - col_lo, 0.0).astype(np.int64)
    run = np.repeat(np.arange(len(run_row)), count)
    sector, rows = run_sector[run], run_row[run]
    cols = col_lo.astype(np.int64)[run] + _ragged_arange(count)
    # The exact test, the same arithmetic cell by cell as on a sector's whole box.
    dx = x0 + (cols + 0.5) * res - cx[sector]
    dy, ux, uy = dy[run], ux[sector], uy[sector]
    along = dx * ux + dy * uy
    across = dy * ux - dx * uy
    inside = (np.abs(across) <= along * math.tan(half_width)) & (
        along * along + across * across <= (rk * rk)[sector]
    )
    along, across = along[inside], across[inside]
    return ConeCells(
        rows=rows[inside],
        cols=cols[inside],
        rho=np.hypot(along, across),
        theta=np.arctan2(across, along),
        reading=ks[sector[inside]],
    )


_SPAN_MARGIN = 1e-6
"""How far [m] :func:`_sector_span` widens a sector: far above rounding, far below a cell."""


def _ragged_arange(counts: IntArray) -> IntArray:
    """``0, 1, ..., counts[0] - 1, 0, 1, ..., counts[1] - 1, ...`` as one array."""
    total = int(counts.sum())
    starts = np.cumsum(counts) - counts
    return np.arange(total) - np.repeat(starts, counts)


def _sector_span(
    dy: FloatArray, ux: FloatArray, uy: FloatArray, reach: FloatArray, half_width: float
) -> tuple[FloatArray, FloatArray]:
    """Where a horizontal line ``dy`` [m] above a sector's apex crosses the sector.

    The sector (axis ``(ux, uy)``, half-width below 90°, radius ``reach``) is convex: the
    wedge between its two edges cut by its circle. Returns the line's ``dx`` interval
    [m] from the apex, each bound widened by ``_SPAN_MARGIN``; ``lo > hi`` when it misses.
    """
    t = math.tan(half_width)
    norm = math.sqrt(1.0 + t * t)
    lo = np.full(len(dy), -np.inf)
    hi = np.full(len(dy), np.inf)
    # Each edge is a half-plane a·dx <= b (``across`` within ``t`` times ``along``).
    for a, b in (
        (-(uy + t * ux), _SPAN_MARGIN * norm - (ux - t * uy) * dy),
        (uy - t * ux, _SPAN_MARGIN * norm + (ux + t * uy) * dy),
    ):
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = b / a
        hi = np.where(a > 0, np.minimum(hi, bound), hi)
        lo = np.where(a < 0, np.maximum(lo, bound), lo)
        hi = np.where((a == 0) & (b < 0), -np.inf, hi)
    half = np.sqrt(np.maximum((reach + _SPAN_MARGIN) ** 2 - dy * dy, 0.0))
    return np.maximum(lo, -half), np.minimum(hi, half)
