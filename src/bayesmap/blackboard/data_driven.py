"""Data-driven birth proposals of the fused mapper: legs from contacts, tables from legs.

The paper's §IV plans "smart proposals": classical detectors re-used as Metropolis–Hastings
proposals, which keep the probabilistic semantics once their density enters the
reversible-jump ratio. Two detectors:

1. **Legs (a Hough transform over leg centres).** Each contact votes for where the centre
   of the leg it touched could be. A whisker rotating about its root first meets a square
   leg at a corner (the rest of the leg lies ahead of the shaft in the sweep), or where its
   tip meets a face; it reports the normal n̂ of the face turned to the root. So the
   centre lies h (−n̂ + t̂) from a corner contact, t̂ the face's direction ahead in the
   sweep, and h n̂ behind a tip contact (h: half a leg's side), not half a leg along the
   whisker (which put the peaks 4–9 cm off the legs). The vote is spread along the whisker
   by the range noise (a short blob when σ_r is a few cm; a 3σ_r-long ridge in the noisy
   condition, where bearings from several poses cross at the leg — the "intersection of
   bearings"). Smoothed local maxima of the vote grid holding at least ``min_votes``
   contacts' worth are leg candidates.
2. **Tables (pairs and triples of legs).** Two candidate legs whose distance matches a
   type's long side, short side or diagonal (within ``spacing_tol``) fix two tables of that
   type; every such table gets a weight ``exp(support_gain × legs)``, legs the number of
   candidate legs within ``spacing_tol`` of its four corners, so a table seen by three or
   four legs is proposed far more often (a triple pins the table).

3. **Fit (local optimisation).** Two leg peaks a few cm off make a table a few cm and
   degrees off, and a table born that far off can fit its contacts worse than walls and
   clutter do. :func:`polish_leg` moves a leg peak to a local maximum of the likelihood of
   the contacts whose bearings pass it, Σ n_i log(floor_i + ρ_leg(i)) — the leg-level fit
   of the intersection of bearings —, and :func:`polish_table` moves a table candidate to
   a local maximum of its own contacts' likelihood, Σ n_i log(floor_i + max_legs
   ρ_leg(i)); both by Nelder–Mead, optionally first with the noise scales widened (a wide
   basin for a start far off) and then at the model's. The fused mapper's final pass fits
   the legs, pairs the fitted legs, places each table on its fitted legs in closed form
   (:func:`place_on_legs`, rigid least squares) and polishes only the leader of each
   place, briefly, at the model's scales. A candidate depends on the stored data only,
   never on the chain's state, so the birth density below is still exactly the density of
   what is drawn.

The birth density is a mixture: with probability ``uniform_share`` a table uniform in the
window (centre), angle and type; otherwise a candidate chosen by weight and jittered by
N(0, σ_xy²) in position and N(0, σ_θ²) in angle (wrapped onto [0, π)). :func:`birth_density`
evaluates exactly the density :func:`draw_birth` samples, for the acceptance ratio.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from scipy import ndimage

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.blackboard.lockstep import minimise_together
from bayesmap.blackboard.sweep_model import (
    ObjectType,
    SweepModel,
    contact_squares,
    into_arena,
    leg_centres,
    leg_contact_density_pairs,
)
from bayesmap.geometry import wrap_angle

__all__ = [
    "BirthProposal",
    "LegVotes",
    "birth_density",
    "draw_birth",
    "draw_near",
    "fit_to_corner_bearings",
    "near_density",
    "place_on_legs",
    "polish_leg",
    "polish_legs",
    "polish_table",
    "polish_tables",
    "table_candidates",
]


class LegVotes:
    """A vote grid over leg centres (the leg detector above).

    Parameters
    ----------
    arena
        ``(width, height)`` [m].
    sigma_r
        Range noise [m] that spreads each vote along its whisker.
    leg_half
        Half a leg's side [m] (h of the module docstring).
    reach
        Whisker length [m]: a vote's contact point lies where the whisker could have touched
        (within ``reach`` of its root), so a noisy contact votes along the reachable segment
        of its bearing, not past the tip; and a range near ``reach`` says the tip touched
        (∞: every contact is taken for a corner).
    cell
        Grid resolution [m].
    """

    def __init__(
        self,
        arena: tuple[float, float],
        sigma_r: float,
        leg_half: float,
        reach: float = math.inf,
        cell: float = 0.025,
    ) -> None:
        self.reach = reach
        self.cell = cell
        self.shape = (int(math.ceil(arena[1] / cell)) + 1, int(math.ceil(arena[0] / cell)) + 1)
        self.votes_ = np.zeros(self.shape)
        self.sigma_r = max(sigma_r, 0.5 * cell)
        self.leg_half = leg_half
        self.smooth = 1.5
        reach = 3.0 * self.sigma_r
        self._offsets = np.arange(-reach, reach + 0.5 * cell, 0.5 * cell)
        weights = np.exp(-0.5 * (self._offsets / self.sigma_r) ** 2)
        self._weights = weights / weights.sum()
        single = np.zeros((41, 41 + 2 * int(reach / cell)))
        columns = np.round(20 + self._offsets / cell).astype(int) + int(reach / cell)
        np.add.at(single, (np.full(len(columns), 20), columns), self._weights)
        self.single_peak = float(ndimage.gaussian_filter(single, self.smooth).max())

    def add(
        self,
        root: FloatArray,
        bearing: FloatArray,
        r_hat: FloatArray,
        counts: FloatArray,
        start: FloatArray,
        normal: FloatArray,
    ) -> None:
        """Add the votes of contacts: ``root`` (m, 2), stop ``bearing``, ``r̂``, ``counts``,
        sweep ``start`` angle and reported ``normal`` φ̂ (all (m,), angles [rad]).

        Where the leg's centre lies relative to the contact point P = root + r̂ (cos ψ, sin ψ)
        follows from the whisking geometry (:mod:`bayesmap.sim.whiskers`): a rotating shaft
        first meets a square leg at its corner nearest in the sweep (the rest of the leg lies
        ahead of the shaft), on the face turned to the root, of outward normal n̂. So the
        centre is P + h (−n̂ + t̂), with t̂ the face's direction that points ahead in the sweep.
        When the tip meets a face instead (r̂ at the whisker's length), the centre is
        P − h n̂, give or take h along the face. The two cases are weighed by how likely r̂ is
        under each: N(r̂; reach, σ_r) for a tip contact, uniform over the reach for a corner.
        """
        ahead = np.sign(wrap_angle(bearing - start))
        ahead = np.where(ahead == 0, 1.0, ahead)
        nx, ny = np.cos(normal), np.sin(normal)
        # the face tangent (−n_y, n_x) or its opposite, whichever points ahead in the sweep
        # (ahead of the shaft is ahead · (−sin ψ, cos ψ))
        side = np.sign(-ny * -np.sin(bearing) + nx * np.cos(bearing)) * ahead
        side = np.where(side == 0, 1.0, side)
        tx, ty = -ny * side, nx * side
        if math.isfinite(self.reach):
            tip = np.exp(-0.5 * ((r_hat - self.reach) / self.sigma_r) ** 2) / (
                math.sqrt(2.0 * math.pi) * self.sigma_r
            )
            share_tip = tip / (tip + 1.0 / self.reach)
        else:
            share_tip = np.zeros(len(r_hat))
        h = self.leg_half
        for shift_x, shift_y, share in (
            (h * (tx - nx), h * (ty - ny), 1.0 - share_tip),
            (-h * nx, -h * ny, share_tip),
        ):
            t = r_hat[:, None] + self._offsets[None]
            x = root[:, :1] + t * np.cos(bearing)[:, None] + shift_x[:, None]
            y = root[:, 1:] + t * np.sin(bearing)[:, None] + shift_y[:, None]
            i = np.round(y / self.cell).astype(np.int64)
            j = np.round(x / self.cell).astype(np.int64)
            ok = (t >= 0) & (t <= self.reach)
            ok &= (i >= 0) & (i < self.shape[0]) & (j >= 0) & (j < self.shape[1])
            w = ((counts * share)[:, None] * self._weights[None]) * ok
            np.add.at(self.votes_, (i[ok], j[ok]), w[ok])

    def peaks(self, box: tuple[float, float, float, float], min_votes: float) -> FloatArray:
        """``(p, 3)`` leg candidates ``x, y, votes`` in ``box`` = ``(x0, y0, x1, y1)`` [m]."""
        j0, i0 = (max(0, int(v / self.cell)) for v in box[:2])
        j1 = min(self.shape[1], int(box[2] / self.cell) + 2)
        i1 = min(self.shape[0], int(box[3] / self.cell) + 2)
        if i1 <= i0 or j1 <= j0:
            return np.zeros((0, 3))
        patch = ndimage.gaussian_filter(self.votes_[i0:i1, j0:j1], self.smooth, mode="constant")
        top = ndimage.maximum_filter(patch, size=5, mode="constant")
        level = min_votes * self.single_peak
        ii, jj = np.nonzero((patch == top) & (patch >= level))
        return np.column_stack(
            [(jj + j0) * self.cell, (ii + i0) * self.cell, patch[ii, jj] / self.single_peak]
        )


def table_candidates(
    legs: FloatArray,
    catalogue: tuple[ObjectType, ...],
    arena: tuple[float, float],
    spacing_tol: float,
    support_gain: float = 2.0,
    unpaired: frozenset[int] = frozenset(),
) -> tuple[FloatArray, FloatArray]:
    """Tables ``(c, 4)`` ``x, y, θ, k`` implied by pairs of candidate legs, and their weights.

    See the module docstring. A table that crosses a wall (zero prior) is moved inside when
    that takes at most ``spacing_tol`` (legs found a centimetre or two off put a table
    pressed against a wall across it), else dropped. Types ``unpaired`` (indices into the
    catalogue) get no candidates here: solid boxes with candidates of their own, which
    pairs of the quarters' peaks would offer half a side off.
    """
    if len(legs) < 2:
        return np.zeros((0, 4)), np.zeros(0)
    p = legs[:, :2]
    i, j = np.triu_indices(len(p), 1)
    delta = p[j] - p[i]
    dist = np.hypot(delta[:, 0], delta[:, 1])
    angle = np.arctan2(delta[:, 1], delta[:, 0])
    mid = 0.5 * (p[i] + p[j])
    normal = np.column_stack([-np.sin(angle), np.cos(angle)])
    found = []
    for k, kind in enumerate(catalogue):
        if k in unpaired:
            continue
        a, b = kind.half_spacing
        diag = math.hypot(a, b)
        for spacing, offset, turn in ((2 * a, b, 0.0), (2 * b, a, 0.5 * math.pi)):
            ok = np.abs(dist - spacing) < spacing_tol
            for sign in (1.0, -1.0):
                centre = mid[ok] + sign * offset * normal[ok]
                theta = angle[ok] + turn
                found.append(np.column_stack([centre, theta, np.full(ok.sum(), k)]))
        ok = np.abs(dist - 2 * diag) < spacing_tol
        for sign in (1.0, -1.0):
            theta = angle[ok] + sign * math.atan2(b, a)
            found.append(np.column_stack([mid[ok], theta, np.full(ok.sum(), k)]))
    tables = np.concatenate(found) if found else np.zeros((0, 4))
    tables[:, 2] = np.mod(tables[:, 2], math.pi)
    tables, moved = into_arena(tables, catalogue, arena)
    tables = tables[moved <= spacing_tol]
    if not len(tables):
        return np.zeros((0, 4)), np.zeros(0)
    support = _supported_corners(leg_centres(tables, catalogue)[..., :2], p, spacing_tol)
    return tables, np.exp(support_gain * (support.sum(axis=1) - 2.0))


_SUPPORT_BLOCK = 64
"""Tables whose corners :func:`_supported_corners` tests against one set of nearby legs."""


def _supported_corners(corners: FloatArray, legs: FloatArray, tol: float) -> BoolArray:
    """``(c, 4)`` whether each corner of ``corners`` (c, 4, 2) has a leg of ``legs``
    (p, 2) closer than ``tol`` [m]: the square root of the least squared distance, < tol.

    Tables in blocks of :data:`_SUPPORT_BLOCK`, ordered by the 1 m cell of their first
    corner, each block against the legs inside its corners' bounding box grown by 2 tol:
    a leg outside it is farther than ``tol`` from every corner of the block, so the answer
    is the one every leg gives, and a block reads a few dozen of the noisy condition's
    150–200 leg peaks rather than all of them.
    """
    out = np.zeros(corners.shape[:2], dtype=bool)
    cells = np.floor(corners[:, 0, :]).astype(np.int64)
    order = np.lexsort((cells[:, 1], cells[:, 0]))
    for start in range(0, len(order), _SUPPORT_BLOCK):
        block = order[start : start + _SUPPORT_BLOCK]
        points = corners[block]
        low = points.reshape(-1, 2).min(axis=0) - 2.0 * tol
        high = points.reshape(-1, 2).max(axis=0) + 2.0 * tol
        near = legs[((legs >= low) & (legs <= high)).all(axis=1)]
        if not len(near):
            continue
        dx = points[:, :, None, 0] - near[:, 0]
        dy = points[:, :, None, 1] - near[:, 1]
        out[block] = np.sqrt((dx * dx + dy * dy).min(axis=2)) < tol
    return out


def place_on_legs(
    tables: FloatArray,
    legs: FloatArray,
    catalogue: tuple[ObjectType, ...],
    tol: float,
) -> FloatArray:
    """Tables ``(c, 4)`` each moved to the rigid least-squares fit of its supported corners
    onto the legs that support them (2-D Kabsch/Procrustes, in closed form).

    A corner is supported by the nearest of ``legs`` (p, ≥ 2) ``x, y`` if it lies within
    ``tol`` [m]; which corner goes to which leg is the candidate's own (it was built from
    them, so the rectangle's symmetries and the choice of supported corners are already
    fixed). With the corners' offsets m_j in the table's frame and the legs' positions
    q_j, both centred on their means m̄, q̄, the rotation that minimises Σ_j |R m_j + t −
    q_j|² has angle atan2(Σ m_j × q_j, Σ m_j · q_j) (cross and dot products of the centred
    pairs) and t = q̄ − R m̄ (Umeyama 1991, eqs. 40–42, without scaling; Kabsch 1976). A
    candidate with fewer than two supported corners is returned as it is. With fitted legs
    (:func:`polish_leg`, a centimetre or two from their true place) this is where a polish
    of the table against its contacts (:func:`polish_table`) lands to within about that.
    The result is moved inside the arena by the caller, as every candidate is.
    """
    tables = np.asarray(tables, dtype=np.float64).reshape(-1, 4).copy()
    if not len(tables) or len(legs) < 2:
        return tables
    corners = leg_centres(tables, catalogue)[..., :2]  # (c, 4, 2)
    gaps = np.linalg.norm(corners[:, :, None, :] - legs[None, None, :, :2], axis=-1)
    nearest = gaps.argmin(axis=2)
    used = gaps.min(axis=2) < tol  # (c, 4)
    target = legs[nearest, :2]  # (c, 4, 2)
    at_origin = np.column_stack([np.zeros((len(tables), 3)), tables[:, 3]])
    local = leg_centres(at_origin, catalogue)[..., :2]  # the corners in the table's frame
    w = used.astype(np.float64)
    n = w.sum(axis=1)
    ok = n >= 2
    n_safe = np.maximum(n, 1.0)[:, None]
    m_bar = (w[..., None] * local).sum(axis=1) / n_safe
    q_bar = (w[..., None] * target).sum(axis=1) / n_safe
    m = local - m_bar[:, None]
    q = target - q_bar[:, None]
    dot = (w * (m[..., 0] * q[..., 0] + m[..., 1] * q[..., 1])).sum(axis=1)
    cross = (w * (m[..., 0] * q[..., 1] - m[..., 1] * q[..., 0])).sum(axis=1)
    theta = np.arctan2(cross, dot)
    c, s = np.cos(theta), np.sin(theta)
    centre = q_bar - np.column_stack(
        [c * m_bar[:, 0] - s * m_bar[:, 1], s * m_bar[:, 0] + c * m_bar[:, 1]]
    )
    tables[ok, :2] = centre[ok]
    tables[ok, 2] = np.mod(theta[ok], math.pi)
    return tables


class BirthProposal(NamedTuple):
    """The birth mixture for one window (see the module docstring)."""

    box: tuple[float, float, float, float]
    candidates: FloatArray
    weights: FloatArray
    n_types: int
    uniform_share: float
    sigma_xy: float
    sigma_theta: float

    @property
    def area(self) -> float:
        return (self.box[2] - self.box[0]) * (self.box[3] - self.box[1])


def draw_birth(rng: np.random.Generator, proposal: BirthProposal) -> FloatArray:
    """One table ``(4,)`` ``x, y, θ, k`` from the birth mixture."""
    if not len(proposal.candidates) or rng.uniform() < proposal.uniform_share:
        x0, y0, x1, y1 = proposal.box
        return np.array(
            [
                rng.uniform(x0, x1),
                rng.uniform(y0, y1),
                rng.uniform(0.0, math.pi),
                float(rng.integers(proposal.n_types)),
            ]
        )
    cum = np.cumsum(proposal.weights)
    k = int(np.searchsorted(cum, rng.uniform() * cum[-1], side="right"))
    k = min(k, len(cum) - 1)
    base = proposal.candidates[k]
    return np.array(
        [
            base[0] + proposal.sigma_xy * rng.standard_normal(),
            base[1] + proposal.sigma_xy * rng.standard_normal(),
            (base[2] + proposal.sigma_theta * rng.standard_normal()) % math.pi,
            base[3],
        ]
    )


def birth_density(table: FloatArray, proposal: BirthProposal) -> float:
    """The density [m⁻² rad⁻¹, per type] with which :func:`draw_birth` proposes ``table``.

    Zero outside the window's box. The angle's jitter is wrapped onto [0, π), so its
    density sums the normal over the neighbouring wraps.
    """
    x0, y0, x1, y1 = proposal.box
    if not (x0 <= table[0] <= x1 and y0 <= table[1] <= y1):
        return 0.0
    uniform = 1.0 / (proposal.area * math.pi * proposal.n_types)
    if not len(proposal.candidates):
        return uniform
    c = proposal.candidates
    same = c[:, 3] == table[3]
    if not same.any():
        return proposal.uniform_share * uniform
    c, w = c[same], proposal.weights[same]
    dens = _jitter_density(table, c, proposal.sigma_xy, proposal.sigma_theta)
    mixture = float((w * dens).sum() / proposal.weights.sum())
    return proposal.uniform_share * uniform + (1.0 - proposal.uniform_share) * mixture


def _near(proposal: BirthProposal, centre: FloatArray, radius: float) -> FloatArray:
    c = proposal.candidates
    if not len(c):
        return np.zeros(0, dtype=bool)
    return np.asarray((c[:, 0] - centre[0]) ** 2 + (c[:, 1] - centre[1]) ** 2 <= radius**2)


def draw_near(
    rng: np.random.Generator, proposal: BirthProposal, centre: FloatArray, radius: float
) -> FloatArray | None:
    """One table from q_L(· | centre): a birth candidate whose centre lies within ``radius``
    [m] of ``centre``, chosen by weight and jittered as in :func:`draw_birth`; ``None`` when
    no candidate lies there (the split and merge moves' proposal)."""
    near = np.flatnonzero(_near(proposal, centre, radius))
    if not len(near):
        return None
    cum = np.cumsum(proposal.weights[near])
    pick = near[
        min(int(np.searchsorted(cum, rng.uniform() * cum[-1], side="right")), len(near) - 1)
    ]
    base = proposal.candidates[pick]
    return np.array(
        [
            base[0] + proposal.sigma_xy * rng.standard_normal(),
            base[1] + proposal.sigma_xy * rng.standard_normal(),
            (base[2] + proposal.sigma_theta * rng.standard_normal()) % math.pi,
            base[3],
        ]
    )


def _jitter_density(table: FloatArray, c: FloatArray, sx: float, st: float) -> FloatArray:
    """Density of the jittered draw about each candidate ``c`` (n, 4) at ``table``."""
    d2 = (c[:, 0] - table[0]) ** 2 + (c[:, 1] - table[1]) ** 2
    dt = np.mod(table[2] - c[:, 2], math.pi)
    angular = sum(np.exp(-0.5 * ((dt + shift) / st) ** 2) for shift in (-math.pi, 0.0, math.pi))
    return np.asarray(
        np.exp(-0.5 * d2 / sx**2) / (2 * math.pi * sx**2) * angular / (math.sqrt(2 * math.pi) * st)
    )


def near_density(
    table: FloatArray, proposal: BirthProposal, centre: FloatArray, radius: float
) -> float:
    """The density with which :func:`draw_near` proposes ``table`` (0 if it cannot)."""
    near = _near(proposal, centre, radius)
    if not near.any():
        return 0.0
    w = proposal.weights[near]
    c = proposal.candidates[near]
    same = c[:, 3] == table[3]
    if not same.any():
        return 0.0
    dens = _jitter_density(table, c[same], proposal.sigma_xy, proposal.sigma_theta)
    return float((w[same] * dens).sum() / w.sum())


def polish_table(
    table: FloatArray,
    contacts: FloatArray,
    counts: FloatArray,
    floor: FloatArray,
    catalogue: tuple[ObjectType, ...],
    model: SweepModel,
    *,
    widen: tuple[float, ...] = (4.0, 1.0),
    max_evals: int = 24,
    line_gap: float = 0.5,
) -> FloatArray:
    """Move a candidate table ``(4,)`` to a local maximum of its contacts' likelihood.

    ``contacts`` ``(m, 4)`` rows ``root x, root y, bearing, r̂`` with their normals
    appended as a fifth column (``(m, 5)``), ``counts`` their multiplicities and ``floor``
    the density that explains each without the table (max of clutter and walls). The
    objective is Σ n_i log(floor_i + max over the table's legs of ρ_leg(i)) (the contact
    term F2 of :mod:`~bayesmap.blackboard.sweep_model`, summed instead of maximised so it
    is smooth), maximised by Nelder–Mead once per factor of ``widen`` (the noise scales
    σ_r, σ_⊥, σ_φ multiplied by it), over tables inside the arena (a position across a wall
    counts as the nearest one inside: a table against a wall). Returns the polished ``(4,)``
    table (θ in [0, π)), or the start (moved inside) if that fits its contacts better at
    the model's noise scales.

    Only contacts whose whisker line passes within ``line_gap`` [m] of one of the start's
    legs (within the whisker's reach) enter the objective: a whisker line farther from every
    leg gets ρ ≈ 0 (its density falls with the gap across the line at σ_⊥, 1 cm, even
    widened four times) wherever a polish of a decimetre or two can take the table, so its
    term is a constant: the noisy condition's contacts, which lie anywhere within a whisker's
    reach of the centre, are mostly of that kind. Many tables at once:
    :func:`polish_tables`.
    """
    polished = polish_tables(
        np.asarray(table, dtype=np.float64)[None],
        [contacts],
        [counts],
        [floor],
        catalogue,
        model,
        widen=widen,
        max_evals=max_evals,
        line_gap=line_gap,
    )
    return np.asarray(polished[0])


def polish_tables(
    tables: FloatArray,
    contacts: list[FloatArray],
    counts: list[FloatArray],
    floor: list[FloatArray],
    catalogue: tuple[ObjectType, ...],
    model: SweepModel,
    *,
    widen: tuple[float, ...] = (4.0, 1.0),
    max_evals: int = 24,
    line_gap: float = 0.5,
) -> FloatArray:
    """:func:`polish_table` of each of ``tables`` (k, 4) against its own ``contacts``,
    ``counts`` and ``floor`` (lists of k arrays), all in lockstep
    (:func:`~bayesmap.blackboard.lockstep.minimise_together`): one density call per
    Nelder–Mead step for all tables, each table's result the one it gets alone."""
    starts = into_arena(
        np.asarray(tables, dtype=np.float64).reshape(-1, 4), catalogue, model.arena
    )[0]
    out = starts.copy()
    run = np.array([t for t in range(len(starts)) if len(contacts[t])], dtype=np.int64)
    if not len(run):
        return out
    kinds = starts[run, 3]
    legs = leg_centres(starts[run], catalogue)[:, :, :2]
    near = [
        _lines_near(contacts[t], legs[i], line_gap, model.reach) for i, t in enumerate(run.tolist())
    ]
    batch = _ContactSets(
        [contacts[t][n] for t, n in zip(run.tolist(), near, strict=True)],
        [counts[t][n] for t, n in zip(run.tolist(), near, strict=True)],
        [floor[t][n] for t, n in zip(run.tolist(), near, strict=True)],
    )

    def placed(v: FloatArray, problems: IntArray) -> FloatArray:
        """The tables at ``v`` (a, 3) = (x, y, θ), moved inside the arena."""
        inside: FloatArray = into_arena(
            np.column_stack([v, kinds[problems]]), catalogue, model.arena
        )[0]
        return inside

    def negative(v: FloatArray, problems: IntArray, scaled: SweepModel) -> FloatArray:
        table = placed(v, problems)
        theta = np.repeat(table[:, 2:3], 4, axis=1)
        return batch.negative(problems, contact_squares(table, catalogue), theta, scaled)

    every = np.arange(len(run))
    climbed = _climb(
        negative, starts[run, :3], model, widen, max_evals, lambda v: placed(v, every)[:, :3]
    )
    found = placed(climbed, every)
    found[:, 2] %= math.pi
    # the wide basin can lead off a table's best place (a table against a wall, whose wall
    # contacts the widened legs also claim): never return worse than the start
    out[run] = _better_of(negative, found, starts[run], model)
    return out


def polish_leg(
    leg: FloatArray,
    contacts: FloatArray,
    counts: FloatArray,
    floor: FloatArray,
    half_side: float,
    model: SweepModel,
    *,
    widen: tuple[float, ...] = (4.0, 1.0),
    max_evals: int = 24,
    line_gap: float = 0.15,
) -> FloatArray:
    """Move a candidate leg ``(3,)`` ``x, y, θ`` to a local maximum of its contacts'
    likelihood, Σ n_i log(floor_i + ρ_leg(i)), as :func:`polish_table` moves a table.

    The leg-level fit of the noisy condition: with σ_r = 0.5 m along the whisker and exact
    bearings, a leg's contacts pin it across their bearings (σ_⊥) from every side it was
    touched, so a peak of the vote grid a few centimetres off moves onto the leg, once per
    leg rather than once per table that could stand on it. ``contacts`` as in
    :func:`polish_table` (only whisker lines passing within ``line_gap`` [m] of the start
    enter), ``half_side`` the leg's half side [m]. Returns the fitted ``x, y`` [m] and θ
    [rad] in [0, π/2) (a square leg's symmetry), or the start if that fits better at the
    model's noise scales. Many legs at once: :func:`polish_legs`.
    """
    polished = polish_legs(
        np.asarray(leg, dtype=np.float64)[None],
        [contacts],
        [counts],
        [floor],
        half_side,
        model,
        widen=widen,
        max_evals=max_evals,
        line_gap=line_gap,
    )
    return np.asarray(polished[0])


def polish_legs(
    legs: FloatArray,
    contacts: list[FloatArray],
    counts: list[FloatArray],
    floor: list[FloatArray],
    half_side: float,
    model: SweepModel,
    *,
    widen: tuple[float, ...] = (4.0, 1.0),
    max_evals: int = 24,
    line_gap: float = 0.15,
) -> FloatArray:
    """:func:`polish_leg` of each of ``legs`` (k, 3) against its own ``contacts``,
    ``counts`` and ``floor`` (lists of k arrays), all in lockstep, as
    :func:`polish_tables` polishes tables."""
    starts = np.asarray(legs, dtype=np.float64).reshape(-1, 3)
    out = starts.copy()
    near = [
        _lines_near(c, start[None, :2], line_gap, model.reach)
        for c, start in zip(contacts, starts, strict=True)
    ]
    run = np.array([t for t, n in enumerate(near) if n.any()], dtype=np.int64)
    if not len(run):
        return out
    batch = _ContactSets(
        [contacts[t][near[t]] for t in run.tolist()],
        [counts[t][near[t]] for t in run.tolist()],
        [floor[t][near[t]] for t in run.tolist()],
    )

    def negative(v: FloatArray, problems: IntArray, scaled: SweepModel) -> FloatArray:
        legs = np.column_stack([v[:, :2], np.full(len(v), half_side)])[:, None, :]
        return batch.negative(problems, legs, v[:, 2:3], scaled)

    found = _climb(negative, starts[run], model, widen, max_evals)
    found[:, 2] %= 0.5 * math.pi
    out[run] = _better_of(negative, found, starts[run], model)
    return out


def fit_to_corner_bearings(
    solid: FloatArray,
    contacts: FloatArray,
    counts: FloatArray,
    half_side: float,
    sigma_r: float,
    *,
    gap: float = 0.03,
    rounds: int = 4,
    iterations: int = 3,
) -> FloatArray:
    """A solid square ``(4,)`` ``x, y, θ, k`` (a box or pillar of half side ``half_side``)
    moved so that its corners lie on the bearings of the contacts that stopped at them.

    A rotating whisker first meets a box at the corner nearest in its sweep and stops on
    that corner's bearing, as exactly as the sensor reads angles, while its range r̂ says
    where along the bearing only to σ_r. So the likelihood of a box's corner contacts peaks
    where every touched corner lies on its contacts' bearing lines: a needle (in the normal
    condition a box 0.6 mm off that place scores 300 nats below it) that a Nelder–Mead
    polish from a few millimetres off does not find. ``contacts`` (m, 5) are ``root x,
    root y, bearing, r̂, whisker length`` with ``counts`` (m,): a contact is assigned to
    the corner closest to its bearing line, if that is within ``gap`` [m] across it and
    3 σ_r along it, and not touched by the whisker's tip (r̂ within 2 σ_r of its length:
    the tip meets a face, not a corner). Gauss–Newton on ``x, y, θ`` minimises the
    count-weighted squared distances of the assigned corners from their lines, the
    assignment made again at each of ``iterations`` steps of each of ``rounds`` rounds,
    ``gap`` shrinking threefold a round: a contact that did not stop at a corner (a tip
    short of its length, another object's) lies millimetres to centimetres off every
    corner's line and drops out as the corners settle on theirs. Returned as it is from
    the step where fewer than three contacts on bearings apart by 0.1 rad are assigned.
    """
    pose = np.asarray(solid, dtype=np.float64).copy()
    c, sn = np.cos(contacts[:, 2]), np.sin(contacts[:, 2])
    usable = contacts[:, 3] < contacts[:, 4] - 2.0 * sigma_r
    signs = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    for within in np.repeat(gap / 3.0 ** np.arange(rounds), iterations):
        ct, st = math.cos(pose[2]), math.sin(pose[2])
        offsets = half_side * np.column_stack(
            [ct * signs[:, 0] - st * signs[:, 1], st * signs[:, 0] + ct * signs[:, 1]]
        )
        dx = pose[0] + offsets[None, :, 0] - contacts[:, :1]
        dy = pose[1] + offsets[None, :, 1] - contacts[:, 1:2]
        across = c[:, None] * dy - sn[:, None] * dx
        along = c[:, None] * dx + sn[:, None] * dy
        near = (np.abs(across) <= within) & (np.abs(along - contacts[:, 3:4]) <= 3.0 * sigma_r)
        corner = np.where(near, np.abs(across), np.inf).argmin(axis=1)
        used = usable & near[np.arange(len(contacts)), corner]
        if used.sum() < 3 or np.ptp(np.mod(contacts[used, 2], math.pi)) < 0.1:
            break
        o = offsets[corner[used]]
        jac = np.column_stack([-sn[used], c[used], c[used] * o[:, 0] + sn[used] * o[:, 1]])
        residual = across[used, corner[used]]
        w = counts[used]
        normal = jac.T @ (w[:, None] * jac)
        if np.linalg.cond(normal) > 1e12:
            break
        step = np.linalg.solve(normal, -jac.T @ (w * residual))
        pose[:3] += step
    pose[2] %= 0.5 * math.pi
    return pose


def _better_of(
    negative: Callable[[FloatArray, IntArray, SweepModel], FloatArray],
    found: FloatArray,
    starts: FloatArray,
    model: SweepModel,
) -> FloatArray:
    """Each polish's result ``found`` (k, ≥ 3) or, where that fits its contacts worse at the
    model's noise scales (``negative`` on ``x, y, θ``), its start ``starts``; both of every
    problem in one call."""
    every = np.arange(len(found))
    both = negative(np.vstack([found[:, :3], starts[:, :3]]), np.concatenate([every, every]), model)
    better = both[: len(found)] <= both[len(found) :]
    return np.where(better[:, None], found, starts)


class _ContactSets:
    """The contacts of several polish problems, concatenated once, and their objective."""

    def __init__(
        self, contacts: list[FloatArray], counts: list[FloatArray], floor: list[FloatArray]
    ) -> None:
        self.sizes = np.array([len(c) for c in contacts], dtype=np.int64)
        self.starts = np.concatenate([[0], np.cumsum(self.sizes)[:-1]])
        self.contacts = np.concatenate(contacts).reshape(-1, 5)
        self.counts = np.concatenate(counts)
        self.floor = np.concatenate(floor)

    def negative(
        self, problems: IntArray, legs: FloatArray, theta: FloatArray, model: SweepModel
    ) -> FloatArray:
        """``(a,)`` −Σ n_i log(floor_i + max over the legs of ρ_leg(i)) of each of
        ``problems`` (a,) over its own contacts, its legs ``legs`` (a, L, 3) at angles
        ``theta`` (a, L) [rad]: each problem's terms summed on their own, as one problem's
        polish sums them."""
        sizes = self.sizes[problems]
        ends = np.cumsum(sizes)
        owner = np.repeat(np.arange(len(problems)), sizes)
        # each problem's rows, in order: its first row plus the position within its block
        rows = self.starts[problems][owner] + np.arange(len(owner)) - (ends - sizes)[owner]
        per_leg = legs.shape[1]
        pair = np.repeat(self.contacts[rows], per_leg, axis=0)
        rho = (
            leg_contact_density_pairs(
                pair[:, :2],
                pair[:, 2],
                pair[:, 3],
                pair[:, 4],
                legs[owner].reshape(-1, 3),
                theta[owner].reshape(-1),
                model,
            )
            .reshape(-1, per_leg)
            .max(axis=1)
        )
        terms = self.counts[rows] * np.log(self.floor[rows] + rho)
        return np.array(
            [-float(terms[end - size : end].sum()) for end, size in zip(ends, sizes, strict=True)]
        )


def _climb(
    negative: Callable[[FloatArray, IntArray, SweepModel], FloatArray],
    starts: FloatArray,
    model: SweepModel,
    widen: tuple[float, ...],
    max_evals: int,
    project: Callable[[FloatArray], FloatArray] = lambda v: v,
) -> FloatArray:
    """Nelder–Mead on ``negative`` over ``x, y, θ`` from each of ``starts`` (k, 3), all in
    lockstep, once per factor of ``widen`` (the noise scales σ_r, σ_⊥, σ_φ and the
    simplex's size multiplied by it), each round's results mapped by ``project`` (e.g. into
    the arena) before the next."""
    out = np.asarray(starts, dtype=np.float64).copy()
    for factor in widen:
        scaled = model._replace(
            sigma_r=model.sigma_r * factor,
            sigma_perp=model.sigma_perp * factor,
            sigma_phi=model.sigma_phi * factor,
        )
        scale = np.array([0.02, 0.02, 0.03]) * factor
        simplices = out[:, None, :] + np.vstack([np.zeros(3), np.diag(scale)])[None]

        def at_scale(v: FloatArray, problems: IntArray, m: SweepModel = scaled) -> FloatArray:
            return negative(v, problems, m)

        found = minimise_together(
            at_scale,
            simplices,
            max_evals=max_evals,
            xatol=1e-3,
            fatol=1e-2,
        )
        out = np.asarray(project(found), dtype=np.float64)
    return out


def _lines_near(contacts: FloatArray, legs: FloatArray, gap: float, reach: float) -> BoolArray:
    """``(m,)`` whether each contact's whisker line (``root x, root y, bearing`` in the first
    three columns of ``contacts``) passes within ``gap`` [m] of one of ``legs`` (j, 2) at a
    distance along it between ``−gap`` and ``reach + gap``."""
    dx = legs[None, :, 0] - contacts[:, None, 0]
    dy = legs[None, :, 1] - contacts[:, None, 1]
    cos_b, sin_b = np.cos(contacts[:, 2:3]), np.sin(contacts[:, 2:3])
    along = dx * cos_b + dy * sin_b
    across = np.abs(dy * cos_b - dx * sin_b)
    return np.asarray(((across <= gap) & (along >= -gap) & (along <= reach + gap)).any(axis=1))
