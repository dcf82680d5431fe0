"""Readings in, map out: run a log of rings through the filter (optional) and a mapper."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, Grid, IntArray, Poses, Ranges
from bayesmap.errors import ConfigError, InputError
from bayesmap.grid import OccupancyGrid
from bayesmap.sonar.filter import SpecularFilter
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.mapping import ElfesMapper

__all__ = ["BuiltMap", "MapRun", "RingMapper", "build_map", "grid_for_poses", "map_log"]


class RingMapper(Protocol):
    """What :func:`map_log` needs of a mapper (see :mod:`bayesmap.sonar.mapping`)."""

    grid: OccupancyGrid

    def integrate(
        self, pose: npt.ArrayLike, ranges: npt.ArrayLike, use: npt.ArrayLike | None = None
    ) -> None:
        """Add one ring."""

    def probability(self) -> Grid:
        """Occupancy probability of each cell."""

    def observed(self) -> np.ndarray:
        """Cells some reading has changed."""

    def sync(self) -> OccupancyGrid:
        """Write the map into the grid."""


class MapRun(NamedTuple):
    """What :func:`map_log` did: ``accepted`` and ``stage`` per reading, ``(n_rings, n)``."""

    accepted: BoolArray
    stage: IntArray


def grid_for_poses(
    poses: Poses, reach: float, resolution: float, *, prior: float = 0.5
) -> OccupancyGrid:
    """An empty grid covering every pose plus ``reach`` [m] around it, at ``resolution`` [m]."""
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0 or not np.all(np.isfinite(p)):
        raise InputError(f"poses must be a non-empty finite (n, 3) array, got shape {p.shape}")
    if not (math.isfinite(reach) and reach > 0 and math.isfinite(resolution) and resolution > 0):
        raise ConfigError(f"need positive reach and resolution [m], got {reach}, {resolution}")
    lo = p[:, :2].min(axis=0) - reach
    hi = p[:, :2].max(axis=0) + reach
    origin = (
        math.floor(lo[0] / resolution) * resolution,
        math.floor(lo[1] / resolution) * resolution,
    )
    return OccupancyGrid(
        hi[0] - origin[0], hi[1] - origin[1], resolution, origin=origin, prior=prior
    )


def map_log(
    poses: Poses,
    ranges: Ranges,
    mapper: RingMapper,
    filt: SpecularFilter | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> MapRun:
    """Feed each ring through ``filt`` (if any) and integrate the accepted readings.

    Parameters
    ----------
    poses
        ``(n_rings, 3)`` robot poses ``(x [m], y [m], heading [rad])``.
    ranges
        ``(n_rings, n)`` ranges [m]; at or above the max range (or ``inf``) means no echo.
    mapper
        Any :class:`RingMapper`; it is synced into its grid at the end.
    filt
        A :class:`~bayesmap.sonar.filter.SpecularFilter`, or ``None`` to map every reading.
    progress
        Optional ``progress(done, total)`` callback, called every 100 rings.
    """
    p = np.asarray(poses, dtype=np.float64)
    r = np.asarray(ranges, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or r.ndim != 2 or len(p) != len(r):
        raise InputError(
            f"need (n, 3) poses and (n, k) ranges of equal n, got {p.shape} and {r.shape}"
        )
    accepted = np.ones(r.shape, dtype=bool)
    stage = np.zeros(r.shape, dtype=np.int64)
    for i in range(len(p)):
        if filt is not None:
            verdict = filt.process(p[i], r[i])
            accepted[i] = verdict.accepted
            stage[i] = verdict.stage
        mapper.integrate(p[i], r[i], accepted[i])
        if progress is not None and (i % 100 == 99 or i == len(p) - 1):
            progress(i + 1, len(p))
    mapper.sync()
    return MapRun(accepted=accepted, stage=stage)


class BuiltMap(NamedTuple):
    """A map built from a log: the mapper (grid synced), the run and the filter (or ``None``)."""

    mapper: RingMapper
    run: MapRun
    filt: SpecularFilter | None


def build_map(
    poses: Poses,
    ranges: Ranges,
    geometry: SonarGeometry,
    resolution: float,
    *,
    use_filter: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> BuiltMap:
    """Map a log with the eq. 1 cone model, after the specular filter unless ``use_filter`` is off.

    The grid covers every pose plus the max range around it, at ``resolution`` [m].
    """
    grid = grid_for_poses(poses, geometry.max_range + geometry.radius, resolution)
    mapper = ElfesMapper(grid, geometry)
    filt = SpecularFilter(geometry) if use_filter else None
    outcome = map_log(poses, ranges, mapper, filt, progress=progress)
    return BuiltMap(mapper=mapper, run=outcome, filt=filt)
