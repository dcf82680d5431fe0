"""Realistic sonar logs: what a real robot's log has and a clean simulator lacks.

:func:`simulate_log` drives a ring (:class:`~bayesmap.sim.sonar.SonarRing`) round a world's
waypoints the way a real robot does and writes down what its log would hold:

- it *turns in place* at every waypoint and *stands still* for a few seconds at random
  moments, so identical rings repeat dozens of times (a stationary transducer repeats its
  echo to the millimetre: the noise is drawn once per place, and ranges are rounded to
  ``quantum`` [m] as the firmware does);
- *people walk through*: each walks to and fro along a random straight line in free space
  (:func:`~bayesmap.sim.sonar.trace` makes them echo);
- door recesses, furniture and clutter come from the realistic worlds of
  :mod:`bayesmap.sim.polygons`; specular loss and one-bounce *multipath* phantoms from the
  ray tracer;
- *odometry drifts*: the logged poses integrate the true motion with a per-run scale error
  and heading noise that grows with distance and turning;
- *no echo* is logged as a code above the maximum range (``no_echo_code``), never as a range;
- optionally (``firing_cycle``), the transducers *fire one after another*, as a Pioneer's
  banks of 8 do, while the log writes a whole ring at every packet: a transducer that has
  not fired since the last ring repeats its last value to the millimetre (ARIA's
  ``isSonarNew`` is what tells a driver which values are fresh; a plain log does not keep
  it), so most readings of a moving robot's ring are a few tenths of a second old.

The truth (true poses, the kind of every reading, where the people were) comes back with the
log for scoring; the mapping code sees only ``times``, ``odometry`` and ``ranges``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import LineString

from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import BoolArray, FloatArray, IntArray, Poses, Ranges
from bayesmap.errors import ConfigError
from bayesmap.geometry import wrap_angle
from bayesmap.sim.polygons import PolygonWorld
from bayesmap.sim.sonar import SonarRing, trace

__all__ = ["Realism", "SimulatedLog", "drive", "odometry", "simulate_log", "walkers"]


class Realism(BaseModel):
    """How a simulated log departs from the clean simulator (all ours; docs/sonar.md)."""

    model_config = ConfigDict(frozen=True)

    speed: float = Field(default=0.4, gt=0, description="Driving speed [m/s].")
    turn_rate_deg: float = Field(default=60.0, gt=0, description="Turning in place [deg/s].")
    ring_rate: float = Field(default=8.0, gt=0, description="Rings per second [Hz].")
    laps: int = Field(default=1, ge=1)
    stops: int = Field(default=3, ge=0, description="Stationary periods per lap.")
    stop_seconds: tuple[float, float] = (3.0, 8.0)
    people: int = Field(default=2, ge=0, description="People walking through.")
    person_radius: float = Field(default=0.2, gt=0, description="[m]")
    person_speed: float = Field(default=1.0, gt=0, description="[m/s]")
    odometry_scale_sd: float = Field(
        default=0.005, ge=0, description="Per-run distance scale error."
    )
    heading_noise: float = Field(
        default=0.004, ge=0, description="Heading random walk [rad per sqrt(m) driven]."
    )
    turn_scale_sd: float = Field(default=0.005, ge=0, description="Per-run turning scale error.")
    no_echo_code: float = Field(
        default=1.05, gt=1, description="No echo is logged as this times the max range."
    )
    quantum: float = Field(default=0.001, ge=0, description="Range rounding [m] (0: none).")
    firing_cycle: float = Field(
        default=0.0,
        ge=0,
        description="Time [s] a bank of 8 transducers takes to fire one after another; each "
        "ring then holds every transducer's latest reading (0: all fresh every ring).",
    )


def latest_firing(times: FloatArray, n: int, cycle: float) -> IntArray:
    """``(m, n)``: for each ring and transducer, the ring whose reading it still holds.

    Transducer ``k`` fires at ``(k mod 8) / 8`` of the ``cycle`` [s] and then once every
    cycle (banks of 8 fire side by side, as a Pioneer's front and rear arrays do). The first
    ring logged after a firing holds its fresh reading, and the rings after it repeat that
    reading until the next firing; the first ring is fresh throughout.
    """
    phase = (np.arange(n) % 8) / 8.0 * cycle
    fired = np.floor((times[:, None] - phase[None, :]) / cycle)
    fresh = np.ones(fired.shape, dtype=bool)
    fresh[1:] = fired[1:] > fired[:-1]
    rings = np.where(fresh, np.arange(len(times))[:, None], 0)
    return np.asarray(np.maximum.accumulate(rings, axis=0))


class SimulatedLog(NamedTuple):
    """A simulated log and its truth.

    Attributes
    ----------
    times
        ``(n,)`` ring times [s].
    odometry
        ``(n, 3)`` logged poses (drifting odometry) [m, m, rad].
    ranges
        ``(n, k)`` logged ranges [m]; no echo is ``no_echo_code · max_range``.
    poses
        ``(n, 3)`` true poses.
    kind
        ``(n, k)`` :class:`~bayesmap.sim.sonar.EchoKind` of each reading.
    specular
        ``(n, k)`` readings that are bounces or lost echoes.
    people
        ``(n, p, 2)`` where each person stood at each ring [m].
    """

    times: FloatArray
    odometry: Poses
    ranges: Ranges
    poses: Poses
    kind: IntArray
    specular: BoolArray
    people: FloatArray


def drive(
    waypoints: FloatArray, realism: Realism, *, rng: np.random.Generator
) -> tuple[Poses, BoolArray]:
    """True poses at each ring: drive the closed waypoint path, turn in place, stop at times.

    Returns the ``(n, 3)`` poses and ``(n,)`` whether the robot moved since the last ring.
    """
    step = realism.speed / realism.ring_rate
    turn_step = math.radians(realism.turn_rate_deg) / realism.ring_rate
    route = np.vstack([waypoints, waypoints[:1]])
    legs = [(a, b) for a, b in zip(route[:-1], route[1:], strict=True) if np.any(a != b)]
    if not legs:
        raise ConfigError("a simulated drive needs at least two distinct waypoints")
    rows: list[FloatArray] = []
    heading = math.atan2(*(legs[0][1] - legs[0][0])[::-1])
    for _ in range(realism.laps):
        for start, end in legs:
            delta = end - start
            length = float(np.hypot(*delta))
            target = math.atan2(delta[1], delta[0])
            turn = float(wrap_angle(target - heading))
            n_turn = int(abs(turn) // turn_step)
            for k in range(1, n_turn + 1):
                rows.append(np.array([start[0], start[1], heading + turn * k / (n_turn + 1)]))
            heading = target
            s = np.arange(0.0, length, step)
            xy = start + s[:, None] * (delta / length)
            rows.extend(np.column_stack([xy, np.full(len(s), heading)]))
    poses = np.vstack(rows)
    poses[:, 2] = wrap_angle(poses[:, 2])
    n_stops = realism.stops * realism.laps
    if n_stops:
        where = np.sort(rng.choice(len(poses), size=min(n_stops, len(poses)), replace=False))
        lo, hi = realism.stop_seconds
        lengths = np.round(rng.uniform(lo, hi, size=len(where)) * realism.ring_rate).astype(int)
        repeat = np.ones(len(poses), dtype=np.int64)
        repeat[where] += lengths
        poses = np.repeat(poses, repeat, axis=0)
    moved = np.ones(len(poses), dtype=bool)
    moved[1:] = np.any(np.abs(np.diff(poses, axis=0)) > 1e-12, axis=1)
    return poses, moved


def odometry(poses: Poses, realism: Realism, *, rng: np.random.Generator) -> Poses:
    """What wheel odometry logs for the true ``poses``: scale errors and heading drift.

    Each step's distance is scaled by ``1 + e_s`` and its turn by ``1 + e_t`` (one draw per
    run), and the heading picks up ``N(0, heading_noise² · distance)``; the result is
    integrated from the true start.
    """
    dxy = np.diff(poses[:, :2], axis=0)
    dist = np.hypot(dxy[:, 0], dxy[:, 1])
    turn = wrap_angle(np.diff(poses[:, 2]))
    scale = 1.0 + rng.normal(0.0, realism.odometry_scale_sd)
    turn_scale = 1.0 + rng.normal(0.0, realism.turn_scale_sd)
    # Direction of travel relative to the heading (the robot drives forwards).
    heading_err = turn * (turn_scale - 1.0) + rng.normal(0.0, 1.0, len(dist)) * (
        realism.heading_noise * np.sqrt(dist)
    )
    heading = poses[0, 2] + np.concatenate([[0.0], np.cumsum(turn + heading_err)])
    travel = np.arctan2(dxy[:, 1], dxy[:, 0]) - poses[:-1, 2]
    travel = np.where(dist > 0, travel, 0.0)
    step_angle = heading[:-1] + travel
    steps = (dist * scale)[:, None] * np.column_stack([np.cos(step_angle), np.sin(step_angle)])
    xy = poses[0, :2] + np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
    return np.column_stack([xy, wrap_angle(heading)])


def walkers(
    world: PolygonWorld, n_rings: int, realism: Realism, *, rng: np.random.Generator
) -> FloatArray:
    """``(n_rings, people, 2)`` positions of people pacing straight lines in free space."""
    room = world.free.buffer(-(realism.person_radius + 0.05))
    xmin, ymin, xmax, ymax = world.bounds
    out = np.full((n_rings, realism.people, 2), np.nan)
    t = np.arange(n_rings) / realism.ring_rate
    for j in range(realism.people):
        for _ in range(500):
            a = rng.uniform([xmin, ymin], [xmax, ymax])
            b = rng.uniform([xmin, ymin], [xmax, ymax])
            length = float(np.hypot(*(b - a)))
            if length > 2.0 and room.contains(LineString([a, b])):
                break
        else:
            continue  # no room for this walker in this world
        phase = rng.uniform(0.0, 2.0 * length)
        s = (phase + realism.person_speed * t) % (2.0 * length)
        s = np.where(s > length, 2.0 * length - s, s)
        out[:, j] = a + s[:, None] * ((b - a) / length)
    return out


def simulate_log(
    world: PolygonWorld,
    ring: SonarRing,
    realism: Realism | None = None,
    *,
    waypoints: FloatArray | None = None,
    rng: RNGLike = None,
) -> SimulatedLog:
    """Drive ``ring`` round ``world`` as a real robot would; return the log and its truth.

    Parameters
    ----------
    world, ring
        Where and with what.
    realism
        The log's departures from a clean simulation (defaults of :class:`Realism`).
    waypoints
        ``(m, 2)`` closed path [m]; default the world's own.
    rng
        Seed or generator for the stops, the people, the odometry and the range noise.
    """
    realism = realism if realism is not None else Realism()
    generator = as_generator(rng)
    path = world.waypoints if waypoints is None else np.asarray(waypoints, dtype=np.float64)
    poses, moved = drive(path, realism, rng=generator)
    people = walkers(world, len(poses), realism, rng=generator)
    # A person standing inside the robot would be seen at range ~0: keep them clear.
    near = np.hypot(*(people - poses[:, None, :2]).transpose(2, 0, 1)) < (
        realism.person_radius + 0.35
    )
    people[near] = np.nan
    clean = trace(world, poses, ring, people=people, person_radius=realism.person_radius)
    # The noise of a standing transducer repeats: one draw per place.
    place = np.cumsum(moved) - 1
    noise = generator.normal(0.0, ring.sigma, size=(int(place[-1]) + 1, ring.n))[place]
    echo = clean.ranges < ring.max_range
    ranges = np.maximum(clean.ranges + noise, ring.min_range)
    if realism.quantum > 0:
        ranges = np.round(ranges / realism.quantum) * realism.quantum
    code = realism.no_echo_code * ring.max_range
    ranges = np.where(echo & (ranges < ring.max_range), ranges, code)
    logged = odometry(poses, realism, rng=generator)
    times = np.arange(len(poses)) / realism.ring_rate
    kind, specular = clean.kind, clean.specular
    if realism.firing_cycle > 0:
        source = latest_firing(times, ring.n, realism.firing_cycle)
        columns = np.arange(ring.n)[None, :]
        ranges, kind, specular = (
            ranges[source, columns],
            kind[source, columns],
            specular[source, columns],
        )
    if not np.all(shapely.contains_xy(world.free, poses[:, 0], poses[:, 1])):
        raise ConfigError(f"world {world.name!r}: the drive leaves free space")
    return SimulatedLog(
        times=times,
        odometry=logged,
        ranges=ranges,
        poses=poses,
        kind=kind,
        specular=specular,
        people=people,
    )
