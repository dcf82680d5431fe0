"""A sonar ring in a polygon world, with specular reflection by ray tracing.

Each transducer's beam is a fan of rays across its cone. A ray that meets a wall at an
incidence angle (from the wall's normal) at most the *critical angle* returns a direct
echo at the hit distance. A ray that meets a wall more obliquely is mirrored off it; if the
mirrored ray meets a second wall within the critical angle, the echo retraces the path and
returns after one bounce, so the transducer reports the whole path length ``d1 + d2``, a
phantom beyond the first wall. The transducer reports the first echo to arrive (the
shortest candidate over its fan); with no echo within the maximum range it reports the
maximum range. Gaussian noise of standard deviation ``sigma`` is added to echoes.

The simulator keeps the truth the mapping code never sees: which readings are direct,
which came back after a bounce, which were lost, and so which were specular.

Functional shape: :func:`h` is the noiseless observation, :func:`observe` the noisy one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import BoolArray, FloatArray, IntArray, Poses, Ranges
from bayesmap.errors import ConfigError, InputError
from bayesmap.geometry import cast_on_segments, to_world
from bayesmap.sensing.sonar_rings import PIONEER_FRONT8, PIONEER_RING16
from bayesmap.sim.polygons import PolygonWorld

__all__ = ["EchoKind", "SonarRing", "SonarScan", "cast_rays", "h", "observe", "trace"]

_EPS = 1e-9


class EchoKind(IntEnum):
    """How a simulated reading came about."""

    DIRECT = 0
    """Echo from the first wall met within the critical angle."""
    BOUNCE = 1
    """Echo after one specular bounce: a phantom beyond the first wall."""
    LOST = 2
    """A wall was in the beam but reflected the pulse away: no echo (max range)."""
    OPEN = 3
    """Nothing within the maximum range: a true no-echo reading."""
    PERSON = 4
    """Echo from a person walking by: a true obstacle, but one that moves on."""


def _pioneer_front_arc() -> tuple[float, ...]:
    return tuple(math.radians(a) for a in (90.0, 50.0, 30.0, 10.0, -10.0, -30.0, -50.0, -90.0))


@dataclass(frozen=True)
class SonarRing:
    """A ring (or arc) of sonar transducers on a robot.

    Parameters
    ----------
    angles
        Bearing of each transducer's axis relative to the robot heading [rad], in ring order.
    radius
        Distance of the transducers from the robot centre [m].
    beam_width
        Full opening angle of each cone [rad] (25° by default, a Polaroid-like transducer).
    sigma
        Standard deviation of the range noise [m].
    max_range
        Maximum range [m]; a reading at or above it means no echo.
    min_range
        Minimum range [m]; noisy echoes (:func:`observe`) are clipped up to it.
    critical_angle
        Largest incidence angle from a wall's normal that still returns an echo [rad].
    fan
        Rays traced across each cone.
    """

    angles: tuple[float, ...] = field(
        default_factory=lambda: tuple(2.0 * math.pi * k / 16 for k in range(16))
    )
    radius: float = 0.15
    beam_width: float = math.radians(25.0)
    sigma: float = 0.02
    max_range: float = 5.0
    min_range: float = 0.1
    critical_angle: float = math.radians(15.0)
    fan: int = 9
    offsets: tuple[tuple[float, float], ...] | None = None
    """Transducer positions ``(x, y)`` [m] in the robot frame; ``None``: on the ring of
    ``radius`` along each axis."""

    def __post_init__(self) -> None:
        if self.offsets is not None and len(self.offsets) != len(self.angles):
            raise ConfigError(
                f"{len(self.offsets)} transducer offsets for {len(self.angles)} transducers"
            )
        if len(self.angles) < 2:
            raise ConfigError(f"a sonar ring needs at least 2 transducers, got {len(self.angles)}")
        if not 0.0 < self.beam_width < math.pi:
            raise ConfigError(f"beam_width must be in (0, pi) rad, got {self.beam_width}")
        if not (
            self.sigma >= 0.0 and 0.0 <= self.min_range < self.max_range and self.radius >= 0.0
        ):
            raise ConfigError("need sigma >= 0, radius >= 0 and 0 <= min_range < max_range [m]")
        if not 0.0 < self.critical_angle < math.pi / 2:
            raise ConfigError(f"critical_angle must be in (0, pi/2) rad, got {self.critical_angle}")
        if self.fan < 1:
            raise ConfigError(f"fan must be at least 1 ray, got {self.fan}")

    @classmethod
    def ring(cls, n: int = 16, **kwargs: float) -> SonarRing:
        """A full ring of ``n`` evenly spaced transducers (default 16, 22.5° apart)."""
        return cls(angles=tuple(2.0 * math.pi * k / n for k in range(n)), **kwargs)  # type: ignore[arg-type]

    @classmethod
    def front_arc(cls, **kwargs: float) -> SonarRing:
        """The 8-transducer front arc of a Pioneer robot: ±90°, ±50°, ±30°, ±10°."""
        return cls(angles=_pioneer_front_arc(), **kwargs)  # type: ignore[arg-type]

    @classmethod
    def pioneer(cls, n: int = 16, **kwargs: float) -> SonarRing:
        """A Pioneer 3-DX ring (``n`` = 8: the front array; 16: front and rear), true offsets."""
        if n not in (8, 16):
            raise ConfigError(f"a Pioneer ring has 8 or 16 transducers, got {n}")
        layout = PIONEER_FRONT8 if n == 8 else PIONEER_RING16
        return cls(
            angles=tuple(a for _, _, a in layout),
            offsets=tuple((x, y) for x, y, _ in layout),
            **kwargs,  # type: ignore[arg-type]
        )

    @property
    def n(self) -> int:
        """Number of transducers."""
        return len(self.angles)

    def positions(self, poses: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Transducer positions ``(n_poses, n, 2)`` [m] and axis bearings ``(n_poses, n)``."""
        axis = poses[:, 2:3] + np.asarray(self.angles)[None, :]
        if self.offsets is None:
            unit = np.stack([np.cos(axis), np.sin(axis)], axis=-1)
            return poses[:, None, :2] + self.radius * unit, axis
        return to_world(poses[:, None, :], self.offsets), axis


class SonarScan(NamedTuple):
    """Readings of a ring at each pose, with the simulator's truth.

    Attributes
    ----------
    ranges
        ``(n_poses, n_transducers)`` reported ranges [m]; ``max_range`` means no echo.
    kind
        ``(n_poses, n_transducers)`` :class:`EchoKind` codes.
    specular
        ``(n_poses, n_transducers)``: the reading is a bounce or a lost echo.
    nearest
        ``(n_poses, n_transducers)`` distance to the nearest wall anywhere in the cone [m]
        (``inf`` if none within the maximum range).
    """

    ranges: Ranges
    kind: IntArray
    specular: BoolArray
    nearest: FloatArray


def cast_rays(
    origins: FloatArray, directions: FloatArray, segments: FloatArray
) -> tuple[FloatArray, IntArray]:
    """First wall hit by each ray.

    Parameters
    ----------
    origins, directions
        ``(m, 2)`` ray starts [m] and unit directions.
    segments
        ``(s, 4)`` walls ``(x0, y0, x1, y1)`` [m].

    Returns
    -------
    (distance, index)
        ``(m,)`` distance to the first hit [m] (``inf`` if none) and the wall's index (−1).
    """
    return cast_on_segments(origins, directions, segments, near=1e-7, parallel=_EPS)


def _normals(segments: FloatArray) -> FloatArray:
    e = segments[:, 2:] - segments[:, :2]
    n = np.column_stack([-e[:, 1], e[:, 0]])
    return np.asarray(n / np.linalg.norm(n, axis=1, keepdims=True))


def _circle_hits(
    origins: FloatArray,
    directions: FloatArray,
    owner: IntArray,
    people: FloatArray,
    radius: float,
) -> FloatArray:
    """Distance along each ray to the first person (a circle of ``radius`` [m]), or ``inf``.

    ``people`` is ``(n_poses, k, 2)``: where each person stands when pose ``owner[ray]`` is
    taken (``nan`` rows: that person is absent).
    """
    centres = people[owner]  # (m, k, 2)
    rel = centres - origins[:, None, :]
    along = np.einsum("mkj,mj->mk", rel, directions)
    across2 = np.einsum("mkj,mkj->mk", rel, rel) - along**2
    with np.errstate(invalid="ignore"):
        half = np.sqrt(radius**2 - across2)
        t = along - half
    ok = np.isfinite(t) & (t > 0)
    return np.asarray(np.where(ok, t, np.inf).min(axis=1, initial=np.inf))


def _trace(
    poses: Poses,
    world: PolygonWorld,
    ring: SonarRing,
    people: FloatArray | None = None,
    person_radius: float = 0.2,
) -> SonarScan:
    poses = np.asarray(poses, dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] != 3 or not np.all(np.isfinite(poses)):
        raise InputError(f"poses must be a finite (n, 3) array of x, y, heading; got {poses.shape}")
    n_poses, n_sensors, n_fan = len(poses), ring.n, ring.fan
    centres, axis = ring.positions(poses)
    half = ring.beam_width / 2.0
    offsets = np.linspace(-half, half, n_fan) if n_fan > 1 else np.zeros(1)
    bearings = axis[..., None] + offsets
    directions = np.stack([np.cos(bearings), np.sin(bearings)], axis=-1).reshape(-1, 2)
    origins = np.broadcast_to(centres[:, :, None, :], (n_poses, n_sensors, n_fan, 2)).reshape(-1, 2)
    segments = world.segments
    normals = _normals(segments)
    t1, wall1 = cast_rays(origins, directions, segments)
    person = np.full_like(t1, np.inf)
    if people is not None and people.shape[1] > 0:
        owner = np.repeat(np.arange(n_poses), n_sensors * n_fan)
        person = _circle_hits(origins, directions, owner, people, person_radius)
        blocked = person < t1
        t1 = np.where(blocked, person, t1)
        wall1 = np.where(blocked, -1, wall1)
        person = np.where(blocked & (person < ring.max_range), person, np.inf)
    hit = wall1 >= 0
    cos1 = np.zeros_like(t1)
    cos1[hit] = np.abs(np.einsum("ij,ij->i", directions[hit], normals[wall1[hit]]))
    cos_critical = math.cos(ring.critical_angle)
    direct = hit & (cos1 >= cos_critical) & (t1 < ring.max_range)
    candidate = np.where(direct, t1, np.inf)
    glancing = hit & ~direct & (t1 < ring.max_range)
    bounce_range = np.full_like(t1, np.inf)
    if np.any(glancing):
        d = directions[glancing]
        nrm = normals[wall1[glancing]]
        mirrored = d - 2.0 * np.einsum("ij,ij->i", d, nrm)[:, None] * nrm
        start = origins[glancing] + t1[glancing, None] * d
        t2, wall2 = cast_rays(start, mirrored, segments)
        hit2 = wall2 >= 0
        cos2 = np.zeros_like(t2)
        cos2[hit2] = np.abs(np.einsum("ij,ij->i", mirrored[hit2], normals[wall2[hit2]]))
        total = t1[glancing] + t2
        ok = hit2 & (cos2 >= cos_critical) & (total < ring.max_range)
        bounce_range[glancing] = np.where(ok, total, np.inf)
    shape = (n_poses, n_sensors, n_fan)
    direct_min = candidate.reshape(shape).min(axis=2)
    bounce_min = bounce_range.reshape(shape).min(axis=2)
    person_min = person.reshape(shape).min(axis=2)
    nearest = np.where(t1 < ring.max_range, t1, np.inf).reshape(shape).min(axis=2)
    ranges = np.minimum(np.minimum(direct_min, bounce_min), person_min)
    kind = np.full((n_poses, n_sensors), EchoKind.OPEN, dtype=np.int64)
    kind[np.isfinite(nearest)] = EchoKind.LOST
    kind[np.isfinite(bounce_min) & (bounce_min < direct_min)] = EchoKind.BOUNCE
    kind[np.isfinite(direct_min) & (direct_min <= bounce_min)] = EchoKind.DIRECT
    kind[np.isfinite(person_min) & (person_min <= np.minimum(direct_min, bounce_min))] = (
        EchoKind.PERSON
    )
    ranges = np.where(np.isfinite(ranges), ranges, ring.max_range)
    specular = (kind == EchoKind.BOUNCE) | (kind == EchoKind.LOST)
    return SonarScan(ranges=ranges, kind=kind, specular=specular, nearest=nearest)


def trace(
    world: PolygonWorld,
    poses: Poses,
    ring: SonarRing,
    *,
    people: FloatArray | None = None,
    person_radius: float = 0.2,
) -> SonarScan:
    """Noiseless readings with people in the way.

    Parameters
    ----------
    world
        The world.
    poses
        ``(n, 3)`` true robot poses.
    ring
        The ring.
    people
        ``(n, k, 2)`` where each of ``k`` people stands at each pose [m] (``nan``: absent),
        or ``None``. A person is a cylinder of ``person_radius`` [m]: clothing and a round
        body echo from any side, so every ray that meets one returns a direct echo
        (:attr:`EchoKind.PERSON`) unless a wall echo arrives first.
    """
    if people is not None:
        people = np.asarray(people, dtype=np.float64)
        if people.ndim != 3 or people.shape[0] != len(poses) or people.shape[2] != 2:
            raise InputError(f"people must be (n_poses, k, 2) positions, got {people.shape}")
    return _trace(poses, world, ring, people, person_radius)


def h(world: PolygonWorld, poses: Poses, ring: SonarRing) -> SonarScan:
    """Noiseless readings of ``ring`` at each of ``poses`` ``(n, 3)`` in ``world``."""
    return _trace(poses, world, ring)


def observe(world: PolygonWorld, poses: Poses, ring: SonarRing, *, rng: RNGLike) -> SonarScan:
    """Noisy readings: :func:`h` plus Gaussian range noise ``N(0, sigma²)`` on every echo.

    A noisy echo is clipped up to ``min_range``; one pushed to or past ``max_range`` becomes
    a no-echo reading (``max_range``).
    """
    generator = as_generator(rng)
    clean = _trace(poses, world, ring)
    echo = clean.ranges < ring.max_range
    noise = generator.normal(0.0, ring.sigma, size=clean.ranges.shape)
    noisy = np.where(echo, np.maximum(clean.ranges + noise, ring.min_range), ring.max_range)
    noisy = np.minimum(noisy, ring.max_range)
    return clean._replace(ranges=noisy)
