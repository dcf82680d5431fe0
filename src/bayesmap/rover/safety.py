"""Footprint safety: which headings the rover can take without touching a likely obstacle.

Post et al. 2016 look for obstacles only along each heading (eqs. 41–42), while the rover's
body sweeps an arc as it turns, partly outside the rangers' ±47° view. This module checks
the whole footprint (a disc of radius ``footprint_radius``) over the path the drive law
would follow toward each candidate heading for the next ``lookahead`` metres, turning
included, against

- cells of the map that are likely obstacles (``p >= p_block``), each a square of the
  grid's resolution, and their neighbours not yet shown certainly free (a cell the edge of
  an obstacle only clips gets mixed evidence and can look free-ish);
- the points the rangers read right now (any reading above ``2 sigma_r``, before eq. 33
  confirms it), spread over the ranger's angle of view;
- cells never observed (still at the prior): the rangers look ahead only, so a turn can
  sweep the body over ground it has never seen; the body may not overlap such a cell,
  unless it overlaps it already;
- the edge of the mapped area (a path may not end farther outside than it starts).

The footprint must keep ``safety_margin = margin_sigmas * position_sigma`` [m] from them,
so the margin grows with the position uncertainty. When the rover stands inside the margin
and no heading keeps it (hemmed in, e.g. in a corridor narrower than its margin), retreats
are allowed instead: pivot onto a heading, then drive straight along it, where the
footprint never comes closer to a hazard than it is now. The result is the evidence of the
decision network's ``Footprint`` node (:mod:`bayesmap.rover.network`).

Where no heading is safe the rover backs off, turns in place or stops. The rangers look
ahead only, so what lies behind is known from the map alone, drawn in GPS frames that may
be 0.2 m away from the current one; instead, a back-off may reverse only into ground the
body itself occupied in the last ``track_cycles`` cycles (:func:`recent_track`, dead-reckoned
from the rover's own commands, so it does not depend on the GPS) and where no remembered
ranger point lies. A turn in place is always allowed: the body is a disc about the point it
turns on, so turning covers no ground it does not cover already (refusing it where the map
put a hazard under the body, from an older GPS frame, left the rover standing still for
thousands of cycles). All of this is an addition to the paper.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.geometry import to_robot, to_world, wrap_angle
from bayesmap.grid.entropy import probability_at_entropy
from bayesmap.rover.params import RoverParams

_SUBSTEP = 0.2
"""Integration step of the predicted path [s]: 5 cm between footprint checks at 0.25 m/s."""


def drive_command(
    heading: float, psi: float, params: RoverParams, *, cautious: bool = False
) -> tuple[float, float]:
    """``(speed [m/s], yaw rate [rad/s])`` that turns a rover facing ``psi`` toward ``heading``.

    Forward at ``speed`` with a proportional yaw rate capped by the turning radius; a pivot
    in place (skid steer) when the heading is more than 90° away or, ``cautious`` (a hazard
    within reach, :attr:`Safety.cautious`), outside the rangers' view
    (:attr:`RoverParams.view_half_angle`). The rangers look ahead only, so a forward arc
    toward a heading outside their view sweeps the body's inner side over ground they are
    not reading, vetted by the map alone, which may put an obstacle's edge a cell or more
    away from where it is (a partly occupied cell mapped free, an older GPS frame): arcing
    left at 0.4 m radius round a wall end 61° off its heading, whose last 0.8 m the map held
    certainly free, the rover touched it (world 2026/00; −0.099 m). A pivot covers no new
    ground and turns the rangers onto the ground the drive will cross. In open ground,
    with nothing mapped or read within reach, arcs are kept: pivoting there cost a quarter
    of the distance driven and 1.3 points of coverage.
    """
    error = float(wrap_angle(heading - psi))
    if _pivots(error, params, cautious):
        return (0.0, math.copysign(params.pivot_rate, error))
    limit = params.speed / params.min_turn_radius
    return (params.speed, float(np.clip(2.0 * error, -limit, limit)))


def _pivots(error: npt.ArrayLike, params: RoverParams, cautious: bool) -> npt.NDArray[np.bool_]:
    """Whether the drive law (:func:`drive_command`) turns in place toward a heading
    ``error`` [rad] away rather than arcing forward."""
    return np.asarray(np.abs(error) > (params.view_half_angle if cautious else math.pi / 2))


def retreat_command(heading: float, psi: float, params: RoverParams) -> tuple[float, float]:
    """``(speed, yaw rate)`` of a retreat (:attr:`Safety.retreat`): turn in place until the
    rover faces ``heading`` exactly, then drive straight along it.

    The pivot slows to land on ``heading``: a round body keeps its clearance while it
    pivots, and a straight path is what the footprint check cleared, whereas the drive
    law's arcs (:func:`drive_command`) would sweep the body toward a wall of a corridor
    narrower than the margin.
    """
    error = float(wrap_angle(heading - psi))
    if abs(error) > 1e-9:
        return (0.0, math.copysign(min(params.pivot_rate, abs(error) / params.dt), error))
    return (params.speed, 0.0)


_ROUNDING = 1e-9
"""Clearance [m] a retreat may lose to rounding (``sin(pi)`` is not 0 in floating point)."""

_BACK_OFF_GAIN = 0.5
"""Fraction of a cycle's travel that backing off must add to the clearance to count as moving
away from the nearest hazard (:attr:`Safety.ahead`): a hazard within about ±60° of the
heading. A hazard beside the rover, such as a corridor's walls, is not ahead: backing off
gains nothing there, and a rover that backed off from its walls and then drove on along
its retreat went back and forth on the spot for hundreds of cycles."""

_TEMPLATE_STEP = math.radians(0.5)
"""Spacing of the precomputed turning errors [rad]: paths are looked up, not integrated."""


@functools.lru_cache(maxsize=8)
def _path_templates(params: RoverParams, cautious: bool) -> FloatArray:
    """``(E, K, 2)`` centre paths in the rover's frame for turning errors on a 0.5° grid.

    A path depends only on the angle between the candidate heading and the rover's
    heading, so it is integrated once per error (exact arcs, steps of 0.2 s) until the
    rover has driven ``lookahead`` metres after any pivot; one set per drive law
    (``cautious`` or not, :func:`drive_command`).
    """
    error0 = np.arange(-math.pi, math.pi + _TEMPLATE_STEP / 2, _TEMPLATE_STEP)
    x, y, psi = np.zeros_like(error0), np.zeros_like(error0), np.zeros_like(error0)
    travelled = np.zeros_like(error0)
    limit = params.speed / params.min_turn_radius
    n_steps = int(
        math.ceil((params.lookahead / params.speed + math.pi / params.pivot_rate) / _SUBSTEP)
    )
    paths = np.zeros((error0.size, n_steps + 1, 2))
    for k in range(1, n_steps + 1):
        error = wrap_angle(error0 - psi)
        pivot = _pivots(error, params, cautious)
        moving = ~pivot & (travelled < params.lookahead)
        v = np.where(moving, params.speed, 0.0)
        w = np.where(pivot, np.sign(error) * params.pivot_rate, np.clip(2.0 * error, -limit, limit))
        turn = np.where(pivot | moving, w, 0.0) * _SUBSTEP
        # exact arc: a chord of length v dt sinc(turn / 2) along the mean heading
        chord = v * _SUBSTEP * np.sinc(turn / (2.0 * np.pi))
        x = x + chord * np.cos(psi + turn / 2.0)
        y = y + chord * np.sin(psi + turn / 2.0)
        psi = psi + turn
        travelled = travelled + v * _SUBSTEP
        paths[:, k, 0], paths[:, k, 1] = x, y
    return paths


@functools.lru_cache(maxsize=8)
def _template_points(params: RoverParams, cautious: bool) -> tuple[FloatArray, IntArray, IntArray]:
    """The distinct points of each path template (:func:`_path_templates`), found once.

    Returns ``(E, D, 2)`` each template's distinct points other than its start ``(0, 0)``
    (padded), ``(E,)`` how many there are, and ``(E, K)`` for each sample its point: 0 for
    the start, ``1 + j`` for distinct point ``j``. The centre stands still while the rover
    pivots and after it has driven ``lookahead``, so most samples repeat.
    """
    templates = _path_templates(params, cautious)
    found = []
    for path in templates:
        moved = (path != 0.0).any(axis=1)
        points, inverse = np.unique(path[moved], axis=0, return_inverse=True)
        sample = np.zeros(len(path), dtype=np.int64)
        sample[moved] = inverse.ravel() + 1
        found.append((points, sample))
    counts = np.array([len(points) for points, _ in found], dtype=np.int64)
    padded = np.zeros((len(found), int(counts.max(initial=0)), 2))
    for e, (points, _) in enumerate(found):
        padded[e, : len(points)] = points
    samples = np.stack([sample for _, sample in found])
    return padded, counts, samples


def _template_index(
    pose: tuple[float, float, float], headings: npt.ArrayLike, params: RoverParams
) -> IntArray:
    """Index of each heading's path template: its turning error rounded to 0.5°."""
    theta = np.asarray(headings, dtype=np.float64).ravel()
    error = wrap_angle(theta - pose[2])
    return np.asarray(np.rint((error + math.pi) / _TEMPLATE_STEP).astype(np.int64))


def predicted_centres(
    pose: tuple[float, float, float],
    headings: npt.ArrayLike,
    params: RoverParams,
    *,
    cautious: bool = False,
) -> FloatArray:
    """``(M, K, 2)`` positions of the rover's centre along the path toward each heading [m].

    The path the drive law of :func:`drive_command` follows (turning included, a pivot
    first when the heading is more than 90° away or, ``cautious``, outside the rangers'
    view) until the rover has driven
    ``lookahead`` metres; the first sample is the current position. Turning errors are
    rounded to 0.5°.
    """
    local = _path_templates(params, cautious)[_template_index(pose, headings, params)]
    return to_world(pose, local)


def predicted_points(
    pose: tuple[float, float, float],
    headings: npt.ArrayLike,
    params: RoverParams,
    *,
    cautious: bool = False,
) -> tuple[FloatArray, IntArray]:
    """The points of :func:`predicted_centres` without repeats: ``(n, 2)`` points [m], the
    current position first, and ``(M, K)`` the point of each sample.

    Each path's repeats are known from its template (:func:`_template_points`), so no cycle
    sorts its samples; a point two paths share is listed once per path.
    """
    index = _template_index(pose, headings, params)
    local, inverse = _paths_points(params, tuple(index.tolist()), cautious)
    return to_world(pose, local), inverse


@functools.lru_cache(maxsize=2048)
def _paths_points(
    params: RoverParams, index: tuple[int, ...], cautious: bool
) -> tuple[FloatArray, IntArray]:
    """The rover-frame points and sample inverse of :func:`predicted_points` for the
    templates ``index`` (read-only: the headings' templates repeat from cycle to cycle)."""
    padded, counts, samples = _template_points(params, cautious)
    chosen = np.asarray(index, dtype=np.int64)
    count = counts[chosen]
    listed = np.arange(padded.shape[1]) < count[:, None]
    local = np.concatenate([np.zeros((1, 2)), padded[chosen][listed]])
    offset = np.concatenate([[0], np.cumsum(count)[:-1]])
    sample = samples[chosen]
    inverse = np.asarray(np.where(sample == 0, 0, sample + offset[:, None]))
    local.flags.writeable = False
    inverse.flags.writeable = False
    return local, inverse


def shared_start_points(centres: FloatArray) -> tuple[FloatArray, IntArray]:
    """``(M, K, 2)`` paths that all start at one point as ``(n, 2)`` points, the start listed
    once, and ``(M, K)`` the point of each sample (the rest listed as they are)."""
    m, k = centres.shape[:2]
    points = np.concatenate([centres[0, :1], centres[:, 1:].reshape(-1, 2)])
    inverse = np.zeros((m, k), dtype=np.int64)
    inverse[:, 1:] = np.arange(1, m * (k - 1) + 1).reshape(m, k - 1)
    return points, inverse


def square_distance(
    px: npt.ArrayLike, py: npt.ArrayLike, cx: npt.ArrayLike, cy: npt.ArrayLike, half: float
) -> FloatArray:
    """Distance [m] from points ``(px, py)`` to axis-aligned squares of half-side ``half``.

    The squares are centred at ``(cx, cy)``; the arrays broadcast; 0 inside a square.
    """
    dx = np.maximum(np.abs(np.asarray(px) - np.asarray(cx)) - half, 0.0)
    dy = np.maximum(np.abs(np.asarray(py) - np.asarray(cy)) - half, 0.0)
    return np.asarray(np.hypot(dx, dy))


def reading_points(
    sensors: npt.ArrayLike, ranges: npt.ArrayLike, above_noise: npt.ArrayLike, params: RoverParams
) -> FloatArray:
    """``(n, 2)`` points [m] where the current readings may have hit something.

    Every ranger whose reading is above the noise (``2 sigma_r``) and within ``r_max`` gives
    five points at its read range, spread over ``±w_r / 2`` around its axis.
    """
    pose = np.atleast_2d(np.asarray(sensors, dtype=np.float64))
    r = np.asarray(ranges, dtype=np.float64).ravel()
    seen = np.asarray(above_noise, dtype=bool).ravel() & (r <= params.r_max) & (r > 0)
    if not seen.any():
        return np.zeros((0, 2))
    spread = np.linspace(-params.w_r / 2, params.w_r / 2, 5)
    angle = pose[seen, 2:3] + spread[None, :]
    px = pose[seen, 0:1] + r[seen, None] * np.cos(angle)
    py = pose[seen, 1:2] + r[seen, None] * np.sin(angle)
    return np.stack([px.ravel(), py.ravel()], axis=1)


def outside_distance(
    x: npt.ArrayLike, y: npt.ArrayLike, extent: tuple[float, float, float, float]
) -> FloatArray:
    """How far [m] points lie outside the rectangle ``extent = (xmin, xmax, ymin, ymax)``."""
    xmin, xmax, ymin, ymax = extent
    xs, ys = np.asarray(x), np.asarray(y)
    dx = np.maximum(np.maximum(xmin - xs, xs - xmax), 0.0)
    dy = np.maximum(np.maximum(ymin - ys, ys - ymax), 0.0)
    return np.asarray(np.hypot(dx, dy))


@dataclass(frozen=True)
class Safety:
    """The footprint check of one cycle.

    Attributes
    ----------
    safe
        ``(M,)`` headings whose predicted path keeps the footprint clear.
    clearance
        ``(M,)`` smallest distance [m] between the footprint's edge and a likely obstacle
        along each path (negative: overlap); along the retreats' straight paths when
        ``retreat``.
    here
        Clearance [m] of the footprint where it stands now.
    ahead
        Whether the nearest hazard lies ahead of the rover, so that backing off one cycle
        (straight back at ``speed``) widens the clearance by at least half its travel
        (``_BACK_OFF_GAIN``).
    back_clear
        Whether backing off one cycle (straight back at ``speed``) keeps the body on its
        recent track (:func:`back_off_on_track`): ground it occupied itself, where no
        remembered ranger point lies.
    retreat
        Whether the rover stands inside the margin and no heading keeps it, so that
        ``safe`` lists the retreats instead: headings the rover can pivot onto and drive
        straight along without the footprint coming closer to a hazard than ``here``
        (:func:`retreat_command`).
    cautious
        Whether a hazard (a hazard cell or a remembered reading) lies within reach of the
        paths checked, so that the drive law arcs only toward headings in the rangers'
        view (:func:`drive_command`); the paths were predicted with that law.
    """

    safe: BoolArray
    clearance: FloatArray
    here: float
    ahead: bool
    back_clear: bool
    retreat: bool = False
    cautious: bool = False


def footprint_safety(
    pose: tuple[float, float, float],
    headings: npt.ArrayLike,
    obstacle_cells: npt.ArrayLike,
    resolution: float,
    reading_hits: npt.ArrayLike,
    extent: tuple[float, float, float, float],
    params: RoverParams,
    unknown_cells: npt.ArrayLike | None = None,
    track: npt.ArrayLike | None = None,
) -> Safety:
    """Check every candidate heading's swept footprint (see the module docstring).

    Parameters
    ----------
    pose
        Estimated ``(x, y, heading)`` [m, m, rad].
    headings
        ``(M,)`` candidate world headings [rad].
    obstacle_cells
        ``(n, 2)`` centres [m] of the likely-obstacle cells near the rover.
    resolution
        Cell side [m].
    reading_hits
        ``(k, 2)`` points the rangers read now (:func:`reading_points`).
    extent
        The mapped area ``(xmin, xmax, ymin, ymax)`` [m].
    params
        Footprint, margin, drive and look-ahead.
    unknown_cells
        ``(u, 2)`` centres [m] of the cells near the rover never observed.
    track
        ``(K, 2)`` the rover's recent track in its body frame (:func:`recent_track`); without
        it the rover never backs off.
    """
    cells = np.asarray(obstacle_cells, dtype=np.float64).reshape(-1, 2)
    hits = np.asarray(reading_hits, dtype=np.float64).reshape(-1, 2)
    unknown = np.zeros((0, 2)) if unknown_cells is None else np.asarray(unknown_cells)
    check = functools.partial(
        _swept_clearance,
        cells=cells,
        hits=hits,
        unknown=unknown,
        resolution=resolution,
        extent=extent,
        radius=params.footprint_radius,
    )
    cautious = bool(cells.size or hits.size)
    gap, clearance, allowed = check(*predicted_points(pose, headings, params, cautious=cautious))
    here = float(gap[0, 0])
    safe = (clearance >= params.safety_margin) & allowed
    # Hemmed in (inside the margin, no heading keeps it): a retreat pivots onto a heading,
    # which keeps a round body's clearance, then drives straight; it is allowed when the smallest
    # clearance along the straight path is the clearance here (its first sample), so it
    # never brings the body closer to a hazard than it is now.
    retreat = here < params.safety_margin and not safe.any()
    if retreat:
        # Hazards beneath the body cannot be kept away from, and with the centre inside one
        # the gap is at its floor (minus the radius), which every path matches: measured
        # against them a retreat could drive straight through a wall (a start cell still at
        # the prior beside a wall's cell). A retreat is measured against the other hazards
        # and the current readings, and comes no closer to them than the margin or than
        # they are now.
        radius = params.footprint_radius
        beside = square_distance(pose[0], pose[1], cells[:, 0], cells[:, 1], resolution / 2)
        away = functools.partial(
            check,
            cells=cells[beside >= radius],
            hits=hits[np.hypot(hits[:, 0] - pose[0], hits[:, 1] - pose[1]) >= radius],
        )
        straight = straight_centres(pose, headings, params)
        gap, clearance, allowed = away(*shared_start_points(straight))
        floor = min(float(gap[0, 0]), params.safety_margin)
        safe = (clearance >= floor - _ROUNDING) & allowed
    step = params.speed * params.dt
    back = np.array(
        [pose[:2], (pose[0] - step * math.cos(pose[2]), pose[1] - step * math.sin(pose[2]))]
    )
    backed, _, _ = check(back, np.array([[0, 1]]))
    ahead = bool(backed[0, 1] > here + _BACK_OFF_GAIN * step)
    back_clear = track is not None and back_off_on_track(
        np.asarray(track, dtype=np.float64), to_robot(pose, hits), params
    )
    return Safety(
        np.asarray(safe), np.asarray(clearance), here, ahead, back_clear, retreat, cautious
    )


_TRACK_SUBSTEPS = 4
"""Samples of the recent track per cycle: 2.5 cm apart at full speed."""


def recent_track(commands: Sequence[tuple[float, float]], params: RoverParams) -> FloatArray:
    """``(K, 2)`` centres [m] the rover's body occupied while it executed ``commands``, in
    its body frame now (x ahead, y to the left), from ``(0, 0)`` back in time.

    ``commands`` are the ``(speed, yaw rate)`` of the last cycles, oldest first, the newest
    just executed (:attr:`~bayesmap.rover.explorer.Decision.command`). Each is retraced
    backward (``(-v, -w)`` along the same exact arc, ``_TRACK_SUBSTEPS`` samples per cycle),
    so the track is dead reckoning from the rover's own drive and does not depend on the
    GPS, whose fixes of one cycle to the next differ by 0.02 m per axis (σ_GPS 0.1 m,
    τ = 20 s), a third of the clearance to keep. Drive limits are the caller's: a command
    the drive clips is retraced as commanded.
    """
    x = y = psi = 0.0
    points = [(0.0, 0.0)]
    h = params.dt / _TRACK_SUBSTEPS
    for v, w in reversed(commands):
        for _ in range(_TRACK_SUBSTEPS):
            if v == 0.0:  # a pivot: the centre stays, only the heading turns
                psi -= w * h
                continue
            turn = -w * h
            chord = -v * h * _sinc(turn / (2.0 * math.pi))
            x += chord * math.cos(psi + turn / 2.0)
            y += chord * math.sin(psi + turn / 2.0)
            psi += turn
            points.append((x, y))
    return np.asarray(points, dtype=np.float64)


def _sinc(x: float) -> float:
    """``numpy.sinc`` of one float, by the same formula (so to the last bit), without the
    cost of an array call: ``sin(pi x) / (pi x)``, with ``x = 0`` taken as ``1e-20``."""
    y = math.pi * (x if x != 0.0 else 1.0e-20)
    return math.sin(y) / y


def back_off_on_track(track: FloatArray, hits: FloatArray, params: RoverParams) -> bool:
    """Whether backing off one cycle, straight at ``speed``, keeps the body on its track.

    Every sampled centre of the back-off (body frame: ``(-s, 0)`` for ``s`` up to
    ``speed * dt``) must lie within ``track_tolerance`` of the polyline of ``track``
    (:func:`recent_track`), so the body covers ground it occupied itself; and no ranger
    point of ``hits`` (body frame) may lie under the body on the way, which would
    contradict that the ground is free (points under the body where it stands now are
    no reason to stay there).
    """
    if len(track) < 2:
        return False
    s = np.linspace(0.0, params.speed * params.dt, 5)[1:]
    centres = np.stack([-s, np.zeros_like(s)], axis=1)
    on_track = segment_distance(centres, track[:-1], track[1:]).min(axis=1)
    if (on_track > params.track_tolerance).any():
        return False
    radius = params.footprint_radius
    behind = hits[np.hypot(hits[:, 0], hits[:, 1]) >= radius]
    under = np.hypot(centres[:, None, 0] - behind[:, 0], centres[:, None, 1] - behind[:, 1])
    return bool(under.min(initial=np.inf) >= radius)


def segment_distance(points: FloatArray, start: FloatArray, end: FloatArray) -> FloatArray:
    """``(n, m)`` distances [m] from ``(n, 2)`` points to ``m`` segments ``start -> end``."""
    d = end - start
    length2 = np.maximum((d**2).sum(axis=1), 1e-18)
    rel = points[:, None, :] - start[None, :, :]
    t = np.clip((rel * d[None]).sum(axis=2) / length2, 0.0, 1.0)
    closest = start[None] + t[..., None] * d[None]
    return np.asarray(np.hypot(*(points[:, None, :] - closest).transpose(2, 0, 1)))


def straight_centres(
    pose: tuple[float, float, float], headings: npt.ArrayLike, params: RoverParams
) -> FloatArray:
    """``(M, K, 2)`` centre positions [m] of a retreat: straight along each heading for
    ``lookahead`` metres (after a pivot in place onto it, which does not move the centre)."""
    theta = np.asarray(headings, dtype=np.float64).ravel()
    s = np.linspace(
        0.0, params.lookahead, int(math.ceil(params.lookahead / (params.speed * _SUBSTEP))) + 1
    )
    x = pose[0] + s[None, :] * np.cos(theta)[:, None]
    y = pose[1] + s[None, :] * np.sin(theta)[:, None]
    return np.stack([x, y], axis=-1)


def least_hypot(dx: FloatArray, dy: FloatArray) -> FloatArray:
    """``np.hypot(dx, dy).min(axis=1)`` for ``(n, m)`` arrays (``m >= 1``), to the bit.

    ``hypot`` is the costly part, so it is taken only where the squared length is within a
    relative 1e-9 of its row's least: a pair outside that margin is longer than the
    shortest by far more than ``hypot``'s rounding, so the row's minimum is among those
    taken.
    """
    squared = dx * dx + dy * dy
    bound = squared.min(axis=1, keepdims=True) * (1.0 + 1e-9) + 1e-300
    rows, cols = np.nonzero(squared <= bound)
    lengths = np.hypot(dx[rows, cols], dy[rows, cols])
    starts = np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
    return np.asarray(np.minimum.reduceat(lengths, starts))


def _swept_clearance(
    points: FloatArray,
    inverse: IntArray,
    *,
    cells: FloatArray,
    hits: FloatArray,
    unknown: FloatArray,
    resolution: float,
    extent: tuple[float, float, float, float],
    radius: float,
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Gap [m] between the footprint and the nearest hazard at every ``(M, K)`` sample of the
    paths, its minimum along each path, and whether a path stays on the map as far as it
    starts and off cells never observed (unless already beneath the body).

    The paths are given as their distinct ``points`` and the ``inverse`` ``(M, K)`` point of
    each sample (:func:`predicted_points`, :func:`shared_start_points`; most samples repeat), so
    each distance is measured once per point and spread back over the paths. The first
    sample of every path is the rover's position.
    """
    px, py = points[:, 0:1], points[:, 1:2]
    gaps = [np.full(len(points), np.inf)]
    if cells.size:
        gaps.append(square_distance(px, py, cells[:, 0], cells[:, 1], resolution / 2).min(axis=-1))
    if hits.size:
        gaps.append(least_hypot(px - hits[:, 0], py - hits[:, 1]))
    gap = (np.minimum.reduce(gaps) - radius)[inverse]
    outside = outside_distance(points[:, 0], points[:, 1], extent)[inverse]
    allowed = ~(outside > outside[:, :1] + 1e-9).any(axis=1)
    if unknown.size:
        distance = square_distance(px, py, unknown[:, 0], unknown[:, 1], resolution / 2)
        under = distance[inverse[0, 0]] < radius  # already beneath the body
        unseen = ((distance < radius) & ~under).any(axis=1)[inverse]
        allowed &= ~unseen[:, 1:].any(axis=1)
    return np.asarray(gap), np.asarray(gap.min(axis=1)), np.asarray(allowed)


def hazard_cells(probability: npt.ArrayLike, params: RoverParams) -> BoolArray:
    """Cells the footprint keeps its margin from: likely obstacles and their doubtful neighbours.

    Likely: ``p >= p_block``. Doubtful neighbour: 8-connected to a likely cell and not
    certainly free (``p`` above the probability whose entropy is ``h_desired``).
    """
    p = np.asarray(probability, dtype=np.float64)
    likely = p >= params.p_block
    near = ndimage.binary_dilation(likely, structure=np.ones((3, 3), dtype=bool))
    return np.asarray(likely | (near & (p >= probability_at_entropy(params.h_desired))))
