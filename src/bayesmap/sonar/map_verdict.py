"""The map's verdict on each reading, after the streaming pass.

The filter's stages (ICINCO 2007, p. 494) judge a reading by traits of echoes: its
neighbours and the line segments of ``L``. A silence cannot be judged that way in open
space: a lost echo (a wall in the cone, met too obliquely to return the pulse) and true
open space are both silent. The map of the whole log can tell them apart: a silence whose
cone holds a surface the map is sure of, within range, should have heard it, so its echo
was lost; one whose cone the map holds free or unknown out to the max range saw open
space. Likewise an echo with no surface the map is sure of in front of it, in its cone,
agrees with the map and is kept. This is the forward sensor model's question (Thrun 2003,
*Learning occupancy grid maps with forward sensor models*: which cell would the beam have
met first?) asked of the map the pass ended with.

A surface the map holds may have moved on: a person who walked past leaves sure cells
that no later reading of a sonar can erase when the silences that cross them are exactly
the readings under judgement. Whether a pulse comes back from a surface depends on the
angle it meets it at, so a static surface answers a transducer the same way whenever it
is seen along the same bearing; a cell an echo found along one bearing and a silence
crossed along the same bearing held something that was gone (:func:`transient_cells`).
The verdict does not count such cells as surfaces.

The thresholds are learnt on simulated logs with known truth (``python
benchmarks/sonar_diagnose.py verdict``, docs/sonar.md *The map's verdict*).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.ndimage import distance_transform_edt

from bayesmap._typing import BoolArray, FloatArray, Grid, IntArray, Poses, Ranges
from bayesmap.errors import ConfigError
from bayesmap.grid import OccupancyGrid
from bayesmap.sonar.filter import Stage
from bayesmap.sonar.geometry import SonarGeometry

__all__ = [
    "MapJudge",
    "MapVerdict",
    "clearance",
    "first_surface",
    "judge_by_map",
    "judging_map",
    "transient_cells",
]


_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class MapVerdict:
    """Thresholds of the map's verdict (learnt on tuning logs, docs/sonar.md).

    Attributes
    ----------
    silence_confidence
        Occupancy probability a cell needs to count as a surface for a silence.
    silence_width
        Fraction of the cone's half-width searched for that surface (the central part of
        the cone, where the beam is strong).
    silence_margin
        How far inside the max range the surface must lie [m].
    open_confidence
        A silence is open space only when no cell of its whole cone within the max range
        is above this probability; a silence neither lost nor open keeps the filter's
        verdict.
    echo_confidence
        Occupancy probability a cell needs to count as a surface in front of an echo.
    echo_margin
        How far before the echo's range that surface must lie [m]; an echo with no such
        surface anywhere in its cone is kept.
    remap
        Whether the forward-model sweep (``ElfesMapper.refine``) maps the readings as the
        verdict judged them (the streaming map then judges; without ``remap`` a mapper with
        a sweep is judged by its refined map); without a sweep the map stays the streaming
        pass's.
    transient_pairs
        Pairs of an echo and a silence along the same bearing that make a cell transient
        (:func:`transient_cells`); 0: every cell of the map counts.
    transient_bearing
        Width of the bearing bins that pair them [rad]: an echo and a silence pair when
        their bins are the same or adjacent.
    transient_spread
        Cells the map leans occupied within this distance of a transient one are transient
        too [m].
    """

    silence_confidence: float = 0.99
    silence_width: float = 0.25
    silence_margin: float = 0.5
    open_confidence: float = 0.9
    echo_confidence: float = 0.9
    echo_margin: float = 1.2
    remap: bool = False
    transient_pairs: int = 2
    transient_bearing: float = math.radians(5.0)
    transient_spread: float = 0.2

    def __post_init__(self) -> None:
        for name in ("silence_confidence", "open_confidence", "echo_confidence"):
            value = getattr(self, name)
            if not 0.5 <= value < 1.0:
                raise ConfigError(f"map verdict: {name} must be in [0.5, 1), got {value}")
        if not 0.0 < self.silence_width <= 1.0:
            raise ConfigError(
                f"map verdict: silence_width must be in (0, 1], got {self.silence_width}"
            )
        for name in ("silence_margin", "echo_margin", "transient_spread"):
            if not getattr(self, name) >= 0.0:
                raise ConfigError(f"map verdict: {name} must be >= 0 m, got {getattr(self, name)}")
        if not (isinstance(self.transient_pairs, int) and self.transient_pairs >= 0):
            raise ConfigError(
                f"map verdict: transient_pairs must be a whole number >= 0, got "
                f"{self.transient_pairs!r}"
            )
        if not 0.0 < self.transient_bearing <= _TWO_PI / 3.0:
            raise ConfigError(
                "map verdict: transient_bearing must be in (0, 2 pi / 3] rad, got "
                f"{self.transient_bearing}"
            )


def clearance(occupied: BoolArray, grid: OccupancyGrid) -> Grid:
    """``(ny, nx)`` distance [m] from each cell's centre to the nearest ``occupied`` one."""
    if not np.any(occupied):
        return np.full(grid.shape, np.inf)
    return np.asarray(distance_transform_edt(~occupied) * grid.resolution)


def first_surface(
    free_distance: Grid,
    grid: OccupancyGrid,
    centres: FloatArray,
    axis: FloatArray,
    reach: FloatArray,
    half_width: float,
) -> FloatArray:
    """How far along each cone the first surface lies [m], ``inf`` where none within reach.

    Cone marching on ``free_distance`` (:func:`clearance` of the surfaces): the ball
    inscribed in a cone at distance ``t`` along its axis has radius ``t sin(half_width)``,
    and these balls together cover the cone. Where the nearest surface is farther from the
    axis point than that, no surface touches the ball, and the next ball that could touch
    one lies at ``(t + d) / (1 + sin(half_width))``; where it is nearer, a surface lies in
    the cone, about ``t + d`` from the transducer (returned when within ``reach``).
    Distances are read per cell and lowered by half a cell's diagonal, so a surface is
    found to within a cell or two; steps are at least half a cell.

    Parameters
    ----------
    free_distance
        ``(ny, nx)`` distance from each cell to the nearest surface [m].
    grid
        Its grid.
    centres, axis
        ``(k, 2)`` transducer positions [m] and ``(k,)`` beam bearings [rad].
    reach
        ``(k,)`` how far from its transducer each cone is searched [m].
    half_width
        Half the searched cone's width [rad].
    """
    k = len(axis)
    found = np.full(k, np.inf)
    spread = math.sin(half_width)
    slack = grid.resolution * math.sqrt(0.5)
    step = grid.resolution / 2.0
    cos, sin = np.cos(axis), np.sin(axis)
    t = np.zeros(k)
    active = np.flatnonzero(np.asarray(reach) > 0)
    ny, nx = grid.shape
    while len(active):
        x = centres[active, 0] + t[active] * cos[active]
        y = centres[active, 1] + t[active] * sin[active]
        rows, cols = grid.world_to_cell(x, y)
        inside = (rows >= 0) & (rows < ny) & (cols >= 0) & (cols < nx)
        d = np.full(len(active), np.inf)
        d[inside] = free_distance[rows[inside], cols[inside]] - slack
        # A surface touches the ball: it lies in the cone, about t + d from the transducer.
        touched = (d <= t[active] * spread) & (t[active] + np.maximum(d, 0.0) <= reach[active])
        found[active[touched]] = t[active[touched]] + np.maximum(d[touched], 0.0)
        advance = np.maximum((d - t[active] * spread) / (1.0 + spread), step)
        t[active] += advance
        active = active[~touched & (t[active] <= reach[active]) & np.isfinite(d)]
    return found


_RINGS_PER_CHUNK = 5_000
"""Rings :func:`judge_by_map` judges at once: its arrays stay a few MB however long the log."""

_RINGS_PER_TALLY = 1_000
"""Rings :func:`transient_cells` steps along at once: each silence's axis is stepped to the
max range at half a cell (some 90 points a reading), so its chunks are smaller than the
verdict's."""


def _flat_cells(grid: OccupancyGrid, x: FloatArray, y: FloatArray) -> IntArray:
    """Row-major index of the cell holding each point, −1 outside the grid."""
    rows, cols = grid.world_to_cell(x, y)
    ny, nx = grid.shape
    inside = grid.in_bounds(rows, cols)
    return np.where(inside, rows * nx + cols, -1)


def _tally(counted: tuple[IntArray, IntArray], keys: IntArray) -> tuple[IntArray, IntArray]:
    """``counted`` (distinct keys, sorted, and their counts) with ``keys`` added: memory
    stays that of the distinct keys, however long the log."""
    known, counts = counted
    merged, where = np.unique(np.concatenate([known, keys]), return_inverse=True)
    weights = np.concatenate([counts, np.ones(len(keys), dtype=np.int64)])
    return merged, np.bincount(where, weights=weights, minlength=len(merged)).astype(np.int64)


def transient_cells(
    probability: Grid,
    grid: OccupancyGrid,
    geometry: SonarGeometry,
    poses: Poses,
    ranges: Ranges,
    verdict: MapVerdict,
    rows: IntArray | None = None,
) -> BoolArray:
    """``(ny, nx)``: the cells of ``probability`` that held a moving obstacle.

    Whether a pulse returns from a surface depends on the angle it meets the surface at
    (the premise of specular loss, ICINCO 2007, p. 494), and that angle is fixed by the
    bearing it is seen along. So a static surface gives one answer along one bearing: a
    cell where an echo ended (its range along the axis) and which a silence's axis later
    or earlier crossed along the same bearing — their bins of ``transient_bearing`` the
    same or adjacent, the crossing within the max range less ``silence_margin``, where a
    surface would have been heard — held something that was no longer there, or not yet:
    a person walking by. A cell with at least ``transient_pairs`` such pairs (each echo
    pairs with one silence: the smaller count per bin) is transient, and so is every cell
    the map leans occupied (above 1/2) within ``transient_spread`` of one: a moving
    obstacle leaves a connected trace that axes cross only here and there. Only cells the
    map leans occupied can be transient; none with ``transient_pairs`` 0.

    Parameters
    ----------
    probability
        ``(ny, nx)`` the map of the whole log.
    grid, geometry
        Its grid and the ring.
    poses, ranges
        ``(m, 3)`` and ``(m, n)``: the log.
    verdict
        The thresholds.
    rows
        The rings counted (default: all), e.g. without repeats of a standing robot.
    """
    shape = grid.shape
    if verdict.transient_pairs == 0:
        return np.zeros(shape, dtype=bool)
    leaning = np.asarray(probability > 0.5).ravel()
    bins = max(round(_TWO_PI / verdict.transient_bearing), 3)
    reach = geometry.max_range - verdict.silence_margin
    step = grid.resolution / 2.0
    poses, ranges = np.asarray(poses, dtype=np.float64), np.asarray(ranges, dtype=np.float64)
    chosen = np.arange(len(poses)) if rows is None else np.asarray(rows)
    nothing = np.zeros(0, dtype=np.int64)
    echoed: tuple[IntArray, IntArray] = (nothing, nothing)
    crossed: tuple[IntArray, IntArray] = (nothing, nothing)
    for start in range(0, len(chosen), _RINGS_PER_TALLY):
        chunk = chosen[start : start + _RINGS_PER_TALLY]
        centres, axis = geometry.sensors_many(poses[chunk])
        centres, axis = centres.reshape(-1, 2), axis.ravel()
        r = ranges[chunk].ravel()
        bearing_bin = np.floor(np.mod(axis, _TWO_PI) * (bins / _TWO_PI)).astype(np.int64) % bins
        cos, sin = np.cos(axis), np.sin(axis)
        echo = geometry.echo(r) & ~geometry.measured_nothing(r)
        ends = _flat_cells(
            grid, centres[echo, 0] + r[echo] * cos[echo], centres[echo, 1] + r[echo] * sin[echo]
        )
        found = (ends >= 0) & leaning[np.maximum(ends, 0)]
        echoed = _tally(echoed, ends[found] * bins + bearing_bin[echo][found])
        silent = ~geometry.echo(r) & ~geometry.measured_nothing(r)
        x, y, cos, sin = centres[silent, 0], centres[silent, 1], cos[silent], sin[silent]
        silent_bin = bearing_bin[silent]
        previous = np.full(len(x), -1)
        crossings: list[IntArray] = []
        for t in np.arange(step, reach, step):
            cells = _flat_cells(grid, x + t * cos, y + t * sin)
            # an axis leaves a cell for good, so a cell its last step held is not crossed anew
            hit = (cells >= 0) & (cells != previous) & leaning[np.maximum(cells, 0)]
            crossings.append(cells[hit] * bins + silent_bin[hit])
            previous = cells
        if crossings:
            crossed = _tally(crossed, np.concatenate(crossings))
    (echo_keys, echo_count), (crossed_keys, crossed_count) = echoed, crossed
    cell, bearing_bin = np.divmod(echo_keys, bins)
    crossings_near = np.zeros(len(echo_keys), dtype=np.int64)
    if len(crossed_keys):
        last = len(crossed_keys) - 1
        for shift in (-1, 0, 1):  # the same bin and its neighbours
            wanted = cell * bins + (bearing_bin + shift) % bins
            at = np.minimum(np.searchsorted(crossed_keys, wanted), last)
            crossings_near += np.where(crossed_keys[at] == wanted, crossed_count[at], 0)
    pairs = np.bincount(
        cell, weights=np.minimum(echo_count, crossings_near), minlength=leaning.size
    )
    moved = (pairs >= verdict.transient_pairs).reshape(shape)
    if verdict.transient_spread > 0.0 and np.any(moved):
        moved = clearance(moved, grid) <= verdict.transient_spread
    return moved & leaning.reshape(shape)


def judging_map(
    probability: Grid,
    grid: OccupancyGrid,
    geometry: SonarGeometry,
    poses: Poses,
    ranges: Ranges,
    verdict: MapVerdict,
    rows: IntArray | None = None,
) -> Grid:
    """``probability`` with its :func:`transient_cells` unknown (1/2): the map the verdict
    asks (same arguments)."""
    moved = transient_cells(probability, grid, geometry, poses, ranges, verdict, rows)
    return np.where(moved, 0.5, probability)


class MapJudge:
    """The map's verdict (:func:`judge_by_map`) for one map, judging rings a chunk at a time.

    What depends only on the map, the distance from each cell to the nearest surface at each
    of the verdict's confidence levels (:func:`clearance`), is computed once, here; then
    :meth:`judge` judges the rings of a log :data:`_RINGS_PER_CHUNK` at a time, so memory
    does not grow with the log, and each reading gets the verdict it gets judged alone.

    Parameters
    ----------
    probability
        ``(ny, nx)`` the map of the whole pass.
    grid, geometry
        Its grid and the ring.
    verdict
        The thresholds.
    """

    def __init__(
        self,
        probability: Grid,
        grid: OccupancyGrid,
        geometry: SonarGeometry,
        verdict: MapVerdict,
    ) -> None:
        self.grid, self.geometry, self.verdict = grid, geometry, verdict
        levels = {verdict.silence_confidence, verdict.open_confidence, verdict.echo_confidence}
        self.free_distance = {level: clearance(probability > level, grid) for level in levels}

    def judge(
        self,
        poses: FloatArray,
        ranges: FloatArray,
        accepted: BoolArray,
        stage: npt.NDArray[np.integer],
        rows: IntArray | None = None,
    ) -> None:
        """Judge rings ``rows`` (default: all) of a log, in place.

        ``poses`` ``(m, 3)`` and ``ranges`` ``(m, n)`` are the log; ``accepted`` and
        ``stage`` ``(m, n)`` hold the filter's verdicts and get the map's (see
        :func:`judge_by_map`).
        """
        chosen = np.arange(len(poses)) if rows is None else rows
        for start in range(0, len(chosen), _RINGS_PER_CHUNK):
            chunk = chosen[start : start + _RINGS_PER_CHUNK]
            accepted[chunk], stage[chunk] = self._judge_rings(
                poses[chunk], ranges[chunk], accepted[chunk], stage[chunk]
            )

    def _judge_rings(
        self,
        poses: FloatArray,
        ranges: FloatArray,
        accepted: BoolArray,
        stage: npt.NDArray[np.integer],
    ) -> tuple[BoolArray, npt.NDArray[np.integer]]:
        """The map's verdict on a few rings: new ``(accepted, stage)`` arrays."""
        geometry, verdict, grid = self.geometry, self.verdict, self.grid
        centres, axis = geometry.sensors_many(poses)
        centres, axis, r = centres.reshape(-1, 2), axis.ravel(), ranges.ravel()
        ok, why = accepted.ravel().copy(), stage.ravel().copy()
        echo = geometry.echo(r)
        half = geometry.beam_width / 2.0
        silent = ~echo & (why != Stage.ACCEPTABILITY) & (why != Stage.AGREEABILITY)

        def surface_met(
            confidence: float, which: BoolArray, reach: FloatArray, width: float
        ) -> BoolArray:
            """Whether a cell above ``confidence`` lies in each chosen cone within ``reach``."""
            found = first_surface(
                self.free_distance[confidence], grid, centres[which], axis[which], reach, width
            )
            return np.asarray(np.isfinite(found))

        if np.any(silent):
            within = np.full(int(silent.sum()), geometry.max_range)
            lost = surface_met(
                verdict.silence_confidence,
                silent,
                np.maximum(within - verdict.silence_margin, 0.0),
                verdict.silence_width * half,
            )
            open_space = ~surface_met(verdict.open_confidence, silent, within, half)
            ok[silent] = np.where(lost, False, np.where(open_space, True, ok[silent]))
            why[silent] = np.where(
                lost,
                int(Stage.MAP_VERDICT),
                np.where(open_space, int(Stage.ACCEPTED), why[silent]),
            )
        if np.any(echo):
            blocked = surface_met(
                verdict.echo_confidence, echo, r[echo] - verdict.echo_margin, half
            )
            clear = np.flatnonzero(echo)[~blocked]
            ok[clear] = True
            why[clear] = int(Stage.ACCEPTED)
        return ok.reshape(accepted.shape), why.reshape(stage.shape)


def judge_by_map(
    probability: Grid,
    grid: OccupancyGrid,
    geometry: SonarGeometry,
    poses: Poses,
    ranges: Ranges,
    accepted: BoolArray,
    stage: IntArray,
    verdict: MapVerdict,
) -> tuple[BoolArray, IntArray]:
    """The map's verdict on ``m`` rings, over the filter's (``accepted``, ``stage``).

    - A silence that reached Trait Verification (the bottom-up stages' rejections stand)
      is rejected (:attr:`Stage.MAP_VERDICT`) when the central ``silence_width`` of its
      cone holds a cell of ``probability`` above ``silence_confidence`` within the max
      range less ``silence_margin`` (a lost echo), and accepted when no cell of its whole
      cone within the max range is above ``open_confidence`` (open space); otherwise the
      filter's verdict stands.
    - An echo is accepted when no cell above ``echo_confidence`` lies in its cone more
      than ``echo_margin`` before its range (nothing the map is sure of stood in the
      way); otherwise the filter's verdict stands.

    Parameters
    ----------
    probability
        ``(ny, nx)`` the map of the whole pass.
    grid, geometry
        Its grid and the ring.
    poses, ranges
        ``(m, 3)`` and ``(m, n)``: the rings judged.
    accepted, stage
        ``(m, n)``: the filter's verdicts.
    verdict
        The thresholds.

    Returns
    -------
    ``(accepted, stage)``, new ``(m, n)`` arrays (judged :data:`_RINGS_PER_CHUNK` rings at a
    time by one :class:`MapJudge`).
    """
    ok, why = np.array(accepted), np.array(stage)
    p, r = np.asarray(poses, dtype=np.float64), np.asarray(ranges, dtype=np.float64)
    judged = judging_map(probability, grid, geometry, p, r, verdict)
    MapJudge(judged, grid, geometry, verdict).judge(p, r, ok, why)
    return ok, why
