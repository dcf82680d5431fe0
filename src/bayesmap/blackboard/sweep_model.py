"""The fused mapper's model: object types, the sweep likelihood and the joint posterior.

This extends Fox & Prescott (2011) §II-B past the paper, as its §IV proposes: several object
types, memory of every whisker sweep, negative evidence, walls. Pure functions on arrays;
docs/blackboard.md ("The fused mapper") gives the equations and choices.

Notation. A map X is a set of tables t = (x, y, θ, k): centre [m], long-side angle θ ∈ [0, π)
[rad] and type k from a catalogue of :class:`ObjectType`. A table of type k has four square
legs of side w_k centred at (±a_k, ±b_k) in its own frame, a_k = (l_k − w_k)/2,
b_k = (d_k − w_k)/2 (legs flush with the corners, as in the paper's world). A *sweep* i
is one whisk of one whisker: root o_i, start and stop angles, length L_i and, if it touched
something, the reported distance r̂_i along the stop bearing ψ_i and normal φ̂_i.

Joint posterior (log, up to a constant), −∞ when a table crosses a wall (tables stand
inside the arena)::

    log π(X | D) = Σ_t log λ_k + Σ_{t<u} v(t, u) log ε_c                    (prior, F1)
                 + Σ_{i contact} n_i log max(κ, ρ_wall(i), max_legs ρ_leg(i))  (contacts, F2)
                 + Σ_t Σ_legs s(leg) log p_miss                              (free space, F3)

- F1: a Poisson process of tables of intensity λ_k per m² per rad for each type (density
  with respect to the unit-rate process, Geyer & Møller 1994), the paper's flat eq. 4,
  times the paper's overlap factor φ_c = ε_c^v (eq. 16), v = 1 for two overlapping tables.
  The fused mapper's default is ε_c = 0 (log ε_c = −∞): solid tables cannot overlap, and a
  soft ε_c lets a slightly shifted copy of a well-seen table pay for itself by fitting
  each contact a little better (we measured gains of 30–70 nats). A wall is a hard limit.
- F2: a contact has exactly one cause c_i: clutter (density κ per m² per rad), a wall or
  one leg — a whisker stops at the first surface it meets. The cause is profiled out (its
  most likely value), not summed: the paper's noisy-OR sum (eq. 12) pays a second copy of a
  table for the contacts the first already explains, so a chain on it piles duplicate
  tables on well-seen legs (we saw +69 nats for a duplicate against ε_c = e⁻¹⁰). Each
  surface's density is the range-bearing sensor model: along the whisker the range noise
  σ_r (folded at the root, as the simulator folds it), across it σ_⊥, and the normal σ_φ —
  a normalised Gaussian, so a noisier contact weighs less against clutter. A surface
  beyond the whisker's reach (its length) explains no contact: with σ_r = 0.5 m the range
  says little, but the bearing (exact) and the reach still pin the surface to a segment of
  the whisker.
- F3: s(leg) counts sweeps whose free sector (swept before the contact, or the whole
  sector when nothing was touched) wholly contains the leg: each such sweep missed the leg,
  which happens with probability p_miss.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.blackboard.densities import rectangles_overlap, rectangles_overlap_scalar
from bayesmap.errors import ConfigError
from bayesmap.geometry import is_solid_square, rectangle_fit_problem, wrap_angle

__all__ = [
    "ACROSS_CUT",
    "SCREEN_ROWS",
    "ObjectType",
    "SweepModel",
    "arena_contains",
    "check_catalogue",
    "contact_cutoff",
    "contact_squares",
    "into_arena",
    "leg_centres",
    "leg_contact_density",
    "leg_contact_density_pairs",
    "legs_swept",
    "legs_swept_pairs",
    "log_posterior",
    "overlap_pairs",
    "reachable_point",
    "tables_overlap",
    "wall_contact_density",
]

_TWO_PI = 2.0 * math.pi

_REACH_ROUNDING = 1e-9
"""[m] A surface computed to lie exactly at the whisker's reach (its tip touching a wall or
a leg, as a whisker first does) comes out up to ~1e-15 m beyond it in floating point; it
is within reach."""


class ObjectType(NamedTuple):
    """One kind of four-legged object (the paper's §IV "several types of object").

    Attributes
    ----------
    name
        Label the map reports.
    length, width
        Outer size [m]; the long side lies along the table's θ.
    leg
        Side of its square legs [m], flush with the corners, at most half the width; legs of
        half the width meet, and a square type is then a solid box or pillar.
    """

    name: str
    length: float
    width: float
    leg: float

    @property
    def solid(self) -> bool:
        """Whether the type is a solid square, a box or pillar: square, legs half its side.

        Whiskers touch such a type on its outline, one square, the whole object
        (:func:`contact_squares`): its four legs meet, and their corners at the seams,
        mid-face, are corners no whisker stops at (a rotating shaft meets a box first at
        an outer corner). Modelled as four legs, two boxes half a side apart put their seams
        on a true box's corners and explained its contacts better than the box itself. The
        free-space term still counts the four quarters a sweep passed over (:func:`leg_centres`):
        the smaller squares lie wholly inside more sweeps than the whole one."""
        return is_solid_square(self.length, self.width, self.leg)

    @property
    def half_spacing(self) -> tuple[float, float]:
        """``(a, b)`` [m]: leg centres sit at ``(±a, ±b)`` in the table's frame."""
        return 0.5 * (self.length - self.leg), 0.5 * (self.width - self.leg)

    @property
    def contact_half_side(self) -> float:
        """Half the side [m] of the squares a whisker touches: a leg's, or the whole
        object's for a :attr:`solid` type."""
        return 0.5 * (self.width if self.solid else self.leg)


def check_catalogue(
    catalogue: tuple[ObjectType, ...], arena: tuple[float, float] | None = None
) -> tuple[ObjectType, ...]:
    """Validate a catalogue of object types (and, given the ``arena`` (width, height) [m],
    that each type could stand in it); :class:`ConfigError` names the bad one."""
    if not catalogue:
        raise ConfigError("the catalogue of object types must hold at least one type")
    for k, t in enumerate(catalogue):
        problem = None if arena is None else rectangle_fit_problem(t.length, t.width, arena)
        if problem is not None:
            raise ConfigError(f"catalogue[{k}] ({t.name}): {problem}")
        twin = next((j for j, other in enumerate(catalogue[:k]) if other.name == t.name), None)
        if twin is not None:
            raise ConfigError(
                f"catalogue[{k}] has the name of catalogue[{twin}] ({t.name!r}): the map could "
                "not tell their objects apart"
            )
        if not (0 < 2 * t.leg <= t.width <= t.length):
            raise ConfigError(
                f"catalogue[{k}] ({t.name}): need 0 < 2 × leg <= width <= length, got "
                f"length={t.length}, width={t.width}, leg={t.leg}"
            )
        for j, other in enumerate(catalogue[:k]):
            if (t.length, t.width, t.leg) == (other.length, other.width, other.leg):
                raise ConfigError(
                    f"catalogue[{k}] ({t.name}) has the size of catalogue[{j}] ({other.name}): "
                    "no contact can tell them apart, so a table's belief would split between them"
                )
    return tuple(catalogue)


class SweepModel(NamedTuple):
    """Constants of the sweep likelihood and prior (units in brackets).

    Attributes
    ----------
    sigma_r
        Range noise along the whisker [m].
    sigma_perp
        Spread across the whisker [m] (bearings are exact; this absorbs where on a leg's
        face the whisker rests).
    sigma_phi
        Normal noise [rad].
    clutter
        κ: density of contacts from no modelled surface [m⁻² rad⁻¹].
    p_miss
        Probability that a whisker sweeps through a leg without reporting it.
    intensity
        λ: prior density of tables of each type [m⁻² rad⁻¹].
    log_overlap
        log ε_c, the log factor of each overlapping pair of tables (eq. 16).
    arena
        ``(width, height)`` [m] of the walled arena, corner at the origin.
    reach
        Whisker length [m]: a whisker touches nothing farther than this from its root, so
        a surface beyond reach explains no contact, whatever its range noise (∞: no bound).
    """

    sigma_r: float
    sigma_perp: float
    sigma_phi: float
    clutter: float
    p_miss: float
    intensity: float
    log_overlap: float
    arena: tuple[float, float]
    reach: float = math.inf


def _normal(x: FloatArray, sigma: float) -> FloatArray:
    return np.asarray(np.exp(-0.5 * (x / sigma) ** 2) / (math.sqrt(_TWO_PI) * sigma))


def _range_density(r_hat: FloatArray, r: FloatArray, sigma: float) -> FloatArray:
    """Folded range noise: N(r̂; r, σ) + N(−r̂; r, σ) for r̂ ≥ 0 (the simulator's fold)."""
    return np.asarray(_normal(r_hat - r, sigma) + _normal(r_hat + r, sigma))


_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])


@functools.lru_cache(maxsize=16)
def _sizes(catalogue: tuple[ObjectType, ...]) -> FloatArray:
    """``(k, 5)`` per type: leg offsets ``a, b``, half leg side, half length, half width [m]
    (built once per catalogue: the chain asks for them at every move)."""
    sizes = np.array(
        [(*t.half_spacing, 0.5 * t.leg, 0.5 * t.length, 0.5 * t.width) for t in catalogue]
    )
    sizes.flags.writeable = False
    return sizes


@functools.lru_cache(maxsize=16)
def _contact_sizes(catalogue: tuple[ObjectType, ...]) -> FloatArray:
    """``(k, 3)`` per type: offsets ``a, b`` and half side of the squares a whisker touches
    (the legs; the whole object, at the centre, for a solid type)."""
    sizes = np.array([_contact_row(t) for t in catalogue])
    sizes.flags.writeable = False
    return sizes


def _contact_row(kind: ObjectType) -> tuple[float, float, float]:
    if kind.solid:
        return 0.0, 0.0, kind.contact_half_side
    return (*kind.half_spacing, 0.5 * kind.leg)


def contact_squares(tables: FloatArray, catalogue: tuple[ObjectType, ...]) -> FloatArray:
    """``(n, 4, 3)`` squares ``x, y, half side`` whose faces the whiskers touch on ``(n, 4)``
    tables ``x, y, θ, k``: the legs (:func:`leg_centres`), except that a solid type's four
    rows are all its whole outline (see :attr:`ObjectType.solid`)."""
    return _squares(tables, _contact_sizes(catalogue))


def leg_centres(tables: FloatArray, catalogue: tuple[ObjectType, ...]) -> FloatArray:
    """``(n, 4, 3)`` legs ``x, y, half side`` of ``(n, 4)`` tables ``x, y, θ, k``.

    Corner order: (+a, +b), (−a, +b), (−a, −b), (+a, −b), counter-clockwise.
    """
    return _squares(tables, _sizes(catalogue)[:, :3])


def _squares(tables: FloatArray, sizes: FloatArray) -> FloatArray:
    """``(n, 4, 3)`` squares at ``(±a, ±b)`` in each table's frame, ``sizes`` (k, 3) rows
    ``a, b, half side`` per type."""
    tables = np.asarray(tables, dtype=np.float64).reshape(-1, 4)
    kinds = tables[:, 3].astype(np.int64)
    spacing = sizes[kinds]
    lx = spacing[:, :1] * _SIGNS[:, 0]
    ly = spacing[:, 1:2] * _SIGNS[:, 1]
    c, s = np.cos(tables[:, 2:3]), np.sin(tables[:, 2:3])
    out = np.empty((len(tables), 4, 3))
    out[..., 0] = tables[:, :1] + c * lx - s * ly
    out[..., 1] = tables[:, 1:2] + s * lx + c * ly
    out[..., 2] = spacing[:, 2:3]
    return out


def contact_cutoff(half_side: float, model: SweepModel) -> float:
    """Distance [m] from a leg's centre beyond which a contact point gets ρ_leg = 0.

    The contact point is :func:`reachable_point` (the reported range clipped to the
    whisker's reach). 4σ_r along (at most the reach: the clipped point and the leg's face
    both lie on the whisker within reach) plus 4σ_⊥ across plus the leg's half diagonal:
    the Gaussian there is below e⁻⁸ of its peak. The cut keeps every sum local (and the
    joint and the local ratios use the same truncated density). With σ_r = 0.5 m and 1 m
    whiskers the reach halves the cut (1.1 m instead of 2.1 m), and with it the evidence
    every move reads.
    """
    along = min(4.0 * model.sigma_r, model.reach)
    return along + 4.0 * model.sigma_perp + math.sqrt(2.0) * half_side


def reachable_point(
    root: FloatArray, bearing: FloatArray, r_hat: FloatArray, reach: FloatArray | float
) -> FloatArray:
    """``(m, 2)`` contact points ``root + min(r̂, reach) (cos ψ, sin ψ)`` [m].

    Where a contact can have been: on the whisker within its reach. A range read beyond the
    whisker's length (noise) is placed at the tip; the spatial index of the evidence and the
    cut of :func:`contact_cutoff` both use this point.
    """
    r = np.minimum(r_hat, reach)
    return np.column_stack([root[:, 0] + r * np.cos(bearing), root[:, 1] + r * np.sin(bearing)])


ACROSS_CUT = 8.0
"""Gaps between a whisker's line and a leg beyond this many σ_⊥ get ρ_leg = 0."""


def leg_contact_density(
    root: FloatArray,
    bearing: FloatArray,
    r_hat: FloatArray,
    phi_hat: FloatArray,
    legs: FloatArray,
    theta: FloatArray,
    model: SweepModel,
) -> FloatArray:
    """``(m, j)`` density ρ_leg of ``m`` contacts under ``j`` square legs (term F2).

    The whisker's line from ``root`` (m, 2) along ``bearing`` (m,) [rad] enters a leg
    (``legs`` (j, 3) rows ``x, y, half side``; ``theta`` (j,) its angle) at distance r*
    through a face of normal φ* (of the faces turned towards the root, the one nearest φ̂).
    If the line misses the leg, r* is the along-distance of the
    leg's centre and e_⊥ the gap between the line and the square (the centre's distance from
    the line less the square's half extent across it). Density::

        ρ = [N(r̂; r*, σ_r) + N(−r̂; r*, σ_r)] · N(e_⊥; 0, σ_⊥) · N(wrap(φ̂ − φ*); 0, σ_φ)

    set to 0 where the contact point (:func:`reachable_point`) lies farther than
    :func:`contact_cutoff` from the leg's centre, where the line passes farther than
    :data:`ACROSS_CUT` σ_⊥ from the square (there the across factor is below e⁻³² of its
    peak, under 10⁻¹⁰ of any clutter density κ the mapper uses), and where the leg lies
    beyond the whisker's reach (r* > reach when the line enters it; its centre's
    along-distance less its half diagonal > reach when the line misses it): a whisker
    cannot touch it there.

    Only the (contact, leg) pairs that pass the first two cuts are evaluated in full: with
    σ_r = 0.5 m a contact point may lie a metre from a leg along its whisker, but few of
    the whisker lines around a table pass within a few centimetres of one of its legs, and
    a line that passes one leg rarely passes the other three.
    """
    out = np.zeros((len(root), len(legs)))
    if not len(root) or not len(legs):
        return out
    cos_b, sin_b = np.cos(bearing), np.sin(bearing)
    dx = root[:, None, 0] - legs[None, :, 0]
    dy = root[:, None, 1] - legs[None, :, 1]
    r_near = np.minimum(r_hat, model.reach)[:, None]
    near = _near_leg(dx, dy, cos_b[:, None], sin_b[:, None], r_near, legs[None, :, 2], model)
    i, j = np.nonzero(near)
    if len(i):
        out[i, j] = _screened_density(
            dx[i, j],
            dy[i, j],
            cos_b[i],
            sin_b[i],
            r_hat[i],
            phi_hat[i],
            legs[j, 2],
            theta[j],
            model,
        )
    return out


def leg_contact_density_pairs(
    root: FloatArray,
    bearing: FloatArray,
    r_hat: FloatArray,
    phi_hat: FloatArray,
    legs: FloatArray,
    theta: FloatArray,
    model: SweepModel,
) -> FloatArray:
    """``(p,)`` density ρ_leg of contact ``k`` under leg ``k``, for ``p`` (contact, leg) pairs.

    The arguments as for :func:`leg_contact_density`, but one row per pair (``root``
    (p, 2), ``legs`` (p, 3), the rest (p,)): entry ``k`` is what ``leg_contact_density``
    answers for row ``k``'s contact and leg, with the same cuts and the same arithmetic,
    so the same number. Many tables' contacts in one call, where one call per table would
    cost mostly numpy's per-call overhead.
    """
    out = np.zeros(len(root))
    if not len(root):
        return out
    cos_b, sin_b = np.cos(bearing), np.sin(bearing)
    dx = root[:, 0] - legs[:, 0]
    dy = root[:, 1] - legs[:, 1]
    near = _near_leg(dx, dy, cos_b, sin_b, np.minimum(r_hat, model.reach), legs[:, 2], model)
    k = np.flatnonzero(near)
    if len(k):
        out[k] = _screened_density(
            dx[k], dy[k], cos_b[k], sin_b[k], r_hat[k], phi_hat[k], legs[k, 2], theta[k], model
        )
    return out


def _near_leg(
    dx: FloatArray,
    dy: FloatArray,
    cos_b: FloatArray,
    sin_b: FloatArray,
    r_near: FloatArray,
    half: FloatArray,
    model: SweepModel,
) -> BoolArray:
    """The two cheap cuts of ρ_leg on broadcastable arrays: the root's offset ``dx, dy``
    from the leg's centre [m], the whisker's direction, the range clipped to the reach and
    the leg's half side ``half`` [m]. The square lies within √2 h of its centre: a contact
    point or a line farther than that plus the cut from the centre is farther than the cut
    from the square."""
    px, py = dx + r_near * cos_b, dy + r_near * sin_b
    cut = contact_cutoff(0.0, model) + math.sqrt(2.0) * half  # contact_cutoff, per leg
    return np.asarray(
        (px * px + py * py <= cut * cut)
        & (np.abs(dx * sin_b - dy * cos_b) <= ACROSS_CUT * model.sigma_perp + math.sqrt(2.0) * half)
    )


def _screened_density(
    dx: FloatArray,
    dy: FloatArray,
    cos_b: FloatArray,
    sin_b: FloatArray,
    r_hat: FloatArray,
    phi_hat: FloatArray,
    h: FloatArray,
    theta: FloatArray,
    model: SweepModel,
) -> FloatArray:
    """ρ_leg of (contact, leg) pairs that passed :func:`_near_leg`, elementwise: the root's
    offset from the leg's centre, the whisker's direction, range and normal, the leg's half
    side ``h`` and angle ``theta``."""
    across_cut = ACROSS_CUT * model.sigma_perp
    c, s = np.cos(theta), np.sin(theta)
    ox, oy = c * dx + s * dy, c * dy - s * dx
    ux, uy = c * cos_b + s * sin_b, c * sin_b - s * cos_b
    ux = np.where(np.abs(ux) < 1e-12, 1e-12, ux)
    uy = np.where(np.abs(uy) < 1e-12, 1e-12, uy)
    ax, ay = np.abs(ux), np.abs(uy)
    ox_in, oy_in = ox * np.sign(ux), oy * np.sign(uy)  # the root's offset along the line
    tx_near, ty_near = (-h - ox_in) / ax, (-h - oy_in) / ay
    tx_far, ty_far = (h - ox_in) / ax, (h - oy_in) / ay
    t_near = np.maximum(tx_near, ty_near)
    hit = (t_near <= np.minimum(tx_far, ty_far)) & (t_near >= 0.0)
    gap = np.maximum(np.abs(ux * oy - uy * ox) - h * (ax + ay), 0.0)
    along = np.where(hit, t_near, -(ox * ux + oy * uy))
    e_perp = np.where(hit, 0.0, gap)
    kept = (np.where(hit, along, along - math.sqrt(2.0) * h) <= model.reach + _REACH_ROUNDING) & (
        e_perp <= across_cut
    )
    # φ*: of the (one or two) faces turned towards the root, the one nearest φ̂ — a whisker
    # resting on a corner reports either face.
    face_x = np.where(ux > 0, np.pi, 0.0)
    face_y = np.where(uy > 0, -0.5 * np.pi, 0.5 * np.pi)
    rel_phi = phi_hat - theta
    d_phi = np.minimum(np.abs(wrap_angle(rel_phi - face_x)), np.abs(wrap_angle(rel_phi - face_y)))
    sr = model.sigma_r
    exponent = (e_perp / model.sigma_perp) ** 2 + (d_phi / model.sigma_phi) ** 2
    fold = np.exp(-0.5 * ((r_hat - along) / sr) ** 2) + np.exp(-0.5 * ((r_hat + along) / sr) ** 2)
    scale = 1.0 / ((2.0 * math.pi) ** 1.5 * sr * model.sigma_perp * model.sigma_phi)
    return np.asarray(np.where(kept, scale * fold * np.exp(-0.5 * exponent), 0.0))


def wall_contact_density(
    root: FloatArray, bearing: FloatArray, r_hat: FloatArray, phi_hat: FloatArray, model: SweepModel
) -> FloatArray:
    """``(m,)`` density ρ_wall of contacts under the known arena walls (term F2).

    The whisker's line from ``root`` inside the arena leaves it at distance r* through a
    wall of inward normal φ*; ρ = [N(r̂; r*, σ_r) + N(−r̂; r*, σ_r)] · N(0; 0, σ_⊥) ·
    N(wrap(φ̂ − φ*); 0, σ_φ), and 0 when the wall lies beyond the whisker's reach (r* > reach).
    """
    width, height = model.arena
    ux, uy = np.cos(bearing), np.sin(bearing)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(ux > 0, (width - root[:, 0]) / ux, np.where(ux < 0, -root[:, 0] / ux, np.inf))
        ty = np.where(
            uy > 0, (height - root[:, 1]) / uy, np.where(uy < 0, -root[:, 1] / uy, np.inf)
        )
    x_wall = tx < ty
    r_star = np.minimum(tx, ty)
    normal = np.where(
        x_wall, np.where(ux > 0, np.pi, 0.0), np.where(uy > 0, -0.5 * np.pi, 0.5 * np.pi)
    )
    d_phi = wrap_angle(phi_hat - normal)
    return np.asarray(
        np.where(r_star <= model.reach + _REACH_ROUNDING, 1.0, 0.0)
        * _range_density(r_hat, r_star, model.sigma_r)
        * _normal(np.zeros(1), model.sigma_perp)
        * _normal(d_phi, model.sigma_phi)
    )


def legs_swept(
    legs: FloatArray,
    root: FloatArray,
    start: FloatArray,
    stop: FloatArray,
    length: FloatArray,
    margin: float = 0.01,
) -> FloatArray:
    """``(j, m)`` whether sweep ``m``'s free sector wholly contains leg ``j`` (term F3).

    The free sector of a sweep is swept from angle ``start`` to ``stop`` [rad] (turning the
    short way, under π) by a shaft of ``length`` [m] from ``root``. A leg (``legs`` rows
    ``x, y, half side``) counts when its circumscribed circle, grown by ``margin`` [m], lies
    within that angular range and its near edge is within reach: the whisker had to cross
    it. A contact's own leg straddles ``stop`` and never counts.

    The angles are computed only for the (leg, sweep) pairs within reach of each other:
    around a table most stored sweeps are too far from a given leg to have crossed it.
    """
    dx = legs[:, None, 0] - root[None, :, 0]
    dy = legs[:, None, 1] - root[None, :, 1]
    d = np.hypot(dx, dy)
    radius = legs[:, None, 2] * math.sqrt(2.0) + margin
    out = np.zeros(d.shape)
    j, i = np.nonzero((d > radius) & (d - legs[:, None, 2] < length[None] - margin))
    if len(j):
        out[j, i] = _in_free_sector(dx[j, i], dy[j, i], d[j, i], radius[j, 0], start[i], stop[i])
    return out


def legs_swept_pairs(
    legs: FloatArray,
    root: FloatArray,
    start: FloatArray,
    stop: FloatArray,
    length: FloatArray,
    margin: float = 0.01,
) -> FloatArray:
    """``(p,)`` whether sweep ``k``'s free sector wholly contains leg ``k``, for ``p`` (leg,
    sweep) pairs: one row per pair (``legs`` (p, 3), ``root`` (p, 2), the rest (p,)), each
    answered as :func:`legs_swept` answers it, with the same arithmetic."""
    dx = legs[:, 0] - root[:, 0]
    dy = legs[:, 1] - root[:, 1]
    d = np.hypot(dx, dy)
    radius = legs[:, 2] * math.sqrt(2.0) + margin
    out = np.zeros(len(d))
    k = np.flatnonzero((d > radius) & (d - legs[:, 2] < length - margin))
    if len(k):
        out[k] = _in_free_sector(dx[k], dy[k], d[k], radius[k], start[k], stop[k])
    return out


def _in_free_sector(
    dx: FloatArray,
    dy: FloatArray,
    d: FloatArray,
    radius: FloatArray,
    start: FloatArray,
    stop: FloatArray,
) -> BoolArray:
    """Whether a leg at offset ``dx, dy`` (distance ``d``) [m] from a sweep's root, within
    reach, lies with its grown circle of ``radius`` [m] inside the sector swept from
    ``start`` to ``stop`` [rad] (elementwise, for :func:`legs_swept`)."""
    turn = wrap_angle(stop - start)
    direction = np.where(turn >= 0, 1.0, -1.0)
    extent = np.abs(turn)
    rel = wrap_angle(np.arctan2(dy, dx) - start) * direction
    gamma = np.arcsin(np.clip(radius / np.maximum(d, 1e-9), 0.0, 1.0))
    return np.asarray((rel >= gamma) & (rel <= extent - gamma))


def _extents(
    tables: FloatArray, catalogue: tuple[ObjectType, ...]
) -> tuple[FloatArray, FloatArray]:
    """``(n,)`` half extents [m] of each table's outline along x and along y."""
    kinds = tables[:, 3].astype(np.int64)
    sizes = _sizes(catalogue)[kinds]
    half_l, half_w = sizes[:, 3], sizes[:, 4]
    c, s = np.abs(np.cos(tables[:, 2])), np.abs(np.sin(tables[:, 2]))
    return half_l * c + half_w * s, half_l * s + half_w * c


def arena_contains(
    tables: FloatArray, catalogue: tuple[ObjectType, ...], arena: tuple[float, float]
) -> BoolArray:
    """``(n,)`` whether each table's outline lies inside the arena (tables may not cross walls)."""
    tables = np.asarray(tables, dtype=np.float64).reshape(-1, 4)
    ex, ey = _extents(tables, catalogue)
    return np.asarray(
        (tables[:, 0] - ex >= 0)
        & (tables[:, 0] + ex <= arena[0])
        & (tables[:, 1] - ey >= 0)
        & (tables[:, 1] + ey <= arena[1])
    )


def into_arena(
    tables: FloatArray, catalogue: tuple[ObjectType, ...], arena: tuple[float, float]
) -> tuple[FloatArray, FloatArray]:
    """``(n, 4)`` tables moved (without turning) the least distance that puts each outline
    inside the arena, and ``(n,)`` how far each moved [m] (∞ where it cannot fit at its angle).

    A table pressed against a wall is estimated a centimetre or two across it as often as
    not; this is where it can stand.
    """
    tables = np.asarray(tables, dtype=np.float64).reshape(-1, 4)
    ex, ey = _extents(tables, catalogue)
    out = tables.copy()
    out[:, 0] = np.clip(tables[:, 0], ex, np.maximum(ex, arena[0] - ex))
    out[:, 1] = np.clip(tables[:, 1], ey, np.maximum(ey, arena[1] - ey))
    moved = np.hypot(out[:, 0] - tables[:, 0], out[:, 1] - tables[:, 1])
    fits = (2.0 * ex <= arena[0]) & (2.0 * ey <= arena[1])
    return out, np.where(fits, moved, np.inf)


def tables_overlap(p: FloatArray, q: FloatArray, catalogue: tuple[ObjectType, ...]) -> BoolArray:
    """``(n,)`` whether table ``p`` (4,) overlaps each of tables ``q`` (n, 4) (separating axes,
    :func:`~bayesmap.blackboard.densities.rectangles_overlap`, the paper mode's test of
    constraint (c), eq. 16).

    Only tables whose centres lie closer than the two half diagonals can overlap. The chain
    mostly asks about one to three nearby tables, where numpy's per-call cost would be most
    of the work, so a few rows are screened and tested one by one on plain floats, and only
    many rows in numpy passes.
    """
    q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
    out = np.zeros(len(q), dtype=bool)
    own = catalogue[int(p[3])]
    first = (float(p[0]), float(p[1]), float(p[2]), *_half_sides(own))
    reach = [0.5 * math.hypot(t.length, t.width) for t in catalogue]
    if len(q) > SCREEN_ROWS:
        gap = np.hypot(q[:, 0] - p[0], q[:, 1] - p[1])
        rows = np.flatnonzero(gap < np.take(reach, q[:, 3].astype(np.int64)) + reach[int(p[3])])
        if len(rows) > SCREEN_ROWS:
            halves = np.array([_half_sides(t) for t in catalogue])[q[rows, 3].astype(np.int64)]
            out[rows] = rectangles_overlap(np.array(first), np.column_stack([q[rows, :3], halves]))
            return out
    else:
        rows = np.arange(len(q))
    for j, row in zip(rows, q[rows].tolist(), strict=True):
        out[j] = _overlaps_one(first, reach[int(p[3])], row, catalogue, reach)
    return out


def overlap_pairs(p: FloatArray, q: FloatArray, catalogue: tuple[ObjectType, ...]) -> BoolArray:
    """``(n,)`` whether table ``p[i]`` overlaps table ``q[i]`` (both ``(n, 4)``), pair by
    pair on plain floats: for each pair, what ``tables_overlap(p[i], q[i][None])[0]``
    answers, without a numpy call per pair."""
    reach = [0.5 * math.hypot(t.length, t.width) for t in catalogue]
    out = np.zeros(len(p), dtype=bool)
    for i, (own, row) in enumerate(zip(p.tolist(), q.tolist(), strict=True)):
        kind = catalogue[int(own[3])]
        first = (own[0], own[1], own[2], *_half_sides(kind))
        out[i] = _overlaps_one(first, reach[int(own[3])], row, catalogue, reach)
    return out


def _overlaps_one(
    first: tuple[float, float, float, float, float],
    first_reach: float,
    row: list[float],
    catalogue: tuple[ObjectType, ...],
    reach: list[float],
) -> bool:
    """Whether the rectangle ``first`` (``x, y, θ``, half sides; half diagonal
    ``first_reach``) overlaps the table ``row`` ``x, y, θ, k``: centres closer than the
    two half diagonals (``reach`` per type), then the separating-axis test."""
    x, y, theta, k = row
    if math.hypot(x - first[0], y - first[1]) < first_reach + reach[int(k)]:
        return rectangles_overlap_scalar(first, (x, y, theta, *_half_sides(catalogue[int(k)])))
    return False


SCREEN_ROWS = 8
"""Above this many rows, :func:`tables_overlap` works in numpy passes; up to this many it
answers each row as it would answer that row alone."""


def _half_sides(kind: ObjectType) -> tuple[float, float]:
    """Half length and half width [m] of a table type's outline."""
    return 0.5 * kind.length, 0.5 * kind.width


def log_posterior(
    tables: FloatArray,
    catalogue: tuple[ObjectType, ...],
    model: SweepModel,
    sweeps: FloatArray,
    counts: FloatArray,
) -> float:
    """The joint log π(X | D) from scratch (the module docstring's F1–F3); tests' oracle.

    ``sweeps`` are ``(m, 8)`` rows ``root x, root y, start, stop, length, r̂, φ̂, τ̂`` (r̂ NaN:
    touched nothing), ``counts`` how many identical sweeps each row stands for.
    """
    tables = np.asarray(tables, dtype=np.float64).reshape(-1, 4)
    if not arena_contains(tables, catalogue, model.arena).all():
        return -math.inf
    overlaps = sum(
        int(tables_overlap(tables[i], tables[i + 1 :], catalogue).sum()) for i in range(len(tables))
    )
    total = len(tables) * math.log(model.intensity)
    if overlaps:
        total += overlaps * model.log_overlap
    hit = np.isfinite(sweeps[:, 5])
    contacts = sweeps[hit]
    explained = np.maximum(
        model.clutter,
        wall_contact_density(
            contacts[:, :2], contacts[:, 3], contacts[:, 5], contacts[:, 6], model
        ),
    )
    legs = leg_centres(tables, catalogue).reshape(-1, 3)
    theta = np.repeat(tables[:, 2], 4)
    if len(legs):
        squares = contact_squares(tables, catalogue).reshape(-1, 3)
        explained = np.maximum(
            explained,
            leg_contact_density(
                contacts[:, :2],
                contacts[:, 3],
                contacts[:, 5],
                contacts[:, 6],
                squares,
                theta,
                model,
            ).max(axis=1),
        )
        swept = legs_swept(legs, sweeps[:, :2], sweeps[:, 2], sweeps[:, 3], sweeps[:, 4])
        total += float((swept * counts[None]).sum()) * math.log(model.p_miss)
    total += float((counts[hit] * np.log(explained)).sum())
    return total
