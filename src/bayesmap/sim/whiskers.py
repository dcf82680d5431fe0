"""A six-whiskered robot touching the tables microworld (Fox & Prescott 2011 §II-A, eqs. 1–3).

Each whisker is a straight, rigid shaft of length ``whisker_length`` [m] rooted at the
robot's pose. Like ScratchBot's whiskers it *whisks*: in one sweep it rotates about its
root from retracted (``sweep`` [rad] behind its rest angle) to protracted (``sweep`` in
front of it) and stops at its first contact. The contact is where the rotating shaft first
meets a leg or a wall — a corner of a leg, or the point where the whisker's tip meets a
face — or, if the shaft already touches something when retracted, the nearest point
along it. A whisker reports (eqs. 1–3)

- the radial distance r [m] from its root to the contact, ``r̂ = r + ε_r``;
- the surface normal φ [rad] of the touched face (for a corner, the face turned towards
  the root), world frame, pointing out of the solid, ``φ̂ = φ + ε_φ``;
- the texture τ of the touched object, ``τ̂ = τ + ε_τ``;

with i.i.d. zero-mean Gaussian ε of standard deviations ``sigma_r`` [m], ``sigma_theta``
[rad], ``sigma_tau``. Under perfect localisation a report becomes a *shapelet*
``S(x, y, θ, τ)``: the point ``r̂`` along the whisker's direction at contact, with
``θ = φ̂`` (wrapped to [−π, π)) and ``τ = τ̂`` (clipped into (0, 1), its domain).

A whisker cannot feel a contact behind its own root, so the reported distance is folded
at the root: ``r̂ = |r + ε_r|``. Its density is ``N(r̂; r, σ_r) + N(−r̂; r, σ_r)`` for
``r̂ ≥ 0`` (the fused mapper's likelihood uses exactly this); the fold only changes draws
with ``r + ε_r < 0``, which at the ``normal`` noise (σ_r = 2 cm, contacts ≥ 0.15 m away)
never happen.

Every whisker also reports its *sweep* (:data:`SWEEP_COLUMNS`), contact or not: the world
angle it started from, the angle where it stopped (at the contact, or fully protracted when
it touched nothing), its length, and r̂, φ̂, τ̂ (NaN when it touched nothing). This is the
fused mapper's input: a sweep that touched nothing is evidence of free space.

σ_r is in metres. The whiskers of ``"whisker-tables-v1"`` are 1 m long, so the paper's
"very noisy" σ_r = 0.5 is also half a whisker length: both readings of its unit agree.

Functional shape (DESIGN convention 8): the noiseless :func:`h` and the noisy
:func:`observe` are pure functions of the world, the pose and the parameters (and, for
:func:`observe`, a generator). Both also return, for metrics only, the truth label of
what each whisker touched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.errors import ConfigError, InputError
from bayesmap.geometry import cast_on_segments, wrap_angle
from bayesmap.sim.tables_world import TablesWorld

__all__ = [
    "CONDITIONS",
    "SWEEP_COLUMNS",
    "Contacts",
    "WhiskerParams",
    "WhiskerReading",
    "condition",
    "h",
    "observe",
]

_DEG = math.pi / 180.0


@dataclass(frozen=True)
class WhiskerParams:
    """The whisker array and its noise (Fox & Prescott 2011 eqs. 1–3).

    Parameters
    ----------
    whisker_length
        Length of each whisker [m].
    rest_angles
        Rest angle of each whisker relative to the heading [rad] (positive: left). The
        default six — ±12°, ±36°, ±60° — fan three whiskers to each side of the snout.
    sweep
        Half amplitude of a whisk [rad]: a whisker sweeps from ``sweep`` behind its rest
        angle to ``sweep`` in front of it. Default 45°.
    sigma_r
        Standard deviation of the radial-distance noise ε_r [m] (eq. 1).
    sigma_theta
        Standard deviation of the surface-normal noise ε_φ [rad] (eq. 2).
    sigma_tau
        Standard deviation of the texture noise ε_τ (eq. 3).
    """

    whisker_length: float = 1.0
    rest_angles: tuple[float, ...] = tuple(
        a * _DEG for a in (60.0, 36.0, 12.0, -12.0, -36.0, -60.0)
    )
    sweep: float = 45.0 * _DEG
    sigma_r: float = 0.02
    sigma_theta: float = 0.05
    sigma_tau: float = 0.02

    def __post_init__(self) -> None:
        if not self.whisker_length > 0:
            raise ConfigError(
                f"WhiskerParams.whisker_length must be > 0, got {self.whisker_length}"
            )
        if not 0 <= self.sweep < math.pi / 2:
            raise ConfigError(f"WhiskerParams.sweep must lie in [0, π/2) rad, got {self.sweep}")
        if any(a == 0 for a in self.rest_angles):
            raise ConfigError("WhiskerParams.rest_angles must be non-zero (left > 0, right < 0)")
        for name in ("sigma_r", "sigma_theta", "sigma_tau"):
            if not getattr(self, name) >= 0:
                raise ConfigError(f"WhiskerParams.{name} must be >= 0, got {getattr(self, name)}")


CONDITIONS: dict[str, dict[str, float]] = {
    "normal": {"sigma_r": 0.02, "sigma_theta": 0.05, "sigma_tau": 0.02},
    "noiseless": {"sigma_r": 0.0, "sigma_theta": 0.0, "sigma_tau": 0.0},
    "noisy": {"sigma_r": 0.5, "sigma_theta": math.pi / 8, "sigma_tau": 0.02},
}
"""Sensor-noise conditions of the experiment: ``noisy`` is the paper's Fig. 7
(σ_r = 0.5 m, σ_θ = π/8); ``normal`` (Fig. 5, whose σ's the paper does not state) is a
few centimetres and degrees; ``noiseless`` is Fig. 6."""


def condition(name: str, params: WhiskerParams | None = None) -> WhiskerParams:
    """``params`` (default :class:`WhiskerParams`) with the σ's of condition ``name``."""
    if name not in CONDITIONS:
        raise ConfigError(
            f"unknown sensor condition {name!r}; choose from: {', '.join(CONDITIONS)}"
        )
    sigmas = CONDITIONS[name]
    return replace(
        params or WhiskerParams(),
        sigma_r=sigmas["sigma_r"],
        sigma_theta=sigmas["sigma_theta"],
        sigma_tau=sigmas["sigma_tau"],
    )


class Contacts(NamedTuple):
    """Noiseless contacts of one pose's whiskers (one row per whisker).

    Attributes
    ----------
    hit
        ``(w,)`` whether each whisker touched something in its sweep.
    point
        ``(w, 2)`` contact point [m] (the protracted tip if no contact).
    r
        ``(w,)`` radial distance [m] from the root to the contact.
    direction
        ``(w,)`` world angle [rad] of the whisker at contact (or fully protracted).
    normal
        ``(w,)`` surface normal φ [rad] at the contact (NaN if no contact).
    texture
        ``(w,)`` texture τ of the touched object (NaN if no contact).
    table, leg
        ``(w,)`` truth labels: table index and leg index (0–3), :data:`WALL` (−1) for a
        wall, −2 for no contact. For metrics only.
    """

    hit: BoolArray
    point: FloatArray
    r: FloatArray
    direction: FloatArray
    normal: FloatArray
    texture: FloatArray
    table: IntArray
    leg: IntArray


class WhiskerReading(NamedTuple):
    """One pose's noisy readings as shapelets, with truth labels for metrics.

    Attributes
    ----------
    shapelets
        ``(n, 4)`` shapelets ``x, y`` [m], ``theta`` [rad], ``tau`` of the ``n``
        contacting whiskers (the blackboard's input).
    table, leg
        ``(n,)`` what each shapelet's whisker touched: table and leg index, or
        :data:`WALL` (−1) for a wall. For metrics only; the mapper never sees them.
    contacts
        The noiseless :class:`Contacts` behind the readings (for figures).
    sweeps
        ``(w, 6)`` one row per whisker, columns :data:`SWEEP_COLUMNS`.
    """

    shapelets: FloatArray
    table: IntArray
    leg: IntArray
    contacts: Contacts
    sweeps: FloatArray


SWEEP_COLUMNS = ("start", "stop", "length", "range", "normal", "texture")
"""Columns of a sweep row: start and stop world angles [rad] of the whisker, its length
[m], the reported distance r̂ [m], normal φ̂ [rad] and texture τ̂ (the last three NaN when the
sweep touched nothing)."""


NO_CONTACT = -2
"""Truth label of a whisker that touched nothing."""


def _contact_candidates(
    origin: FloatArray, segments: FloatArray, normal: FloatArray, length: float
) -> tuple[FloatArray, IntArray]:
    """Points where a whisker rotating about ``origin`` can first touch the segments.

    A rotating shaft first meets a polygon at one of its corners within reach, or where
    its tip's circle of radius ``length`` crosses a face. Only points on faces turned
    towards the root qualify (their normal has a positive component towards it).
    """
    edge = segments[:, 2:] - segments[:, :2]
    offset = segments[:, :2] - origin
    a = np.einsum("ij,ij->i", edge, edge)
    b = 2.0 * np.einsum("ij,ij->i", offset, edge)
    c = np.einsum("ij,ij->i", offset, offset) - length**2
    disc = b**2 - 4.0 * a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    points = [segments[:, :2], segments[:, 2:]]
    owners = [np.arange(len(segments))] * 2
    for sign in (-1.0, 1.0):
        u = (-b + sign * root) / (2.0 * a)
        ok = (disc >= 0.0) & (u >= 0.0) & (u <= 1.0)
        points.append(segments[ok, :2] + u[ok, None] * edge[ok])
        owners.append(np.flatnonzero(ok))
    point, owner = np.concatenate(points), np.concatenate(owners)
    v = point - origin
    rho = np.hypot(v[:, 0], v[:, 1])
    facing = -(np.cos(normal[owner]) * v[:, 0] + np.sin(normal[owner]) * v[:, 1]) > 0.0
    keep = facing & (rho <= length * (1.0 + 1e-12)) & (rho > 0.0)
    return point[keep], owner[keep]


def h(world: TablesWorld, pose: FloatArray, params: WhiskerParams) -> Contacts:
    """Noiseless whisker contacts at ``pose`` (the simulator's ``h``).

    Parameters
    ----------
    world
        The tables world.
    pose
        ``(3,)`` robot pose ``x, y`` [m], heading [rad]; the whiskers' common root.
    params
        The whisker array (its σ's are ignored here).
    """
    pose = np.asarray(pose, dtype=np.float64)
    if pose.shape != (3,) or not np.isfinite(pose).all():
        raise InputError(f"pose must be a finite (3,) array x, y, heading; got {pose!r}")
    origin = pose[:2]
    rest = pose[2] + np.asarray(params.rest_angles, dtype=np.float64)
    side = np.sign(np.asarray(params.rest_angles))
    start = rest + side * params.sweep
    length = params.whisker_length
    unit = np.column_stack([np.cos(start), np.sin(start)])
    t0, seg0 = cast_on_segments(origin, unit, world.segments, far=length)
    progress = np.where(np.isfinite(t0), 0.0, np.inf)
    owner = np.where(np.isfinite(t0), seg0, -1)
    point = origin + unit * np.where(np.isfinite(t0), t0, 0.0)[:, None]
    candidates, cand_owner = _contact_candidates(origin, world.segments, world.normal, length)
    if len(candidates):
        v = candidates - origin
        rho = np.hypot(v[:, 0], v[:, 1])
        turn = wrap_angle(np.arctan2(v[:, 1], v[:, 0])[None] - start[:, None]) * -side[:, None]
        turn = np.where((turn >= 0.0) & (turn <= 2.0 * params.sweep), turn, np.inf)
        best = np.argmin(turn + 1e-9 * rho[None], axis=1)
        best_turn = turn[np.arange(len(best)), best]
        sooner = best_turn < progress
        progress = np.where(sooner, best_turn, progress)
        owner = np.where(sooner, cand_owner[best], owner)
        point = np.where(sooner[:, None], candidates[best], point)
    hit = np.isfinite(progress)
    end = start - side * 2.0 * params.sweep
    direction = np.where(hit, np.arctan2(point[:, 1] - origin[1], point[:, 0] - origin[0]), end)
    tip = origin + length * np.column_stack([np.cos(end), np.sin(end)])
    point = np.where(hit[:, None], point, tip)
    r = np.hypot(point[:, 0] - origin[0], point[:, 1] - origin[1])
    safe = np.where(hit, owner, 0)
    return Contacts(
        hit=hit,
        point=point,
        r=r,
        direction=wrap_angle(direction),
        normal=np.where(hit, wrap_angle(world.normal[safe]), np.nan),
        texture=np.where(hit, world.texture[safe], np.nan),
        table=np.where(hit, world.table[safe], NO_CONTACT).astype(np.int64),
        leg=np.where(hit, world.leg[safe], NO_CONTACT).astype(np.int64),
    )


def observe(
    world: TablesWorld, pose: FloatArray, params: WhiskerParams, *, rng: np.random.Generator
) -> WhiskerReading:
    """Noisy whisker readings at ``pose`` as shapelets (eqs. 1–3, perfect localisation).

    The noise is drawn for all whiskers (contacting or not) so that the stream of
    ``rng`` advances by the same amount at every pose.
    """
    contacts = h(world, pose, params)
    n = len(contacts.hit)
    noise = rng.standard_normal((3, n))
    r_hat = np.abs(contacts.r + params.sigma_r * noise[0])
    phi_hat = wrap_angle(contacts.normal + params.sigma_theta * noise[1])
    tau_hat = np.clip(contacts.texture + params.sigma_tau * noise[2], 1e-3, 1.0 - 1e-3)
    origin = np.asarray(pose, dtype=np.float64)[:2]
    xy = origin + r_hat[:, None] * np.column_stack(
        [np.cos(contacts.direction), np.sin(contacts.direction)]
    )
    shapelets = np.column_stack([xy, phi_hat, tau_hat])[contacts.hit]
    side = np.sign(np.asarray(params.rest_angles))
    heading = float(np.asarray(pose, dtype=np.float64)[2])
    start = wrap_angle(heading + np.asarray(params.rest_angles) + side * params.sweep)
    missing = np.where(contacts.hit, 1.0, np.nan)
    sweeps = np.column_stack(
        [
            start,
            contacts.direction,
            np.full(n, params.whisker_length),
            r_hat * missing,
            phi_hat * missing,
            tau_hat * missing,
        ]
    )
    return WhiskerReading(
        shapelets=np.ascontiguousarray(shapelets, dtype=np.float64),
        table=contacts.table[contacts.hit],
        leg=contacts.leg[contacts.hit],
        contacts=contacts,
        sweeps=sweeps,
    )
