"""IR mapping on an occupancy grid: readings in, local probability and entropy updates out.

One call of :meth:`IRMapper.update` is the mapping half of a rover cycle (Post et al. 2016
§4.1–4.4): contact detection (eq. 33), range from the ADC reading (§5.1), per-cell evidence
pooled over the rangers (eqs. 31–35), the Bayes map update (eq. 36) and the entropy kept as
its minimum over time (eq. 37). Only the cells within reach of the rangers are touched.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.errors import InputError
from bayesmap.grid import OccupancyGrid, Window
from bayesmap.rover.params import RoverParams
from bayesmap.sensing.fusion import bayes_map_update, ir_cell_evidence
from bayesmap.sensing.ir import contact, range_from_raw, ranger_poses

_TOUCHED = 1e-3
"""Cells whose evidence strength is below this are left alone."""


def local_patch(
    grid: OccupancyGrid, layer: FloatArray, x: float, y: float, radius: float, fill: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cell centres and values of ``layer`` in the square of half-side ``radius`` around ``(x, y)``.

    Cells outside the map are included with value ``fill``, so the patch has the same size
    wherever the rover is (off the map too); its cost depends on ``radius`` only.
    """
    res = grid.resolution
    col0 = math.floor((x - radius - grid.origin[0]) / res)
    row0 = math.floor((y - radius - grid.origin[1]) / res)
    n = int(math.floor(2.0 * radius / res)) + 2
    values = np.full((n, n), fill)
    ny, nx = grid.shape
    r_lo, r_hi = max(row0, 0), min(row0 + n, ny)
    c_lo, c_hi = max(col0, 0), min(col0 + n, nx)
    if r_lo < r_hi and c_lo < c_hi:
        values[r_lo - row0 : r_hi - row0, c_lo - col0 : c_hi - col0] = layer[r_lo:r_hi, c_lo:c_hi]
    rows = np.arange(row0, row0 + n)
    cols = np.arange(col0, col0 + n)
    xc, yc = grid.cell_centers(rows[:, None], cols[None, :])
    return np.broadcast_to(xc, (n, n)), np.broadcast_to(yc, (n, n)), values


class UncertainBlocks:
    """How many cells of each ``size`` x ``size`` block of the map are still uncertain.

    Kept up to date from the windows the mapper writes, so that the nearest uncertain cell
    of the whole map is found by looking at blocks, nearest first, instead of at every
    cell: a cycle's cost does not grow with the map.

    Attributes
    ----------
    counts
        ``(ceil(ny / size), ceil(nx / size))`` uncertain cells per block.
    """

    def __init__(self, uncertain: npt.NDArray[np.bool_], size: int = 8) -> None:
        self.size = size
        ny, nx = uncertain.shape
        by, bx = -(-ny // size), -(-nx // size)
        padded = np.zeros((by * size, bx * size), dtype=np.int64)
        padded[:ny, :nx] = uncertain
        self.counts = padded.reshape(by, size, bx, size).sum(axis=(1, 3))

    @property
    def total(self) -> int:
        """Uncertain cells in the whole map."""
        return int(self.counts.sum())

    def refresh(self, entropy: FloatArray, h_desired: float, window: Window) -> None:
        """Recount the blocks that ``window`` overlaps (cells with ``entropy >= h_desired``)."""
        b = self.size
        r0, r1 = window.row0 // b, (window.row1 - 1) // b + 1
        c0, c1 = window.col0 // b, (window.col1 - 1) // b + 1
        ny, nx = entropy.shape
        padded = np.zeros(((r1 - r0) * b, (c1 - c0) * b), dtype=np.int64)
        part = entropy[r0 * b : r1 * b, c0 * b : c1 * b] >= h_desired
        padded[: part.shape[0], : part.shape[1]] = part
        self.counts[r0:r1, c0:c1] = padded.reshape(r1 - r0, b, c1 - c0, b).sum(axis=(1, 3))

    def nearest_first(self, row: float, col: float) -> npt.NDArray[np.intp]:
        """Flat indices of the blocks holding uncertain cells, nearest to cell ``(row, col)``."""
        held = np.flatnonzero(self.counts)
        bi, bj = np.divmod(held, self.counts.shape[1])
        half = (self.size - 1) / 2
        d = np.hypot(bi * self.size + half - row, bj * self.size + half - col)
        return np.asarray(held[np.argsort(d, kind="stable")])

    def block(self, flat: int) -> Window:
        """The cells of block ``flat`` (clipped to the map by the caller's slicing)."""
        bi, bj = divmod(int(flat), self.counts.shape[1])
        b = self.size
        return Window(bi * b, (bi + 1) * b, bj * b, (bj + 1) * b)


class IRMapper:
    """Keeps the probability and entropy maps up to date from IR readings.

    Parameters
    ----------
    grid
        The map to update (its ``prior`` should be ``params.prior``).
    params
        Sensor model and task parameters.

    Attributes
    ----------
    grid_
        The map being built.
    previous_raw_
        The previous ADC readings (for eq. 33), ``None`` before the first reading.
    uncertain_
        :class:`UncertainBlocks` of the cells whose entropy is still at least
        ``params.h_desired``.
    """

    def __init__(self, grid: OccupancyGrid, params: RoverParams) -> None:
        self.params = params
        self.grid_ = grid
        self.previous_raw_: FloatArray | None = None
        self.uncertain_ = UncertainBlocks(grid.entropy >= params.h_desired)
        self.last_contacts_ = np.zeros(len(params.sensor_angles), dtype=bool)
        self.last_ranges_ = np.full(len(params.sensor_angles), np.inf)
        self.last_above_noise_ = np.zeros(len(params.sensor_angles), dtype=bool)

    def update(self, raw: npt.ArrayLike, pose: npt.ArrayLike) -> Window:
        """Fold ADC readings taken at ``pose`` into the maps; return the window touched."""
        p = self.params
        readings = np.asarray(raw, dtype=np.float64).reshape(-1)
        if readings.shape != (len(p.sensor_angles),) or not np.all(np.isfinite(readings)):
            raise InputError(
                f"expected {len(p.sensor_angles)} finite IR readings (one per ranger), "
                f"got {readings}"
            )
        previous = np.zeros_like(readings) if self.previous_raw_ is None else self.previous_raw_
        contacts = contact(readings, previous, sigma_r=p.sigma_r)
        above_noise = readings > 2.0 * p.sigma_r
        ranges = range_from_raw(readings, p.ir_fit)
        self.previous_raw_ = readings
        self.last_contacts_, self.last_ranges_ = contacts, ranges
        self.last_above_noise_ = above_noise
        sensors = ranger_poses(pose, p.sensor_angles, p.sensor_offset)
        reach = p.r_max + p.sensor_offset + 3.0 * p.sigma_xy
        window = self.grid_.window(float(sensors[0, 0]), float(sensors[0, 1]), reach)
        if window.size == 0:
            return window
        xc, yc = self.grid_.window_centers(window)
        evidence, strength = ir_cell_evidence(
            xc,
            yc,
            sensors,
            ranges,
            contacts,
            prior=p.prior,
            r_max=p.r_max,
            beta_b=p.beta_b,
            w_r=p.w_r,
            sigma_xy=p.sigma_xy,
            reliability_floor=p.reliability_floor,
            above_noise=above_noise,
        )
        touched = strength > _TOUCHED
        block = self.grid_.probability[window.rows, window.cols]
        updated = bayes_map_update(block, p.prior + strength * (evidence - p.prior), p.prior)
        self.grid_.set_probability(window, updated, mask=touched)
        self.uncertain_.refresh(self.grid_.entropy, p.h_desired, window)
        return window

    @property
    def n_uncertain_(self) -> int:
        """Number of cells whose entropy is still at least ``params.h_desired``."""
        return self.uncertain_.total
