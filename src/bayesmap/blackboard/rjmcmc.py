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

Acceptance: ``log α = β Δlog π + log q-ratio`` (Metropolis–Hastings; all moves are rigid
maps of (x, y, θ), Jacobian 1). ``Δlog π`` is computed locally (the changed table's contacts,
free-space sweeps and neighbours); tests check it against
:func:`~bayesmap.blackboard.sweep_model.log_posterior` from scratch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from bayesmap._typing import FloatArray, IntArray
from bayesmap.blackboard.data_driven import BirthProposal, birth_density, draw_birth
from bayesmap.blackboard.evidence import EvidenceStore
from bayesmap.blackboard.sweep_model import (
    ObjectType,
    SweepModel,
    arena_contains,
    contact_cutoff,
    leg_centres,
    leg_contact_density,
    legs_swept,
    log_posterior,
    tables_overlap,
    wall_contact_density,
)

__all__ = ["ChainState", "Move", "MoveKind", "MoveRates", "evaluate", "propose", "run"]


class MoveKind(Enum):
    BIRTH = "birth"
    DEATH = "death"
    REFINE = "refine"
    MIRROR = "mirror"
    CORNER = "corner"
    TYPE = "type"
    SWITCH = "switch"


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


class Context:
    """What every move needs: catalogue, model, evidence, the walls' density per contact."""

    def __init__(self, catalogue: tuple[ObjectType, ...], model: SweepModel, store: EvidenceStore):
        self.catalogue = catalogue
        self.model = model
        self.store = store
        self.half_diagonal = max(0.5 * math.hypot(t.length, t.width) for t in catalogue)
        half_leg = max(0.5 * t.leg for t in catalogue)
        self.contact_radius = self.half_diagonal + contact_cutoff(half_leg, model)
        """Contact points farther than this [m] from a table's centre get no ρ from it."""
        self.reach = 1.0
        self.log_p_miss = math.log(model.p_miss)
        self.log_intensity = math.log(model.intensity)
        self.floor = np.zeros(0)
        """Per stored sweep, max(κ, ρ_wall): what explains a contact without tables."""

    def tables_density(self, tables: FloatArray, ids: IntArray) -> FloatArray:
        """``(len(ids), n)``: for each of ``tables`` (n, 4), max over its legs of ρ_leg."""
        out = np.zeros((len(ids), len(tables)))
        if not len(ids) or not len(tables):
            return out
        points = self.store.points_[ids]
        d2 = (points[:, None, 0] - tables[None, :, 0]) ** 2 + (
            points[:, None, 1] - tables[None, :, 1]
        ) ** 2
        near = np.flatnonzero((d2 <= self.contact_radius**2).any(axis=1))
        if not len(near):
            return out
        rows = self.store.rows_[ids[near]]
        legs = leg_centres(tables, self.catalogue).reshape(-1, 3)
        theta = np.repeat(tables[:, 2], 4)
        density = leg_contact_density(
            rows[:, :2], rows[:, 3], rows[:, 5], rows[:, 6], legs, theta, self.model
        )
        out[near] = density.reshape(len(near), len(tables), 4).max(axis=2)
        return out

    def table_free_space(self, table: FloatArray) -> float:
        """Term F3 of one table."""
        ids = self.store.near(table[0], table[1], self.reach + self.half_diagonal + 0.05)
        if not len(ids):
            return 0.0
        rows = self.store.rows_[ids]
        legs = leg_centres(table, self.catalogue)[0]
        swept = legs_swept(legs, rows[:, :2], rows[:, 2], rows[:, 3], rows[:, 4])
        return float((swept * self.store.counts_[ids][None]).sum()) * self.log_p_miss

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
        self._extend_floor(np.arange(len(store)))
        state.free_space = np.array([self.table_free_space(t) for t in state.tables])
        state.log_pi = log_posterior(
            state.tables, self.catalogue, self.model, store.rows_, store.counts_
        )

    def update_near(self, state: ChainState, new_ids: IntArray, x: float, y: float) -> None:
        """Bring the caches up to date after sweeps ``new_ids`` were stored around ``(x, y)``."""
        self.reach = max(self.reach, float(self.store.rows_[new_ids, 4].max()))
        self._extend_floor(new_ids)
        radius = self.reach + self.half_diagonal + 0.1
        for i, table in enumerate(state.tables):
            if math.hypot(table[0] - x, table[1] - y) <= radius:
                state.free_space[i] = self.table_free_space(table)


class Move:
    """A proposed change: replace table ``index`` (or none) by ``table`` (or none)."""

    __slots__ = ("index", "kind", "log_q_ratio", "table")

    def __init__(
        self, kind: MoveKind, index: int | None, table: FloatArray | None, log_q_ratio: float = 0.0
    ):
        self.kind = kind
        self.index = index
        self.table = table
        self.log_q_ratio = log_q_ratio


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


def propose(
    rng: np.random.Generator,
    state: ChainState,
    ctx: Context,
    birth: BirthProposal,
    rates: MoveRates,
) -> Move | None:
    """Draw one move inside ``birth.box``; ``None`` when the drawn kind cannot apply."""
    kinds = list(MoveKind)
    p = np.array(
        [
            rates.birth,
            rates.death,
            rates.refine,
            rates.mirror,
            rates.corner,
            rates.type,
            rates.switch,
        ]
    )
    if len(ctx.catalogue) == 1:
        p[5] = 0.0
    p = p / p.sum()
    kind = kinds[min(int(np.searchsorted(np.cumsum(p), rng.uniform(), side="right")), len(p) - 1)]
    box = birth.box
    inside = [i for i, t in enumerate(state.tables) if _in_box(t, box)]
    n = len(inside)
    if kind is MoveKind.BIRTH:
        table = draw_birth(rng, birth)
        q = birth_density(table, birth)
        if q <= 0.0:
            return None
        return Move(kind, None, table, math.log(p[1] / (n + 1)) - math.log(p[0] * q))
    if n == 0:
        return None
    index = inside[int(rng.integers(n))]
    old = state.tables[index]
    k = int(old[3])
    kind_of = ctx.catalogue[k]
    if kind is MoveKind.DEATH:
        q = birth_density(old, birth)
        return Move(kind, index, None, math.log(p[0] * q) - math.log(p[1] / n))
    if kind is MoveKind.SWITCH:
        new = draw_birth(rng, birth)
        q_new = birth_density(new, birth)
        if q_new <= 0.0:
            return None
        return Move(kind, index, new, math.log(birth_density(old, birth)) - math.log(q_new))
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
    return Move(kind, index, new, 0.0)


def evaluate(state: ChainState, ctx: Context, move: Move) -> tuple[float, float]:
    """``Δlog π`` of ``move`` and the moved table's new free-space term.

    Local: only contacts within reach of the old or new table change, and their best cause
    is sought among the walls, clutter and the tables near them.
    """
    new, old = move.table, None if move.index is None else state.tables[move.index]
    keep = np.ones(len(state.tables), dtype=bool)
    if move.index is not None:
        keep[move.index] = False
    others = state.tables[keep]
    overlaps = 0
    if new is not None:
        if not arena_contains(new, ctx.catalogue, ctx.model.arena)[0]:
            return -math.inf, 0.0
        overlaps += int(tables_overlap(new, others, ctx.catalogue).sum()) if len(others) else 0
    if old is not None and len(others):
        overlaps -= int(tables_overlap(old, others, ctx.catalogue).sum())
    changed = [t for t in (old, new) if t is not None]
    radius = ctx.contact_radius
    ids = np.unique(np.concatenate([ctx.store.contacts_near(t[0], t[1], radius) for t in changed]))
    delta = 0.0
    if len(ids):
        centre = np.mean([t[:2] for t in changed], axis=0)
        spread = max(math.hypot(*(t[:2] - centre)) for t in changed)
        close = np.hypot(others[:, 0] - centre[0], others[:, 1] - centre[1]) <= 2 * radius + spread
        group = np.vstack([others[close], *[t[None] for t in changed]])
        density = ctx.tables_density(group, ids)
        n_others = int(close.sum())
        base = ctx.floor[ids]
        if n_others:
            base = np.maximum(base, density[:, :n_others].max(axis=1))
        before = np.maximum(base, density[:, n_others]) if old is not None else base
        after = np.maximum(base, density[:, -1]) if new is not None else base
        delta = float((ctx.store.counts_[ids] * (np.log(after) - np.log(before))).sum())
    free_new = ctx.table_free_space(new) if new is not None else 0.0
    delta += free_new - (state.free_space[move.index] if move.index is not None else 0.0)
    delta += ctx.log_intensity * ((new is not None) - (old is not None))
    if overlaps:
        delta += ctx.model.log_overlap * overlaps
    return delta, free_new


def apply(state: ChainState, move: Move, free_new: float, delta: float) -> None:
    """Make ``move`` the chain's state, with its cached terms."""
    if move.index is None:
        assert move.table is not None
        state.tables = np.vstack([state.tables, move.table[None]])
        state.free_space = np.append(state.free_space, free_new)
    elif move.table is None:
        state.tables = np.delete(state.tables, move.index, axis=0)
        state.free_space = np.delete(state.free_space, move.index)
    else:
        state.tables = state.tables.copy()
        state.tables[move.index] = move.table
        state.free_space = state.free_space.copy()
        state.free_space[move.index] = free_new
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
