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

__all__ = ["MapJudge", "MapVerdict", "clearance", "first_surface", "judge_by_map"]


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
    """

    silence_confidence: float = 0.99
    silence_width: float = 0.25
    silence_margin: float = 0.5
    open_confidence: float = 0.9
    echo_confidence: float = 0.9
    echo_margin: float = 1.2
    remap: bool = False

    def __post_init__(self) -> None:
        for name in ("silence_confidence", "open_confidence", "echo_confidence"):
            value = getattr(self, name)
            if not 0.5 <= value < 1.0:
                raise ConfigError(f"map verdict: {name} must be in [0.5, 1), got {value}")
        if not 0.0 < self.silence_width <= 1.0:
            raise ConfigError(
                f"map verdict: silence_width must be in (0, 1], got {self.silence_width}"
            )
        for name in ("silence_margin", "echo_margin"):
            if not getattr(self, name) >= 0.0:
                raise ConfigError(f"map verdict: {name} must be >= 0 m, got {getattr(self, name)}")


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
    MapJudge(probability, grid, geometry, verdict).judge(
        np.asarray(poses, dtype=np.float64), np.asarray(ranges, dtype=np.float64), ok, why
    )
    return ok, why
