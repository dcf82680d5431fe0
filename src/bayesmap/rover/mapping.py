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
    rows = np.arange(row0, row0 + n)
    cols = np.arange(col0, col0 + n)
    values = np.full((n, n), fill)
    ny, nx = grid.shape
    r_ok = (rows >= 0) & (rows < ny)
    c_ok = (cols >= 0) & (cols < nx)
    if r_ok.any() and c_ok.any():
        values[np.ix_(r_ok, c_ok)] = layer[np.ix_(rows[r_ok], cols[c_ok])]
    xc, yc = grid.cell_centers(rows[:, None], cols[None, :])
    return np.broadcast_to(xc, (n, n)), np.broadcast_to(yc, (n, n)), values


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
    n_uncertain_
        Number of cells whose entropy is still at least ``params.h_desired``.
    """

    def __init__(self, grid: OccupancyGrid, params: RoverParams) -> None:
        self.params = params
        self.grid_ = grid
        self.previous_raw_: FloatArray | None = None
        self.n_uncertain_ = int(np.count_nonzero(grid.entropy >= params.h_desired))
        self.last_contacts_ = np.zeros(len(params.sensor_angles), dtype=bool)
        self.last_ranges_ = np.full(len(params.sensor_angles), np.inf)

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
        ranges = range_from_raw(readings)
        self.previous_raw_ = readings
        self.last_contacts_, self.last_ranges_ = contacts, ranges
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
        )
        touched = strength > _TOUCHED
        block = self.grid_.probability[window.rows, window.cols]
        updated = bayes_map_update(block, p.prior + strength * (evidence - p.prior), p.prior)
        before = int(np.count_nonzero(self.grid_.entropy[window.rows, window.cols] >= p.h_desired))
        self.grid_.set_probability(window, updated, mask=touched)
        after = int(np.count_nonzero(self.grid_.entropy[window.rows, window.cols] >= p.h_desired))
        self.n_uncertain_ -= before - after
        return window
