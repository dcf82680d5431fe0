"""Hypotheses and the blackboard B that holds them (Fox & Prescott 2011 §II-B, §II-C).

- :class:`Table` T(x_T, y_T, θ_T, w_T^L, τ_T): a table of the known size centred on
  ``(x, y)`` [m], long side along ``theta`` [rad], legs of side ``w`` [m], texture ``tau``.
- :class:`Leg` L(x_L, y_L, θ_L, w_L^x, w_L^y, τ_L, T): a square leg; its parent T is not a
  field of the leg but an explicit, changeable parameter held by the blackboard
  (``Blackboard.parent_``), as in the paper ("the purpose of the explicit parent parameter is
  to model constraint (b)").
- Shapelets S(x_S, y_S, θ_S, τ_S): the observed contacts, rows of a ``(n, 4)`` array.

:class:`Blackboard` is the sampler's state: the hypotheses, their parent links, the
children of every table by corner, and caches of the factors that change rarely (each leg's
density contribution to every shapelet, each leg's log density given its parent), so that a
move's Markov-blanket ratio touches only what the move touches.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from bayesmap._typing import FloatArray
from bayesmap.blackboard.densities import (
    CORNER_SIGNS,
    delta_leg_shapelet_scalar,
    delta_table_leg_scalar,
    rectangles_overlap_scalar,
)
from bayesmap.blackboard.params import BlackboardParams
from bayesmap.blackboard.spatial_hash import SpatialHash

NULL = -1
"""Parent id of a leg caused by chance (the null prior, eq. 8)."""

_HALF_PI = 0.5 * math.pi


class Leg(NamedTuple):
    """A leg hypothesis: centre ``x, y`` [m], ``theta`` [rad] (mod π/2), widths [m], texture."""

    x: float
    y: float
    theta: float
    wx: float
    wy: float
    tau: float


class Table(NamedTuple):
    """A table hypothesis: centre ``x, y`` [m], ``theta`` [rad] (mod π), leg width ``w`` [m],
    texture ``tau``, and its four leg-centre ``corners`` (eq. 6) in corner-index order."""

    x: float
    y: float
    theta: float
    w: float
    tau: float
    corners: tuple[tuple[float, float], ...]


def make_leg(x: float, y: float, theta: float, wx: float, wy: float, tau: float) -> Leg:
    """A :class:`Leg` with its angle reduced to ``[0, π/2)`` (a square's symmetry)."""
    return Leg(x, y, theta % _HALF_PI, wx, wy, tau)


def make_table(
    x: float, y: float, theta: float, w: float, tau: float, params: BlackboardParams
) -> Table:
    """A :class:`Table` with its angle reduced to ``[0, π)`` and its corners computed.

    The corners are the leg centres at ``(±a, ±b)`` in the table frame, with
    ``a = (table_length − w)/2`` and ``b = (table_width − w)/2`` (legs flush with the
    corners, as :attr:`BlackboardParams.corner_offset` for ``w = leg_width``); corner ``i``
    has the signs ``CORNER_SIGNS[i]``.
    """
    theta = theta % math.pi
    a = 0.5 * (params.table_length - w)
    b = 0.5 * (params.table_width - w)
    c, s = math.cos(theta), math.sin(theta)
    corners = tuple(
        (x + c * sx * a - s * sy * b, y + s * sx * a + c * sy * b) for sx, sy in CORNER_SIGNS
    )
    return Table(x, y, theta, w, tau, corners)


class Blackboard:
    """The blackboard B: tables, legs, their explicit parents, and the shapelets in memory.

    Attributes ending in ``_`` are the state; hypotheses are keyed by integer ids that are
    never reused. ``parent_[leg]`` is a table id or :data:`NULL`; ``corner_[leg]`` is the
    corner of that table the leg sits at (the minimiser in eq. 6, or -1);
    ``children_[table][i]`` lists the legs at corner ``i``; ``contrib_[leg][k]`` is the leg's
    density for shapelet ``k``, α_S e^{−Δ_LS} (eq. 7); ``shapelet_density_[k]`` is the
    noisy-OR sum c_S + Σ_L contrib (eq. 12); ``leg_log_term_[leg]`` is
    log((2δ)³ (α_L e^{−Δ_TL} + c_L)) given the current parent (eqs. 5, 8, 12, 19).
    """

    def __init__(self, params: BlackboardParams) -> None:
        self.params = params
        self.tables_: dict[int, Table] = {}
        self.legs_: dict[int, Leg] = {}
        self.parent_: dict[int, int] = {}
        self.corner_: dict[int, int] = {}
        self.children_: dict[int, list[list[int]]] = {}
        self.contrib_: dict[int, list[float]] = {}
        self.leg_log_term_: dict[int, float] = {}
        self.shapelets_: tuple[tuple[float, float, float, float], ...] = ()
        self.shapelet_density_: list[float] = []
        self.next_id_ = 0
        cell = params.table_length
        self.table_hash_ = SpatialHash(cell)
        self.leg_hash_ = SpatialHash(cell)
        self._log_box = params.log_box
        self._log_c_L = params.log_box + math.log(params.c_L)
        # two rectangles overlap only if their centres are closer than a full diagonal
        self._table_reach = math.hypot(params.table_length, params.table_width)
        self._leg_reach = math.sqrt(2.0) * params.leg_width

    # ------------------------------------------------------------------ size
    def __len__(self) -> int:
        return len(self.tables_) + len(self.legs_)

    # ------------------------------------------------------------------ shapelets
    def set_shapelets(self, shapelets: FloatArray) -> None:
        """Replace the observed shapelets (rows ``x, y, theta, tau``) and refresh caches."""
        self.shapelets_ = tuple(
            (float(r[0]), float(r[1]), float(r[2]), float(r[3])) for r in np.asarray(shapelets)
        )
        for key, leg in self.legs_.items():
            self.contrib_[key] = self.leg_contributions(leg)
        self.refresh_shapelet_density()

    def refresh_shapelet_density(self) -> None:
        """Recompute every shapelet's noisy-OR density from the legs' cached contributions."""
        density = [self.params.c_S] * len(self.shapelets_)
        for values in self.contrib_.values():
            for k, v in enumerate(values):
                density[k] += v
        self.shapelet_density_ = density

    def leg_contributions(self, leg: Leg) -> list[float]:
        """α_S e^{−Δ_LS} of ``leg`` for every shapelet in memory (eq. 7)."""
        p = self.params
        a, sr, st, sx = p.alpha_S, p.sigma_r_shapelet, p.sigma_theta_shapelet, p.sigma_tau_shapelet
        # beyond this distance from the leg's centre, α_S e^{−Δ} < 10⁻¹⁵ c_S: exactly 0 here
        reach = 0.5 * math.hypot(leg.wx, leg.wy) + sr * math.sqrt(
            max(math.log(a / p.c_S) + 35.0, 0.0)
        )
        reach2 = reach * reach
        out = []
        for s in self.shapelets_:
            if (s[0] - leg.x) ** 2 + (s[1] - leg.y) ** 2 > reach2:
                out.append(0.0)
            else:
                out.append(math.exp(-delta_leg_shapelet_scalar(leg, s, sr, st, sx)) * a)
        return out

    # ------------------------------------------------------------------ factors
    def leg_term(self, leg: Leg, parent: int) -> tuple[float, int]:
        """``(log((2δ)³ p(L | parent)), corner)`` with the noisy-OR of eqs. 5, 8 and 12.

        For ``parent == NULL`` the density is c_L (eq. 8) and the corner is -1.
        """
        if parent == NULL:
            return self._log_c_L, -1
        return self.leg_term_given(leg, self.tables_[parent])

    def leg_term_given(self, leg: Leg, table: Table) -> tuple[float, int]:
        """:meth:`leg_term` for a parent ``table`` that need not be on the board."""
        p = self.params
        value, corner = delta_table_leg_scalar(
            table.theta,
            table.w,
            table.tau,
            table.corners,
            leg,
            p.sigma_r_leg,
            p.sigma_theta_leg,
            p.sigma_w,
            p.sigma_tau_leg,
        )
        return self._log_box + math.log(p.alpha_L * math.exp(-value) + p.c_L), corner

    def overlapping_legs(self, leg: Leg, exclude: int = NULL) -> int:
        """How many legs on the board overlap ``leg`` (constraint (c), eq. 16)."""
        row = (leg.x, leg.y, leg.theta, 0.5 * leg.wx, 0.5 * leg.wy)
        count = 0
        for key in self.leg_hash_.query(leg.x, leg.y, self._leg_reach):
            if key == exclude:
                continue
            o = self.legs_[key]
            if rectangles_overlap_scalar(row, (o.x, o.y, o.theta, 0.5 * o.wx, 0.5 * o.wy)):
                count += 1
        return count

    def overlapping_tables(self, table: Table, exclude: int = NULL) -> int:
        """How many tables on the board overlap ``table`` (constraint (c), eq. 16)."""
        p = self.params
        half = (0.5 * p.table_length, 0.5 * p.table_width)
        row = (table.x, table.y, table.theta, *half)
        count = 0
        for key in self.table_hash_.query(table.x, table.y, self._table_reach):
            if key == exclude:
                continue
            o = self.tables_[key]
            if rectangles_overlap_scalar(row, (o.x, o.y, o.theta, *half)):
                count += 1
        return count

    def legs_overlap(self, first: int, second: int) -> bool:
        """Whether legs ``first`` and ``second`` overlap (eq. 16)."""
        p, q = self.legs_[first], self.legs_[second]
        return rectangles_overlap_scalar(
            (p.x, p.y, p.theta, 0.5 * p.wx, 0.5 * p.wy), (q.x, q.y, q.theta, 0.5 * q.wx, 0.5 * q.wy)
        )

    def supports(self, leg: int) -> bool:
        """Whether ``leg`` explains some shapelet better than chance, α_S e^{−Δ_LS} ≥ c_S."""
        c_S = self.params.c_S
        return any(v >= c_S for v in self.contrib_[leg])

    def unsupported_children(self, table: int) -> list[int]:
        """Legs of ``table`` that explain no shapelet (they exist only as its consequence)."""
        return [leg for legs in self.children_[table] for leg in legs if not self.supports(leg)]

    def missing(self, table: int) -> int:
        """Number m of corners of ``table`` without a leg (eq. 15)."""
        return sum(1 for legs in self.children_[table] if not legs)

    def shared_corner_pairs(self, table: int) -> int:
        """Pairs of legs sharing a corner of ``table`` (eq. 17)."""
        return sum(len(legs) * (len(legs) - 1) // 2 for legs in self.children_[table])

    # ------------------------------------------------------------------ edits
    def _new_id(self) -> int:
        key = self.next_id_
        self.next_id_ += 1
        return key

    def add_table(self, table: Table) -> int:
        """Put ``table`` on the board (no legs yet); return its id."""
        key = self._new_id()
        self.tables_[key] = table
        self.children_[key] = [[], [], [], []]
        self.table_hash_.insert(key, table.x, table.y)
        return key

    def add_leg(self, leg: Leg, parent: int = NULL) -> int:
        """Put ``leg`` on the board with ``parent`` (a table id or NULL); return its id."""
        key = self._new_id()
        self.legs_[key] = leg
        contrib = self.leg_contributions(leg)
        self.contrib_[key] = contrib
        density = self.shapelet_density_
        for k, v in enumerate(contrib):
            density[k] += v
        self.leg_hash_.insert(key, leg.x, leg.y)
        self.parent_[key] = NULL
        self.corner_[key] = -1
        self.leg_log_term_[key] = self._log_c_L
        if parent != NULL:
            self.set_parent(key, parent)
        return key

    def set_parent(self, leg: int, parent: int) -> None:
        """Make ``parent`` (a table id or NULL) the explicit parent of ``leg``."""
        old = self.parent_[leg]
        if old != NULL:
            self.children_[old][self.corner_[leg]].remove(leg)
        term, corner = self.leg_term(self.legs_[leg], parent)
        self.parent_[leg] = parent
        self.corner_[leg] = corner
        self.leg_log_term_[leg] = term
        if parent != NULL:
            self.children_[parent][corner].append(leg)

    def remove_leg(self, leg: int) -> None:
        """Take ``leg`` off the board."""
        self.set_parent(leg, NULL)
        density = self.shapelet_density_
        for k, v in enumerate(self.contrib_.pop(leg)):
            density[k] = max(density[k] - v, self.params.c_S)
        del self.legs_[leg], self.parent_[leg], self.corner_[leg], self.leg_log_term_[leg]
        self.leg_hash_.remove(leg)

    def remove_table(self, table: int) -> None:
        """Take ``table`` off the board; its legs lose their parent (become null-caused)."""
        for legs in self.children_[table]:
            for leg in list(legs):
                self.set_parent(leg, NULL)
        del self.tables_[table], self.children_[table]
        self.table_hash_.remove(table)

    def candidate_parents(self, leg: Leg, radius: float) -> list[int]:
        """Tables whose centre lies within ``radius`` [m] of ``leg`` (spatial-hash look-up)."""
        return self.table_hash_.query(leg.x, leg.y, radius)

    # ------------------------------------------------------------------ copies and views
    def copy(self) -> Blackboard:
        """An independent copy (hypotheses are immutable and shared)."""
        new = Blackboard.__new__(Blackboard)
        new.params = self.params
        new.tables_ = dict(self.tables_)
        new.legs_ = dict(self.legs_)
        new.parent_ = dict(self.parent_)
        new.corner_ = dict(self.corner_)
        new.children_ = {k: [list(c) for c in v] for k, v in self.children_.items()}
        new.contrib_ = dict(self.contrib_)
        new.leg_log_term_ = dict(self.leg_log_term_)
        new.shapelets_ = self.shapelets_
        new.shapelet_density_ = list(self.shapelet_density_)
        new.next_id_ = self.next_id_
        new.table_hash_ = SpatialHash(self.table_hash_.cell)
        for key, t in new.tables_.items():
            new.table_hash_.insert(key, t.x, t.y)
        new.leg_hash_ = SpatialHash(self.leg_hash_.cell)
        for key, leg in new.legs_.items():
            new.leg_hash_.insert(key, leg.x, leg.y)
        new._log_box = self._log_box
        new._log_c_L = self._log_c_L
        new._table_reach = self._table_reach
        new._leg_reach = self._leg_reach
        return new

    def table_array(self) -> FloatArray:
        """``(k, 5)`` rows ``x, y, theta, w_L, tau`` of the tables, in id order."""
        rows = [t[:5] for t in self.tables_.values()]
        return np.array(rows, dtype=np.float64).reshape(len(rows), 5)

    def leg_array(self) -> FloatArray:
        """``(m, 6)`` rows ``x, y, theta, w_x, w_y, tau`` of the legs, in id order."""
        rows = list(self.legs_.values())
        return np.array(rows, dtype=np.float64).reshape(len(rows), 6)
