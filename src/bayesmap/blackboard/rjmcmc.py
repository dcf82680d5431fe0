"""Reversible-jump MCMC over sets of tables (the paper's §II-C "future work", Green 1995).

The target is the fused posterior of :mod:`~bayesmap.blackboard.sweep_model`, tempered as
π^β. Every move works inside a *window* (an axis-aligned box): it picks among the tables
whose centre lies in the box and rejects any result whose centre leaves it, so the kernel
is a valid Metropolis–Hastings kernel for π^β whatever the window (a window only limits
where the chain looks). Moves, each with its proposal ratio in the acceptance:

- **birth**: a table from the data-driven mixture q_W
  (:mod:`~bayesmap.blackboard.data_driven`); ratio (p_death / (n_W + 1)) / (p_birth q_W(t));
- **death**: a table of the window chosen uniformly; the inverse ratio;
- **refine**: Gaussian random walk on (x, y, θ) at one of two scales (symmetric);
- **mirror** (the Fig. 3 ambiguity): reflect a table across the line through the two legs of
  one of its four sides, chosen uniformly; its reverse reflects across the same two legs,
  now the opposite side (symmetric, unit Jacobian);
- **corner**: keep one leg (chosen uniformly) in place and move the table to one of the 7
  other placements that put one of its corners on that leg with an axis along the leg's
  faces (symmetric: the 8 placements are the same set seen from any of them);
- **type**: keep one leg in place and change the table's type (symmetric).
- **switch**: replace a table of the window by a fresh draw t' from q_W; ratio
  q_W(t) / q_W(t') (an independence proposal, dimension kept). It lets the chain trade a
  wrong table that explains many contacts for the right one in one step.
- **split / merge** (one table ↔ two): split picks a window table t (1 of n) and draws two
  tables t₁, t₂ independently from q_L(· | t), the birth candidates whose centre lies within
  R of t's centre (jittered as in a birth); merge picks one of the M window pairs whose
  centres are within 2R and draws t from q_L(· | midpoint). Ratio of a split
  (p_merge q_L(t | mid) / M') / (p_split 2 q_L(t₁ | t) q_L(t₂ | t) / n), M' counted after
  the split (the factor 2: two orders give the same pair); a merge the inverse. An
  identity map of (t, t₁, t₂), Jacobian 1. It reaches the maps where one table lay across
  two (or two stood where one is) that single-table moves can only reach through far
  worse maps, and where a birth is blocked because the wrong table overlaps it.

Acceptance: ``log α = β Δlog π + log q-ratio`` (Metropolis–Hastings; all moves are rigid
maps of (x, y, θ), Jacobian 1). ``Δlog π`` is computed locally (the changed table's contacts,
free-space sweeps and neighbours); tests check it against
:func:`~bayesmap.blackboard.sweep_model.log_posterior` from scratch.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.blackboard.data_driven import (
    BirthProposal,
    birth_density,
    draw_birth,
    draw_near,
    near_density,
)
from bayesmap.blackboard.evidence import EvidenceStore
from bayesmap.blackboard.sweep_model import (
    SCREEN_ROWS,
    ObjectType,
    SweepModel,
    arena_contains,
    contact_cutoff,
    contact_squares,
    leg_centres,
    leg_contact_density,
    leg_contact_density_pairs,
    legs_swept,
    legs_swept_pairs,
    log_posterior,
    overlap_pairs,
    tables_overlap,
    wall_contact_density,
)

__all__ = [
    "CandidateScreen",
    "ChainState",
    "Move",
    "MoveKind",
    "MoveRates",
    "evaluate",
    "greedy_ascent",
    "holding",
    "moved_tables",
    "propose",
    "run",
    "visit_frequencies",
]


class MoveKind(Enum):
    BIRTH = "birth"
    DEATH = "death"
    REFINE = "refine"
    MIRROR = "mirror"
    CORNER = "corner"
    TYPE = "type"
    SWITCH = "switch"
    SPLIT = "split"
    MERGE = "merge"


@dataclass(frozen=True)
class MoveRates:
    """Probabilities of each move kind (normalised), and the random-walk scales."""

    birth: float = 0.15
    death: float = 0.15
    refine: float = 0.4
    mirror: float = 0.1
    corner: float = 0.12
    type: float = 0.08
    switch: float = 0.1
    split: float = 0.05
    merge: float = 0.05
    step_xy: tuple[float, float] = (0.01, 0.06)
    step_theta: tuple[float, float] = (0.01, 0.06)


@dataclass
class ChainState:
    """The chain's current map and its cached free-space terms.

    Attributes
    ----------
    tables
        ``(n, 4)`` tables ``x, y, θ, k``.
    free_space
        ``(n,)`` each table's term F3 (its legs' missed sweeps × log p_miss).
    log_pi
        log π of the state (tracked through accepted moves; exact after
        :meth:`Context.refresh`).
    """

    tables: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))
    free_space: FloatArray = field(default_factory=lambda: np.zeros(0))
    log_pi: float = 0.0


_TERMS_KEPT = 200_000
"""Per-table terms :class:`Context` keeps before it starts afresh (bounds its memory)."""


class Context:
    """What every move needs: catalogue, model, evidence, the walls' density per contact."""

    def __init__(self, catalogue: tuple[ObjectType, ...], model: SweepModel, store: EvidenceStore):
        self.catalogue = catalogue
        self.model = model
        self.store = store
        self.half_diagonal = max(0.5 * math.hypot(t.length, t.width) for t in catalogue)
        half_leg = max(t.contact_half_side for t in catalogue)
        self.contact_radius = self.half_diagonal + contact_cutoff(half_leg, model)
        """Contact points farther than this [m] from a table's centre get no ρ from it."""
        self.reach = 1.0
        self.log_p_miss = math.log(model.p_miss)
        self.log_intensity = math.log(model.intensity)
        self.floor = np.zeros(0)
        """Per stored sweep, max(κ, ρ_wall): what explains a contact without tables."""
        self._terms_version = -1
        self._contact_terms: dict[bytes, tuple[IntArray, FloatArray]] = {}
        self._free_terms: dict[bytes, float] = {}

    def _fresh_terms(self) -> None:
        """Forget the per-table terms when the store changed since they were computed (or
        when too many are kept)."""
        size = len(self._contact_terms) + len(self._free_terms)
        if self._terms_version != self.store.version_ or size > _TERMS_KEPT:
            self._contact_terms.clear()
            self._free_terms.clear()
            self._terms_version = self.store.version_

    def table_contacts(self, table: FloatArray) -> tuple[IntArray, FloatArray]:
        """One table's contacts: the sorted ids of the stored contacts within
        :attr:`contact_radius` of its centre that one of its legs explains (ρ_leg > 0), and
        for each the max over its legs of ρ_leg (every other contact gets ρ_leg = 0, which
        changes no contact's best cause).

        Kept per table (its exact ``x, y, θ, k``) while the store is unchanged: a chain and
        a greedy ascent visit the same tables again and again (every neighbour of a moved
        table, every candidate a refill tries).
        """
        self._fresh_terms()
        key = table.tobytes()
        found = self._contact_terms.get(key)
        if found is None:
            ids = np.sort(self.store.contacts_near(table[0], table[1], self.contact_radius))
            density = self._own_density(table, ids)
            explains = density > 0
            found = (ids[explains], density[explains])
            self._contact_terms[key] = found
        return found

    def prime(self, tables: FloatArray) -> None:
        """Compute the kept terms of many tables at once: for each of ``tables`` (n, 4) not
        yet kept, its contacts (:meth:`table_contacts`) and its free space
        (:meth:`table_free_space`).

        One call of :func:`~bayesmap.blackboard.sweep_model.leg_contact_density_pairs` and
        one of :func:`~bayesmap.blackboard.sweep_model.legs_swept_pairs` per block of
        tables, on the (contact, leg) and (leg, sweep) pairs the one-table calls would
        form, where those calls, one per table, cost mostly numpy's per-call overhead (the
        final pass scores a few thousand candidates). The terms are the ones the one-table
        path computes: each pair gets the same arithmetic, a maximum over legs is exact, and
        a free-space count sums whole numbers (sweeps' multiplicities), exact in any order.
        """
        self._fresh_terms()
        contacts = [t for t in tables if t.tobytes() not in self._contact_terms]
        for block in _blocks(
            contacts,
            [np.sort(self.store.contacts_near(t[0], t[1], self.contact_radius)) for t in contacts],
        ):
            self._prime_contacts(*block)
        free = [t for t in tables if t.tobytes() not in self._free_terms]
        radius = self.reach + self.half_diagonal + 0.05
        for block in _blocks(free, [self.store.near(t[0], t[1], radius) for t in free]):
            self._prime_free_space(*block)

    def _prime_contacts(self, tables: FloatArray, ids: list[IntArray]) -> None:
        """:meth:`table_contacts` of ``tables`` (n, 4), each over its candidate contacts."""
        sizes = [len(found) for found in ids]
        rows = self.store.rows_[np.repeat(np.concatenate(ids), 4)]
        legs = contact_squares(tables, self.catalogue)[np.repeat(np.arange(len(tables)), sizes)]
        theta = np.repeat(tables[:, 2], 4 * np.asarray(sizes, dtype=np.int64))
        density = (
            leg_contact_density_pairs(
                rows[:, :2],
                rows[:, 3],
                rows[:, 5],
                rows[:, 6],
                legs.reshape(-1, 3),
                theta,
                self.model,
            )
            .reshape(-1, 4)
            .max(axis=1)
        )
        at = 0
        for table, found, size in zip(tables, ids, sizes, strict=True):
            own = density[at : at + size]
            at += size
            explains = own > 0
            self._contact_terms[table.tobytes()] = (found[explains], own[explains])

    def _prime_free_space(self, tables: FloatArray, ids: list[IntArray]) -> None:
        """:meth:`table_free_space` of ``tables`` (n, 4), each over its sweeps within reach."""
        sizes = np.array([len(found) for found in ids], dtype=np.int64)
        sweeps = np.tile(np.concatenate(ids).reshape(-1, 1), 4).reshape(-1)
        rows = self.store.rows_[sweeps]
        legs = leg_centres(tables, self.catalogue)[np.repeat(np.arange(len(tables)), sizes)]
        swept = legs_swept_pairs(
            legs.reshape(-1, 3), rows[:, :2], rows[:, 2], rows[:, 3], rows[:, 4]
        )
        owner = np.repeat(np.arange(len(tables)), 4 * sizes)
        missed = np.bincount(
            owner, weights=swept * self.store.counts_[sweeps], minlength=len(tables)
        )
        for table, size, count in zip(tables, sizes.tolist(), missed.tolist(), strict=True):
            self._free_terms[table.tobytes()] = count * self.log_p_miss if size else 0.0

    def _own_density(self, table: FloatArray, ids: IntArray) -> FloatArray:
        """``(len(ids),)``: max over the legs of ``table`` (4,) of ρ_leg, for the stored
        contacts ``ids`` (those within :attr:`contact_radius` of its centre)."""
        if not len(ids):
            return np.zeros(0)
        rows = self.store.rows_[ids]
        legs = contact_squares(table, self.catalogue)[0]
        density = leg_contact_density(
            rows[:, :2], rows[:, 3], rows[:, 5], rows[:, 6], legs, np.full(4, table[2]), self.model
        )
        return np.asarray(density.max(axis=1))

    def gain_alone(self, table: FloatArray) -> float:
        """Δlog π of adding ``table`` to an empty room: prior, its contacts against walls and
        clutter, its free space (−∞ across a wall).

        An upper bound on its gain in any map: with other tables present each contact
        already has a cause at least as likely as walls and clutter, and overlaps only cost
        (so a table whose gain alone is not positive is never needed in a MAP map).
        """
        if not arena_contains(table, self.catalogue, self.model.arena)[0]:
            return -math.inf
        return self.log_intensity + self.table_free_space(table) + self.contact_gain(table[None])

    def contact_gain(self, tables: FloatArray) -> float:
        """The contact term's gain when ``tables`` (n, 4) join an empty room: Σ_i n_i
        [log max(floor_i, max over the tables of ρ(i)) − log floor_i] over their contacts.

        It grows with the set, and bounds the contact gain of any of its subsets added to
        any map (a contact's best cause there is at least its floor).
        """
        found = [self.table_contacts(table) for table in tables]
        if len(found) == 1:
            ids, density = found[0]
        else:
            ids, at = np.unique(np.concatenate([f[0] for f in found]), return_inverse=True)
            density = np.zeros(len(ids))
            np.maximum.at(density, at.reshape(-1), np.concatenate([f[1] for f in found]))
        if not len(ids):
            return 0.0
        floor = self.floor[ids]
        return float(
            (self.store.counts_[ids] * (np.log(np.maximum(floor, density)) - np.log(floor))).sum()
        )

    def table_free_space(self, table: FloatArray) -> float:
        """Term F3 of one table (kept per table while the store and reach are unchanged)."""
        self._fresh_terms()
        key = table.tobytes()
        found = self._free_terms.get(key)
        if found is None:
            found = self._free_space(table)
            self._free_terms[key] = found
        return found

    def _free_space(self, table: FloatArray) -> float:
        return float(self.leg_misses(table).sum()) * self.log_p_miss

    def leg_misses(self, table: FloatArray) -> FloatArray:
        """``(4,)`` stored sweeps (with their multiplicities) whose free sector holds each
        leg of ``table``: the misses that term F3 charges ``log p_miss`` each."""
        ids = self.store.near(table[0], table[1], self.reach + self.half_diagonal + 0.05)
        if not len(ids):
            return np.zeros(4)
        rows = self.store.rows_[ids]
        legs = leg_centres(table, self.catalogue)[0]
        swept = legs_swept(legs, rows[:, :2], rows[:, 2], rows[:, 3], rows[:, 4])
        return swept @ self.store.counts_[ids]

    def _extend_floor(self, ids: IntArray) -> None:
        store = self.store
        if len(self.floor) < len(store):
            self.floor = np.concatenate([self.floor, np.zeros(len(store) - len(self.floor))])
        rows = store.rows_[ids]
        hit = np.isfinite(rows[:, 5])
        floor = np.full(len(ids), self.model.clutter)
        if hit.any():
            r = rows[hit]
            wall = wall_contact_density(r[:, :2], r[:, 3], r[:, 5], r[:, 6], self.model)
            floor[hit] = np.maximum(floor[hit], wall)
        self.floor[ids] = floor

    def refresh(self, state: ChainState) -> None:
        """Recompute every cached term and log π from scratch."""
        store = self.store
        self.reach = float(store.rows_[:, 4].max()) if len(store) else 1.0
        self._free_terms.clear()
        self._extend_floor(np.arange(len(store)))
        state.free_space = np.array([self.table_free_space(t) for t in state.tables])
        state.log_pi = log_posterior(
            state.tables, self.catalogue, self.model, store.rows_, store.counts_
        )

    def update_near(self, state: ChainState, new_ids: IntArray, x: float, y: float) -> None:
        """Bring the caches up to date after sweeps ``new_ids`` were stored around ``(x, y)``
        (their roots, to within a centimetre: one pose).

        The kept terms of the map's tables that the new sweeps cannot reach stay: a new or
        merged contact lies within its whisker's length of its root, so a table whose centre
        lies farther than :attr:`contact_radius` plus that from every new root keeps its
        contacts and their densities; one farther than the free-space radius (reach + half
        diagonal + 5 cm) from every new root keeps its missed sweeps. Every other kept term
        is forgotten, as when the store changes elsewhere.
        """
        rows = self.store.rows_[new_ids]
        reach = max(self.reach, float(rows[:, 4].max()))
        current = self._terms_version == self.store.version_ - 1 and reach == self.reach
        contacts, free = self._contact_terms, self._free_terms
        self._contact_terms, self._free_terms = {}, {}
        self._terms_version = self.store.version_
        self.reach = reach
        if current:
            slack = float(np.hypot(rows[:, 0] - x, rows[:, 1] - y).max())
            for table in state.tables:
                gap = math.hypot(table[0] - x, table[1] - y) - slack
                key = table.tobytes()
                if gap > self.contact_radius + reach and key in contacts:
                    self._contact_terms[key] = contacts[key]
                if gap > reach + self.half_diagonal + 0.05 and key in free:
                    self._free_terms[key] = free[key]
        self._extend_floor(new_ids)
        radius = self.reach + self.half_diagonal + 0.1
        for i, table in enumerate(state.tables):
            if math.hypot(table[0] - x, table[1] - y) <= radius:
                state.free_space[i] = self.table_free_space(table)


_PAIRS_PER_BLOCK = 100_000
"""(Row, leg) pairs :meth:`Context.prime` evaluates in one numpy pass (bounds its memory)."""


def _blocks(
    tables: list[FloatArray], ids: list[IntArray]
) -> list[tuple[FloatArray, list[IntArray]]]:
    """``tables`` and their evidence rows ``ids`` in consecutive blocks of about
    :data:`_PAIRS_PER_BLOCK` (row, leg) pairs; tables without rows are left out of the
    pairs but kept in their block."""
    out: list[tuple[FloatArray, list[IntArray]]] = []
    start, pairs = 0, 0
    for end, found in enumerate(ids, 1):
        pairs += 4 * len(found)
        if pairs >= _PAIRS_PER_BLOCK or end == len(ids):
            out.append((np.array(tables[start:end]).reshape(-1, 4), ids[start:end]))
            start, pairs = end, 0
    return out


class Move:
    """A proposed change: remove the tables at indices ``removed``, add the tables ``added``."""

    __slots__ = ("added", "kind", "log_q_ratio", "removed")

    def __init__(
        self,
        kind: MoveKind,
        removed: tuple[int, ...],
        added: tuple[FloatArray, ...],
        log_q_ratio: float = 0.0,
    ):
        self.kind = kind
        self.removed = removed
        self.added = added
        self.log_q_ratio = log_q_ratio


def moved_tables(tables: FloatArray, move: Move) -> FloatArray:
    """The tables after ``move``: the kept ones in order, then the added ones."""
    kept = np.delete(tables, list(move.removed), axis=0)
    return np.vstack([kept, *[t[None] for t in move.added]]) if move.added else kept


def _in_box(table: FloatArray, box: tuple[float, float, float, float]) -> bool:
    return bool(box[0] <= table[0] <= box[2] and box[1] <= table[1] <= box[3])


def _rotation(theta: float) -> FloatArray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


_CORNER_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])


def _place(leg: FloatArray, theta: float, corner: int, kind: ObjectType, k: int) -> FloatArray:
    """The table of type ``kind`` at angle ``theta`` whose corner ``corner`` is at ``leg``."""
    a, b = kind.half_spacing
    centre = leg - _rotation(theta) @ (_CORNER_SIGNS[corner] * (a, b))
    return np.array([centre[0], centre[1], theta % math.pi, float(k)])


def _close_pairs(tables: FloatArray, radius: float) -> list[tuple[int, int]]:
    """Pairs ``(i, j)``, i < j, of ``tables`` whose centres lie within ``2 radius``."""
    if len(tables) < 2:
        return []
    d = np.hypot(tables[:, None, 0] - tables[None, :, 0], tables[:, None, 1] - tables[None, :, 1])
    i, j = np.nonzero(np.triu(d <= 2.0 * radius, 1))
    return list(zip(i.tolist(), j.tolist(), strict=True))


def _split_density(
    parts: tuple[FloatArray, FloatArray], whole: FloatArray, birth: BirthProposal, radius: float
) -> float:
    """log of 2 q_L(t₁ | t) q_L(t₂ | t): the unordered pair drawn by a split of ``whole``."""
    q1 = near_density(parts[0], birth, whole[:2], radius)
    q2 = near_density(parts[1], birth, whole[:2], radius)
    return math.log(2.0) + math.log(q1) + math.log(q2) if q1 > 0 and q2 > 0 else -math.inf


def _merge_density(
    parts: tuple[FloatArray, FloatArray], whole: FloatArray, birth: BirthProposal, radius: float
) -> float:
    """log q_L(t | midpoint of the pair): the table a merge of ``parts`` draws."""
    q = near_density(whole, birth, 0.5 * (parts[0][:2] + parts[1][:2]), radius)
    return math.log(q) if q > 0 else -math.inf


@functools.cache
def _kind_rates(
    rates: MoveRates, n_types: int
) -> tuple[list[MoveKind], FloatArray, dict[MoveKind, float]]:
    """The move kinds, their cumulative probabilities and each kind's probability (no type
    change with a single type), normalised once per rates and catalogue size."""
    kinds = list(MoveKind)
    p = np.array([getattr(rates, kind.value) for kind in kinds])
    if n_types == 1:
        p[kinds.index(MoveKind.TYPE)] = 0.0
    p = p / p.sum()
    return kinds, np.cumsum(p), dict(zip(kinds, p.tolist(), strict=True))


def propose(
    rng: np.random.Generator,
    state: ChainState,
    ctx: Context,
    birth: BirthProposal,
    rates: MoveRates,
) -> Move | None:
    """Draw one move inside ``birth.box``; ``None`` when the drawn kind cannot apply."""
    kinds, cumulative, rate = _kind_rates(rates, len(ctx.catalogue))
    kind = kinds[min(int(np.searchsorted(cumulative, rng.uniform(), side="right")), len(kinds) - 1)]
    box = birth.box
    tables = state.tables
    inside = np.flatnonzero(
        (tables[:, 0] >= box[0])
        & (tables[:, 0] <= box[2])
        & (tables[:, 1] >= box[1])
        & (tables[:, 1] <= box[3])
    ).tolist()
    n = len(inside)
    radius = ctx.half_diagonal
    if kind is MoveKind.BIRTH:
        table = draw_birth(rng, birth)
        q = birth_density(table, birth)
        if q <= 0.0:
            return None
        log_q = math.log(rate[MoveKind.DEATH] / (n + 1)) - math.log(rate[kind] * q)
        return Move(kind, (), (table,), log_q)
    if kind is MoveKind.MERGE:
        pairs = _close_pairs(state.tables[inside], radius)
        if not pairs:
            return None
        i, j = pairs[int(rng.integers(len(pairs)))]
        parts = (state.tables[inside[i]], state.tables[inside[j]])
        whole = draw_near(rng, birth, 0.5 * (parts[0][:2] + parts[1][:2]), radius)
        if whole is None or not _in_box(whole, box):
            return None
        log_q = (
            math.log(rate[MoveKind.SPLIT] / (n - 1))
            + _split_density(parts, whole, birth, radius)
            - math.log(rate[kind] / len(pairs))
            - _merge_density(parts, whole, birth, radius)
        )
        return Move(kind, (inside[i], inside[j]), (whole,), log_q)
    if n == 0:
        return None
    index = inside[int(rng.integers(n))]
    old = state.tables[index]
    k = int(old[3])
    kind_of = ctx.catalogue[k]
    if kind is MoveKind.DEATH:
        q = birth_density(old, birth)
        return Move(
            kind, (index,), (), math.log(rate[MoveKind.BIRTH] * q) - math.log(rate[kind] / n)
        )
    if kind is MoveKind.SWITCH:
        new = draw_birth(rng, birth)
        q_new = birth_density(new, birth)
        if q_new <= 0.0:
            return None
        return Move(kind, (index,), (new,), math.log(birth_density(old, birth)) - math.log(q_new))
    if kind is MoveKind.SPLIT:
        first, second = (
            draw_near(rng, birth, old[:2], radius),
            draw_near(rng, birth, old[:2], radius),
        )
        if first is None or second is None or not (_in_box(first, box) and _in_box(second, box)):
            return None
        parts = (first, second)
        after = np.vstack(
            [np.delete(state.tables[inside], inside.index(index), axis=0), first, second]
        )
        if math.hypot(*(first[:2] - second[:2])) > 2.0 * radius:
            return None  # no merge could undo it: q(reverse) = 0
        n_pairs = len(_close_pairs(after, radius))
        log_q = (
            math.log(rate[MoveKind.MERGE] / n_pairs)
            + _merge_density(parts, old, birth, radius)
            - math.log(rate[kind] / n)
            - _split_density(parts, old, birth, radius)
        )
        return Move(kind, (index,), parts, log_q)
    if kind is MoveKind.REFINE:
        scale = int(rng.integers(2))
        step = np.array([rates.step_xy[scale], rates.step_xy[scale], rates.step_theta[scale]])
        new = old.copy()
        new[:3] += step * rng.standard_normal(3)
        new[2] %= math.pi
    elif kind is MoveKind.MIRROR:
        side = int(rng.integers(4))
        a, b = kind_of.half_spacing
        offset = [(0.0, -2 * b), (2 * a, 0.0), (0.0, 2 * b), (-2 * a, 0.0)][side]
        new = old.copy()
        new[:2] += _rotation(old[2]) @ np.array(offset)
    elif kind is MoveKind.CORNER:
        corner = int(rng.integers(4))
        leg = leg_centres(old, ctx.catalogue)[0, corner, :2]
        choice = int(rng.integers(7))
        placements = [(turn, j) for turn in (0, 1) for j in range(4) if (turn, j) != (0, corner)]
        turn, j = placements[choice]
        new = _place(leg, old[2] + turn * 0.5 * math.pi, j, kind_of, k)
    else:
        corner = int(rng.integers(4))
        leg = leg_centres(old, ctx.catalogue)[0, corner, :2]
        others = [m for m in range(len(ctx.catalogue)) if m != k]
        k_new = others[int(rng.integers(len(others)))]
        new = _place(leg, float(old[2]), corner, ctx.catalogue[k_new], k_new)
    if not _in_box(new, box):
        return None
    return Move(kind, (index,), (new,), 0.0)


def _overlaps(tables: tuple[FloatArray, ...], others: FloatArray, ctx: Context) -> int:
    """Overlapping pairs among ``tables`` and between them and ``others``."""
    count = 0
    for i, table in enumerate(tables):
        rest = np.vstack([others, *tables[i + 1 :]]) if i + 1 < len(tables) else others
        count += int(tables_overlap(table, rest, ctx.catalogue).sum())
    return count


def _best_cause(
    base: FloatArray, found: list[tuple[IntArray, FloatArray]], ids: IntArray
) -> FloatArray:
    """``max(base, ρ of each table)`` on the sorted contacts ``ids``: ``found`` holds the
    tables' contacts and densities (:meth:`Context.table_contacts`); a table has ρ = 0 on
    the contacts it does not list. All tables are merged in one pass (max is exact, so the
    order does not matter)."""
    out = base.copy()
    if not found:
        return out
    own = np.concatenate([f[0] for f in found]) if len(found) > 1 else found[0][0]
    density = np.concatenate([f[1] for f in found]) if len(found) > 1 else found[0][1]
    at = np.searchsorted(ids, own)
    ok = at < len(ids)
    ok[ok] = ids[at[ok]] == own[ok]
    np.maximum.at(out, at[ok], density[ok])
    return out


def evaluate(state: ChainState, ctx: Context, move: Move) -> tuple[float, FloatArray]:
    """``Δlog π`` of ``move`` and the added tables' free-space terms.

    Local: only contacts within reach of the removed or added tables change, and their best
    cause is sought among the walls, clutter and the tables near them.
    """
    removed = tuple(state.tables[i] for i in move.removed)
    added = move.added
    others = state.tables
    if move.removed:
        keep = np.ones(len(others), dtype=bool)
        keep[list(move.removed)] = False
        others = others[keep]
    if added and not arena_contains(np.array(added), ctx.catalogue, ctx.model.arena).all():
        return -math.inf, np.zeros(len(added))
    forbidden = ctx.model.log_overlap == -math.inf
    overlaps = _overlaps(added, others, ctx)
    if not (forbidden and math.isfinite(state.log_pi)):
        # with overlaps forbidden, a map of finite log π has none to remove
        overlaps -= _overlaps(removed, others, ctx)
    if overlaps > 0 and forbidden:
        return -math.inf, np.zeros(len(added))  # a forbidden overlap: nothing else matters
    changed = [*removed, *added]
    radius = ctx.contact_radius
    own = [ctx.table_contacts(t) for t in changed]
    # one table's contact ids are already sorted and distinct
    ids = own[0][0] if len(own) == 1 else np.unique(np.concatenate([found[0] for found in own]))
    delta = 0.0
    if len(ids):
        centre = np.mean([t[:2] for t in changed], axis=0)
        spread = max(math.hypot(*(t[:2] - centre)) for t in changed)
        close = np.hypot(others[:, 0] - centre[0], others[:, 1] - centre[1]) <= 2 * radius + spread
        base = _best_cause(ctx.floor[ids], [ctx.table_contacts(t) for t in others[close]], ids)
        before = _best_cause(base, own[: len(removed)], ids)
        after = _best_cause(base, own[len(removed) :], ids)
        delta = float((ctx.store.counts_[ids] * (np.log(after) - np.log(before))).sum())
    free_new = np.array([ctx.table_free_space(t) for t in added])
    delta += float(free_new.sum() - state.free_space[list(move.removed)].sum())
    delta += ctx.log_intensity * (len(added) - len(removed))
    if overlaps:
        delta += ctx.model.log_overlap * overlaps
    return delta, free_new


def apply(state: ChainState, move: Move, free_new: FloatArray, delta: float) -> None:
    """Make ``move`` the chain's state, with its cached terms."""
    state.tables = moved_tables(state.tables, move)
    state.free_space = np.concatenate([np.delete(state.free_space, list(move.removed)), free_new])
    state.log_pi += delta


def run(
    rng: np.random.Generator,
    state: ChainState,
    ctx: Context,
    birth: BirthProposal,
    rates: MoveRates,
    betas: FloatArray,
    *,
    record_every: int = 0,
) -> tuple[FloatArray, float, list[FloatArray], dict[str, int]]:
    """Run one move per entry of ``betas`` (inverse temperatures), updating ``state``.

    Returns the tables of the best state visited and its log π (untempered), the recorded
    samples (every ``record_every`` moves at β = 1, if > 0) and counters
    ``proposed_<kind>``, ``accepted_<kind>``.
    """
    best, best_log_pi = state.tables.copy(), state.log_pi
    samples: list[FloatArray] = []
    info: dict[str, int] = {}
    for step, beta in enumerate(betas):
        move = propose(rng, state, ctx, birth, rates)
        if move is not None:
            name = move.kind.value
            info[f"proposed_{name}"] = info.get(f"proposed_{name}", 0) + 1
            delta, free_new = evaluate(state, ctx, move)
            log_alpha = beta * delta + move.log_q_ratio
            if math.isfinite(log_alpha) and (log_alpha >= 0 or rng.uniform() < math.exp(log_alpha)):
                apply(state, move, free_new, delta)
                info[f"accepted_{name}"] = info.get(f"accepted_{name}", 0) + 1
                if state.log_pi > best_log_pi:
                    best, best_log_pi = state.tables.copy(), state.log_pi
        if record_every and beta == 1.0 and step % record_every == 0:
            samples.append(state.tables.copy())
    return best, best_log_pi, samples, info


def _copy(state: ChainState) -> ChainState:
    return ChainState(state.tables.copy(), state.free_space.copy(), state.log_pi)


def holding(
    tables: FloatArray, reference: FloatArray, xy: float, theta: float, periods: FloatArray
) -> BoolArray:
    """``(n,)`` whether ``tables`` holds, for each of ``reference`` (n, 4), a table of the same
    type within ``xy`` [m] and ``theta`` [rad]; ``periods`` (n,) is each reference object's
    rotational symmetry (π for a rectangle, π/2 for a square)."""
    if not len(tables) or not len(reference):
        return np.zeros(len(reference), dtype=bool)
    d = np.mod(tables[None, :, 2] - reference[:, None, 2], periods[:, None])
    close = np.hypot(
        tables[None, :, 0] - reference[:, None, 0], tables[None, :, 1] - reference[:, None, 1]
    )
    same = (
        (tables[None, :, 3] == reference[:, None, 3])
        & (close <= xy)
        & (np.minimum(d, periods[:, None] - d) <= theta)
    )
    return np.asarray(same.any(axis=1))


def visit_frequencies(
    samples: list[FloatArray], reference: FloatArray, xy: float, theta: float, periods: FloatArray
) -> FloatArray:
    """``(n,)`` the fraction of ``samples`` (states of a chain at β = 1) holding each object
    of ``reference`` (see :func:`holding`): a Monte Carlo estimate of the posterior
    probability that an object of that type stands there, to the given tolerance."""
    if not samples:
        return np.full(len(reference), np.nan)
    held = np.zeros(len(reference))
    for sample in samples:
        held += holding(sample, reference, xy, theta, periods)
    return held / len(samples)


def _try(state: ChainState, ctx: Context, move: Move) -> float:
    """Apply ``move`` to ``state`` and return its Δlog π (−∞, state unchanged, if forbidden)."""
    delta, free_new = evaluate(state, ctx, move)
    if math.isfinite(delta):
        apply(state, move, free_new, delta)
    return delta


_BOUND_SLACK = 1e-6
"""Margin [nats] by which a bound on a trial's gain must stay below the keep threshold
before the greedy ascent skips the trial (rounding of the two sums it compares)."""


def removal_costs(state: ChainState, ctx: Context) -> FloatArray:
    """``(n,)`` each table's removal cost: log π(X) − log π(X without it), the rest kept.

    The costs are super-additive: removing a set H of tables together costs at least the
    sum of their costs ::

        log π(X) − log π(X ∖ H)  ≥  Σ_{h ∈ H} [log π(X) − log π(X ∖ {h})].

    Proof, term by term of the joint (:func:`~bayesmap.blackboard.sweep_model.log_posterior`):

    - *prior* (log λ per table) and *free space* (F3, each table's own missed sweeps): a
      sum over tables, so removing H costs exactly the sum of the single costs;
    - *contacts*: contact i contributes n_i log max(b_i, ρ_1, …, ρ_m), b_i the best of walls,
      clutter and the tables outside H, ρ_h the best leg of h ∈ H. Only the table with the
      largest ρ can cost anything alone, and it costs n_i [log M − log max(b_i, second
      largest ρ)] ≤ n_i [log M − log b_i], M = max(b_i, ρ_1, …, ρ_m): the joint cost of H on
      that contact. Tables compete for contacts (each takes its best cause), so what a
      contact loses when several of its explanations go at once is at least the sum of
      what it loses when each goes alone;
    - *overlap* (log ε < 0 per overlapping pair, paper eq. 16): a pair inside H counts
      once in the joint cost and twice in the sum, a pair between H and the rest once in
      each; as log ε < 0 the sum is the smaller.

    It would fail for any term that rewards tables together: a positive pair factor
    (log ε > 0, refused by the model), a contact explained only by two tables jointly, or
    free space shared between tables (a whisker stopped by one table's leg cannot sweep
    through a leg behind it, so removing the front table would *add* the rear one's
    free-space cost — a term this model does not have: each table's F3 counts its own
    legs' sweeps, whatever else stands there). The test
    ``test_an_exchange_never_gains_more_than_its_bound`` checks the resulting bound against
    the joint on random configurations.
    """
    costs = np.empty(len(state.tables))
    for index in range(len(state.tables)):
        costs[index] = -evaluate(state, ctx, Move(MoveKind.DEATH, (index,), ()))[0]
    return costs


class CandidateScreen:
    """What the greedy ascent can tell about its fixed candidate tables without evaluating
    a move: whether the map already holds one, whether it crosses a wall, whether it
    overlaps a given table.

    Overlaps are computed once per (candidate, table) pair, as
    ``tables_overlap(candidate, table[None])[0]`` answers
    (:func:`~bayesmap.blackboard.sweep_model.overlap_pairs`), and kept under the table's exact
    ``x, y, θ, k``: the ascent asks about the same few tables of the map (and the candidate
    each exchange puts in) for thousands of candidates. That is, row by row, what
    :func:`~bayesmap.blackboard.sweep_model.tables_overlap` answers for a candidate against
    up to :data:`~bayesmap.blackboard.sweep_model.SCREEN_ROWS` tables at once (its
    plain-float path treats each row alone); against more, the answers are not kept but
    computed by that call itself. So they are always the answers a move's evaluation gets.
    """

    def __init__(self, candidates: FloatArray, ctx: Context) -> None:
        self.candidates = candidates
        self.catalogue = ctx.catalogue
        self.inside = arena_contains(candidates, ctx.catalogue, ctx.model.arena)
        self.forbidden = ctx.model.log_overlap == -math.inf
        self._known: dict[bytes, IntArray] = {}

    def overlapping(self, rows: IntArray, tables: FloatArray) -> BoolArray:
        """``(len(rows), len(tables))`` whether candidate ``rows`` overlap each of
        ``tables`` (n, 4)."""
        if len(tables) > SCREEN_ROWS:
            return np.array(
                [tables_overlap(self.candidates[r], tables, self.catalogue) for r in rows],
                dtype=bool,
            ).reshape(len(rows), len(tables))
        out = np.empty((len(rows), len(tables)), dtype=bool)
        for column, table in enumerate(tables):
            known = self._known.get(table.tobytes())
            if known is None:
                known = np.full(len(self.candidates), -1, dtype=np.int8)
                self._known[table.tobytes()] = known
            values = known[rows]
            unknown = np.flatnonzero(values < 0)
            if len(unknown):
                new = rows[unknown]
                answers = overlap_pairs(
                    self.candidates[new], np.tile(table, (len(new), 1)), self.catalogue
                )
                values[unknown] = known[new] = answers
            out[:, column] = values == 1
        return out

    def held(self, tables: FloatArray, rows: IntArray) -> BoolArray:
        """``(len(rows),)`` whether ``tables`` holds, for each candidate of ``rows``, one of
        the same type within 3 cm and 0.05 rad (modulo π): the ascent adds no table twice."""
        reference = self.candidates[rows]
        return holding(tables, reference, 0.03, 0.05, np.full(len(reference), math.pi))

    def blocked(self, tables: FloatArray, rows: IntArray) -> BoolArray:
        """``(len(rows),)`` whether each candidate of ``rows`` is held by the map ``tables``
        or could not join it (its birth's Δlog π is −∞): it crosses a wall or, with
        overlaps forbidden, overlaps one of ``tables``."""
        out = self.held(tables, rows) | ~self.inside[rows]
        if self.forbidden and len(tables):
            open_rows = np.flatnonzero(~out)
            out[open_rows] = self.overlapping(rows[open_rows], tables).any(axis=1)
        return out


def greedy_ascent(
    state: ChainState, ctx: Context, candidates: FloatArray, *, passes: int = 2
) -> dict[str, int]:
    """Climb log π from ``state`` through the data-driven candidates (reading off the MAP).

    The zero-temperature end of the annealing, over a larger neighbourhood than the chain's
    single moves: for each candidate table c (in the order given) not already in the map,
    *replace and refill* — remove every table c overlaps, add c, then add each other
    candidate whose centre lies within a half diagonal of a removed table's and whose
    birth raises log π — and keep the result if log π rose in total; then remove any table
    whose death raises log π. This reaches, in one step, the one-table-for-two exchanges
    (and back) that the chain reaches only through much worse maps. Repeats until a pass
    changes nothing (at most ``passes``). Modifies ``state``;
    returns counters ``greedy_tried``, ``greedy_kept``, ``greedy_ruled_out``.

    Two bounds skip work that cannot pay; the result is the same as trying everything.
    Adding tables gains at most the sum of their gains alone (:meth:`Context.gain_alone`:
    tables only compete for contacts, overlaps only cost), and removing the set H that c
    overlaps costs at least the sum of its tables' removal costs (:func:`removal_costs`,
    super-additive). So an exchange gains at most gain_alone(c) + Σ max(gain_alone(r), 0)
    over its possible refills r − Σ_{h ∈ H} cost(h); or, tighter where the refills crowd the
    same contacts, the prior and free-space terms of c (and any positive ones of the r) plus
    the contact gain of c and all its possible refills together
    (:meth:`Context.contact_gain`, each contact counted once at its best cause among them)
    − Σ_{h ∈ H} cost(h). An exchange is *ruled out* untried when the smaller is below
    zero. Once tried, the refills stop as soon as the exchange's gain so far plus the gains
    alone of the refills not yet tried cannot exceed zero (the exchange could no longer be
    kept, whatever they add). Refills that could never join after c — those
    whose gain alone is not positive, and, when overlaps are forbidden (log ε_c = −∞),
    those c overlaps — are neither tried nor counted in the bound (in the noisy condition
    most refills near a removed table overlap the candidate that replaces it, and counting
    them left the bound unable to rule anything out).

    Refills that could not join the trial map are skipped without evaluating their birth,
    found for all of an exchange's refills at once (:class:`CandidateScreen`): those the
    map already holds, those across a wall, and, with overlaps forbidden, those that
    overlap one of its tables (the same answers as the birth's own overlap test). One by
    one, each would have been skipped or its birth scored −∞.
    """
    info = {"greedy_tried": 0, "greedy_kept": 0, "greedy_ruled_out": 0}
    reach = ctx.half_diagonal
    ctx.prime(candidates)
    alone = np.array([ctx.gain_alone(c) for c in candidates])
    refill_gain = np.maximum(alone, 0.0)
    own = np.array([ctx.log_intensity + ctx.table_free_space(c) for c in candidates])
    screen = CandidateScreen(candidates, ctx)
    every = np.arange(len(candidates))

    for _ in range(passes):
        changed = False
        costs = removal_costs(state, ctx)
        held = screen.held(state.tables, every)
        for j, c in enumerate(candidates):
            if held[j]:
                continue
            hit = (
                np.flatnonzero(screen.overlapping(every[j : j + 1], state.tables)[0])
                if len(state.tables)
                else np.zeros(0, dtype=np.int64)
            )
            near = np.zeros(len(candidates), dtype=bool)
            if len(hit):
                centres = state.tables[hit, :2]
                near = (
                    np.hypot(
                        candidates[:, None, 0] - centres[None, :, 0],
                        candidates[:, None, 1] - centres[None, :, 1],
                    ).min(axis=1)
                    <= reach
                )
                near[j] = False  # c is in the map before any refill
                # never added after c: a refill c overlaps (when overlaps are forbidden) or
                # one whose gain alone, its largest anywhere, is not positive
                near &= alone > 0
                if ctx.model.log_overlap == -math.inf and near.any():
                    near[near] = ~tables_overlap(c, candidates[near], ctx.catalogue)
            bound = alone[j] + refill_gain[near].sum()
            if near.any() and bound - costs[hit].sum() >= -_BOUND_SLACK:
                # the refills compete with c and each other for contacts (a tighter bound,
                # needed only when the first does not rule the exchange out)
                together = ctx.contact_gain(np.vstack([c, candidates[near]]))
                bound = min(bound, own[j] + np.maximum(own[near], 0.0).sum() + together)
            if bound - costs[hit].sum() < -_BOUND_SLACK:
                info["greedy_ruled_out"] += 1
                continue  # no exchange through c can raise log π
            trial = _copy(state)
            info["greedy_tried"] += 1
            gain = _try(trial, ctx, Move(MoveKind.SWITCH, tuple(hit.tolist()), (c,)))
            if not math.isfinite(gain):
                continue
            if len(hit):
                # what the refills not yet tried could still add, at most (their gains alone)
                left = float(refill_gain[near].sum())
                refills = np.flatnonzero(near)
                skip = screen.blocked(trial.tables, refills)
                for position, row in enumerate(refills.tolist()):
                    if gain + left <= 1e-9:
                        break  # even every remaining refill could not make it pay: not kept
                    left -= refill_gain[row]
                    if skip[position]:
                        continue
                    birth = Move(MoveKind.BIRTH, (), (candidates[row],))
                    extra, free_new = evaluate(trial, ctx, birth)
                    if extra > 0:
                        apply(trial, birth, free_new, extra)
                        gain += extra
                        rest = refills[position + 1 :]
                        skip[position + 1 :] = screen.blocked(trial.tables, rest)
            if gain > 1e-9:
                state.tables, state.free_space, state.log_pi = (
                    trial.tables,
                    trial.free_space,
                    trial.log_pi,
                )
                info["greedy_kept"] += 1
                changed = True
                costs = removal_costs(state, ctx)
                held = screen.held(state.tables, every)
        index = 0
        while index < len(state.tables):
            trial = _copy(state)
            if _try(trial, ctx, Move(MoveKind.DEATH, (index,), ())) > 1e-9:
                state.tables, state.free_space, state.log_pi = (
                    trial.tables,
                    trial.free_space,
                    trial.log_pi,
                )
                changed = True
            else:
                index += 1
        if not changed:
            break
    return info
