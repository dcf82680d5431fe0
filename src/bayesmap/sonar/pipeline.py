"""Readings in, map out: run a log of rings through the filter (optional) and a mapper.

A :class:`Pipeline` names one complete way of turning rings into a map: which filter stages
run (ICINCO 2007, p. 494), which sensor model maps the survivors (eq. 1 cone, Thrun's ±0.4,
the ROS range layer), what a no-echo reading does, the saturation and decay of the log-odds,
and whether identical stationary rings count once. :data:`PIPELINES` holds the ones the
experiment compares and ``bayesmap sonar map --pipeline`` offers; :data:`DEFAULT_PIPELINE`
is the one that did best over the realistic simulated worlds (docs/sonar.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, Literal, NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, FloatArray, Grid, IntArray, Poses, ProgressHook, Ranges
from bayesmap.errors import ConfigError, InputError
from bayesmap.grid import OccupancyGrid
from bayesmap.sonar.filter import SpecularFilter, Stage
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.map_verdict import MapJudge, MapVerdict, judging_map
from bayesmap.sonar.mapping import ElfesMapper, NoEcho, RosRangeLayerMapper, ThrunMapper

__all__ = [
    "DEFAULT_PIPELINE",
    "PIPELINES",
    "BuiltMap",
    "MapRun",
    "Pipeline",
    "RingMapper",
    "build_map",
    "grid_for_poses",
    "map_log",
    "repeats_last",
]


_RINGS_PER_BATCH = 100
"""Rings :func:`map_log` hands to the filter and the mapper at once."""


class RingMapper(Protocol):
    """What :func:`map_log` needs of a mapper (see :mod:`bayesmap.sonar.mapping`).

    A mapper may also offer ``integrate_many(poses, ranges, use)``, adding ``m`` rings in
    order with the map that ring-by-ring integration gives (the shipped mappers do, for
    speed); :func:`map_log` uses it when present and otherwise calls :meth:`integrate`
    ring by ring, so a user's own mapper needs only the methods below.
    """

    grid: OccupancyGrid

    def integrate(
        self,
        pose: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None = None,
        free_limit: npt.ArrayLike | None = None,
    ) -> None:
        """Add one ring (``free_limit``: per reading, where its free space stops [m])."""

    def probability(self) -> Grid:
        """Occupancy probability of each cell."""

    def observed(self) -> np.ndarray:
        """Cells some reading has changed."""

    def sync(self) -> OccupancyGrid:
        """Write the map into the grid."""


class MapRun(NamedTuple):
    """What :func:`map_log` did.

    ``accepted`` and ``stage`` per reading ``(n_rings, n)``; ``repeat`` ``(n_rings,)``: rings
    merged with the one before (they take its verdict and are not mapped again).
    """

    accepted: BoolArray
    stage: IntArray
    repeat: BoolArray


def repeats_last(
    last_pose: FloatArray,
    last_ranges: FloatArray,
    pose: FloatArray,
    ranges: FloatArray,
    geometry: SonarGeometry,
) -> bool:
    """Whether a ring repeats the last one: same pose, every reading the same within sigma.

    A standing robot logs the same ring dozens of times; these are one observation, not
    many (two no-echo readings are the same reading).
    """
    if np.any(np.abs(pose[:2] - last_pose[:2]) > 1e-3):
        return False
    if abs(math.remainder(float(pose[2] - last_pose[2]), 2 * math.pi)) > 1e-3:
        return False
    echo, last_echo = geometry.echo(ranges), geometry.echo(last_ranges)
    if np.any(echo != last_echo):
        return False
    return bool(np.all(np.abs(ranges[echo] - last_ranges[echo]) <= geometry.sigma))


def grid_for_poses(
    poses: Poses,
    reach: float,
    resolution: float,
    *,
    prior: float = 0.5,
    max_cells: int = 25_000_000,
) -> OccupancyGrid:
    """An empty grid covering every pose plus ``reach`` [m] around it, at ``resolution`` [m].

    A grid of more than ``max_cells`` cells is refused before anything is allocated, with
    a message that names the likely unit mistake (positions in mm or cm read as metres).
    """
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0 or not np.all(np.isfinite(p)):
        raise InputError(f"poses must be a non-empty finite (n, 3) array, got shape {p.shape}")
    if not (math.isfinite(reach) and reach > 0 and math.isfinite(resolution) and resolution > 0):
        raise ConfigError(f"need positive reach and resolution [m], got {reach}, {resolution}")
    lo = p[:, :2].min(axis=0) - reach
    hi = p[:, :2].max(axis=0) + reach
    span = p[:, :2].max(axis=0) - p[:, :2].min(axis=0)
    cells = math.ceil((hi[0] - lo[0]) / resolution + 1) * math.ceil(
        (hi[1] - lo[1]) / resolution + 1
    )
    if cells > max_cells:
        hint = (
            "positions look like millimetres or centimetres read as metres (set the position unit)"
            if span.max() > 1000.0
            else "use a coarser resolution"
        )
        raise InputError(
            f"the map would have {cells:,} cells ({hi[0] - lo[0]:.4g} m by {hi[1] - lo[1]:.4g} m "
            f"at {resolution:g} m), over the limit of {max_cells:,}: the robot's poses span "
            f"{span[0]:.4g} m by {span[1]:.4g} m; {hint}, or raise the cell limit"
        )
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
    merge_repeats: bool = False,
    map_verdict: MapVerdict | None = None,
    progress: ProgressHook | None = None,
) -> MapRun:
    """Feed each ring through ``filt`` (if any) and integrate the accepted readings.

    Parameters
    ----------
    poses
        ``(n_rings, 3)`` robot poses ``(x [m], y [m], heading [rad])``.
    ranges
        ``(n_rings, n)`` ranges [m]; at or above the max range (or ``inf``) means no echo.
        A range of 0 or less, or below the ring's min range, measured nothing (a driver's
        code for "too close" or "no reading", REP 117's −inf): it is never mapped, its stage
        is :attr:`~bayesmap.sonar.filter.Stage.TOO_CLOSE`, and the filter's neighbour tests
        see it as no echo.
    mapper
        Any :class:`RingMapper`; it is synced into its grid at the end.
    filt
        A :class:`~bayesmap.sonar.filter.SpecularFilter`, or ``None`` to map every reading.
    merge_repeats
        Count a ring that repeats the last one (:func:`repeats_last`) once: it takes the
        last ring's verdict and is neither filtered nor mapped again.
    map_verdict
        After the pass, judge every ring again by the map it ended with
        (:func:`~bayesmap.sonar.map_verdict.judge_by_map`: silences by the surfaces the map
        is sure of in their cones, echoes by what stands in front of them); a mapper that
        refines the whole log (``forward_sweeps``) is judged by its refined map. With
        ``remap``, the streaming map judges instead and the refinement maps the readings
        as the verdict judged them. Needs a mapper with ``geometry``.
    progress
        Optional hook, called as ``progress("mapping", rings_done, rings_total)`` every 100
        rings and at the end.
    """
    p = np.asarray(poses, dtype=np.float64)
    r = np.asarray(ranges, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or r.ndim != 2 or len(p) != len(r):
        raise InputError(
            f"need (n, 3) poses and (n, k) ranges of equal n, got {p.shape} and {r.shape}"
        )
    geometry: SonarGeometry | None = getattr(mapper, "geometry", None)
    too_close = r <= 0.0 if geometry is None else geometry.measured_nothing(r)
    if too_close.any():
        r = np.where(too_close, np.inf, r)
    # One byte a reading for the outcomes while the log runs (stage codes fit in int8).
    accepted = ~too_close
    stage = np.where(too_close, int(Stage.TOO_CLOSE), int(Stage.ACCEPTED)).astype(np.int8)
    repeat = np.zeros(len(p), dtype=bool)
    integrate_many: Callable[..., None] | None = getattr(mapper, "integrate_many", None)
    if map_verdict is not None and geometry is None:
        raise ConfigError("the map's verdict needs a mapper with the ring's geometry")
    last = -1
    # Rings go through in batches: which rings repeat the last one, the filter's
    # trait-independent stages and the cone cells are computed for a batch at once.
    for start in range(0, len(p), _RINGS_PER_BATCH):
        stop = min(start + _RINGS_PER_BATCH, len(p))
        fresh = []
        for i in range(start, stop):
            if (
                merge_repeats
                and last >= 0
                and geometry is not None
                and repeats_last(p[last], r[last], p[i], r[i], geometry)
            ):
                repeat[i] = True
            else:
                last = i
                fresh.append(i)
        if fresh:
            free_limit = np.full((len(fresh), r.shape[1]), np.inf)
            if filt is not None:
                verdict = filt.process_many(p[fresh], r[fresh])
                measured = ~too_close[fresh]
                accepted[fresh] = verdict.accepted & measured
                stage[fresh] = np.where(measured, verdict.stage, int(Stage.TOO_CLOSE))
                free_limit = verdict.free_limit
            # Only a filter that stops free space (keep_supported_echoes) sets a limit.
            limited = bool(np.isfinite(free_limit).any())
            if integrate_many is not None:
                if limited:
                    integrate_many(p[fresh], r[fresh], accepted[fresh], free_limit)
                else:
                    integrate_many(p[fresh], r[fresh], accepted[fresh])
            else:
                for i, limit in zip(fresh, free_limit, strict=True):
                    if limited:
                        mapper.integrate(p[i], r[i], accepted[i], limit)
                    else:
                        mapper.integrate(p[i], r[i], accepted[i])
        for i in range(start, stop):
            if repeat[i]:
                # A repeat takes the verdict of the ring before (a repeat or the one repeated).
                accepted[i], stage[i] = accepted[i - 1], stage[i - 1]
        if progress is not None:
            progress("mapping", stop, len(p))
    if map_verdict is not None and geometry is not None:
        _judge_by_map(p, r, mapper, geometry, map_verdict, accepted, stage, repeat, too_close)
    mapper.sync()
    return MapRun(accepted=accepted, stage=stage.astype(np.int64), repeat=repeat)


def _judge_by_map(
    poses: FloatArray,
    ranges: FloatArray,
    mapper: RingMapper,
    geometry: SonarGeometry,
    verdict: MapVerdict,
    accepted: BoolArray,
    stage: npt.NDArray[np.int8],
    repeat: BoolArray,
    too_close: BoolArray,
) -> None:
    """Replace (in place) the verdicts of a mapped log by the map's (see :func:`map_log`);
    readings ``too_close`` stay unmapped whatever the map says.

    The judging map is the one the pipeline ends with: a mapper that refines the whole log
    (``forward_sweeps``) refines first, unless ``remap`` is to feed the verdict to that
    refinement, in which case the streaming map judges; its transient cells, counted over
    the rings mapped (not the repeats), are unknown to the verdict
    (:func:`~bayesmap.sonar.map_verdict.judging_map`). The rings are judged a chunk at a
    time (:class:`~bayesmap.sonar.map_verdict.MapJudge`), so memory does not grow with the log.
    """
    refine: Callable[[], None] | None = getattr(mapper, "refine", None)
    if not verdict.remap and refine is not None:
        refine()
    fresh = ~repeat
    rows = np.flatnonzero(fresh)
    judged = judging_map(mapper.probability(), mapper.grid, geometry, poses, ranges, verdict, rows)
    MapJudge(judged, mapper.grid, geometry, verdict).judge(poses, ranges, accepted, stage, rows)
    # A repeat takes the verdict of the last ring mapped before it.
    last = np.maximum.accumulate(np.where(fresh, np.arange(len(fresh)), 0))
    accepted[:], stage[:] = accepted[last], stage[last]
    accepted[too_close], stage[too_close] = False, int(Stage.TOO_CLOSE)
    remask: Callable[[BoolArray], None] | None = getattr(mapper, "remask", None)
    if verdict.remap and remask is not None:
        remask(accepted[fresh])


@dataclass(frozen=True)
class Pipeline:
    """One way from rings to a map: filter stages, sensor model and its options.

    Attributes
    ----------
    model
        ``"elfes"`` (eq. 1 cone, :class:`~bayesmap.sonar.mapping.ElfesMapper`), ``"thrun"``
        (Table 9.2, ±0.4) or ``"ros"`` (the ROS ``range_sensor_layer``).
    acceptability, agreeability, trait_verification
        Which filter stages run (none: no filter).
    no_echo, clear_distance
        What a no-echo reading does in the eq. 1 model (see ``ElfesMapper``).
    clamp, decay, footprint
        Log-odds saturation, decay and footprint clearing radius [m] of the eq. 1 model
        (saturation and decay also of Thrun's).
    p_free
        Probability deep in the free part of an eq. 1 cone (its occupied peak stays 0.7).
    sigma_front
        Width [m] of an eq. 1 echo's occupied arc in front of its range (``None``: the
        arc's width on both sides; see ``ElfesMapper``).
    explain_away, explain_beyond
        Share of an echo's occupied evidence along its arc by what the map already knows
        (exponent, 0: off), for arc cells beyond ``explain_beyond`` [m] (see
        ``ElfesMapper``).
    forward_sweeps, forward_gamma, forward_beyond, forward_free_stop, forward_echo_stop
        The forward-model refinement of the eq. 1 map over the whole log (sweeps, 0: off;
        see ``ElfesMapper``).
    merge_repeats
        Count identical stationary rings once.
    map_verdict
        Thresholds of the map's verdict on every reading after the pass (see
        :func:`map_log`), or ``None``: the filter's verdicts stand.
    filter_options
        Further :class:`~bayesmap.sonar.filter.SpecularFilter` settings, as (name, value).
    """

    model: Literal["elfes", "thrun", "ros"] = "elfes"
    acceptability: bool = False
    agreeability: bool = False
    trait_verification: bool = False
    no_echo: NoEcho = "cone"
    clear_distance: float = 2.0
    clamp: float = 10.0
    decay: float = 0.0
    footprint: float = 0.0
    p_free: float = 0.35
    sigma_front: float | None = None
    free_lock: float = 0.0
    explain_away: float = 0.0
    explain_beyond: float = 0.0
    forward_sweeps: int = 0
    forward_gamma: float = 1.0
    forward_beyond: float = 2.0
    forward_free_stop: bool = False
    forward_no_echo: float = 0.0
    forward_echo_stop: bool = False
    merge_repeats: bool = False
    map_verdict: MapVerdict | None = None
    filter_options: tuple[tuple[str, float | None], ...] = ()

    @property
    def filtered(self) -> bool:
        """Whether any filter stage runs."""
        return self.acceptability or self.agreeability or self.trait_verification

    def make_filter(self, geometry: SonarGeometry) -> SpecularFilter | None:
        """The pipeline's filter for ``geometry``, or ``None``."""
        if not self.filtered:
            return None
        options: dict[str, Any] = dict(self.filter_options)
        return SpecularFilter(
            geometry,
            acceptability=self.acceptability,
            agreeability=self.agreeability,
            trait_verification=self.trait_verification,
            **options,
        )

    def make_mapper(self, grid: OccupancyGrid, geometry: SonarGeometry) -> RingMapper:
        """The pipeline's mapper on ``grid``."""
        if self.model == "ros":
            return RosRangeLayerMapper(grid, geometry)
        if self.model == "thrun":
            return ThrunMapper(grid, geometry, clamp=self.clamp, decay=self.decay)
        return ElfesMapper(
            grid,
            geometry,
            no_echo=self.no_echo,
            clear_distance=min(self.clear_distance, geometry.max_range),
            clamp=self.clamp,
            decay=self.decay,
            footprint=self.footprint,
            p_free=self.p_free,
            sigma_front=self.sigma_front,
            free_lock=self.free_lock,
            explain_away=self.explain_away,
            explain_beyond=self.explain_beyond,
            forward_sweeps=self.forward_sweeps,
            forward_gamma=self.forward_gamma,
            forward_beyond=self.forward_beyond,
            forward_free_stop=self.forward_free_stop,
            forward_no_echo=min(self.forward_no_echo, geometry.max_range),
            forward_echo_stop=self.forward_echo_stop,
        )


_STREAMING = Pipeline(
    acceptability=True,
    agreeability=True,
    trait_verification=True,
    no_echo="clear",
    clear_distance=1.0,
    footprint=0.2,
    sigma_front=0.03,
    explain_away=1.0,
    explain_beyond=2.0,
    merge_repeats=True,
    filter_options=(
        ("no_echo_spread", None),
        ("certainty_threshold", 0.3),
        ("keep_supported_echoes", True),
        ("static_span", 0.5),
        ("l_in_case_a", True),
    ),
    map_verdict=MapVerdict(),
)

PIPELINES: dict[str, Pipeline] = {
    "default": replace(
        _STREAMING,
        forward_sweeps=1,
        forward_free_stop=True,
        forward_echo_stop=True,
        map_verdict=MapVerdict(silence_confidence=0.999, silence_width=0.5, open_confidence=0.999),
    ),
    "streaming": _STREAMING,
    "paper": Pipeline(acceptability=True, agreeability=True, trait_verification=True),
    "acceptability": Pipeline(acceptability=True),
    "agreeability": Pipeline(agreeability=True),
    "trait-verification": Pipeline(trait_verification=True),
    "elfes": Pipeline(),
    "elfes-ignore-no-echo": Pipeline(no_echo="ignore"),
    "thrun": Pipeline(model="thrun"),
    "ros": Pipeline(model="ros"),
}
"""The pipelines compared in ``reproduce sonar`` and offered by ``sonar map --pipeline``.

``streaming``: one pass over the log. All three stages with the settings learnt on
simulated logs with known truth (``benchmarks/sonar_tuning.py``, docs/sonar.md): no-echo
readings tested across their cone (axis and both edges) against ``L``, certainty threshold
0.3; an echo that agrees with a trait of ``L`` re-seen over 0.5 m of path is kept despite a
trait in front, whose free space it then stops short of (``keep_supported_echoes``,
``static_span``); ``L`` judges silent readings and stops free space from the start
(``l_in_case_a``); no-echo readings clear 1 m; the robot's footprint (0.2 m) cleared and
kept free; Elfes' free strength ``p_free`` 0.35; an echo's occupied arc one-sided (its
peak over half a cell in front of the echo, then a Gaussian of 0.03 m: ``sigma_front``,
the echo being the first return); an echo's occupied evidence beyond 2 m
shared along its arc by the current map (``explain_away``); identical stationary rings
merged; after the pass, every reading judged again by the map it ended with
(``map_verdict``, the learnt :class:`~bayesmap.sonar.map_verdict.MapVerdict`; it labels the
readings, the map stays the filter's). ``default``: the streaming pipeline's filter and
map, then one sweep of the forward-model refinement over the whole log
(``ElfesMapper.refine``: echo arcs shared by the whole log's map, free space stopped at the
first surface it holds, accepted silences clearing 1 m as in the pass), and the verdict
asked of that refined map, with its own learnt thresholds (sure at 0.999 over half the cone
for a lost echo, nothing above 0.999 in the cone for open space); the best map over the
realistic worlds with the Pioneer 16- and 8-sonar rings (in the open hall the one pass's
is as good), at some more CPU than ``streaming`` (docs/sonar.md). ``paper``: all
three stages with the eq. 1 cone model as first built (no-echo clears the cone, ±10
clamp); the single stages likewise; ``elfes``, ``elfes-ignore-no-echo``, ``thrun``,
``ros``: unfiltered baselines (the ROS layer exactly as ``range_sensor_layer`` does it)."""

DEFAULT_PIPELINE = "default"
"""The pipeline ``sonar map`` uses unless told otherwise."""

DEFAULT_CELL_SIDE = 0.1
"""Map cell side [m] of ``sonar map`` and of the experiment unless told otherwise: a
fifth of a Pioneer's body and a tenth of a door, below the transducers' spacing."""


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
    pipeline: Pipeline | None = None,
    max_cells: int = 25_000_000,
    progress: ProgressHook | None = None,
) -> BuiltMap:
    """Map a log with ``pipeline`` (default: ``PIPELINES[DEFAULT_PIPELINE]``).

    The grid covers every pose plus the max range around it, at ``resolution`` [m].
    """
    chosen = PIPELINES[DEFAULT_PIPELINE] if pipeline is None else pipeline
    grid = grid_for_poses(
        poses, geometry.max_range + geometry.reach, resolution, max_cells=max_cells
    )
    mapper = chosen.make_mapper(grid, geometry)
    filt = chosen.make_filter(geometry)
    outcome = map_log(
        poses,
        ranges,
        mapper,
        filt,
        merge_repeats=chosen.merge_repeats,
        map_verdict=chosen.map_verdict if filt is not None else None,
        progress=progress,
    )
    return BuiltMap(mapper=mapper, run=outcome, filt=filt)
