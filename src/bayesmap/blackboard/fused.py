"""The fused, persistent table mapper: one posterior over the whole room from every sweep.

Where :class:`~bayesmap.blackboard.TableMapper` (the paper's Algorithm 1) forgets all but
seven contacts and answers each pose on its own, :class:`FusedMapper` keeps every sweep in
an :class:`~bayesmap.blackboard.evidence.EvidenceStore` and runs one reversible-jump chain
(:mod:`~bayesmap.blackboard.rjmcmc`) on the posterior of
:mod:`~bayesmap.blackboard.sweep_model` — contacts, free space, walls, several object
types — across poses. Each :meth:`FusedMapper.step` stores a pose's sweeps and moves the
chain a little inside a window around the robot (data-driven births from the legs seen
there); :meth:`FusedMapper.finish` fits the legs seen anywhere to their contacts, pairs
the fitted legs into table candidates placed on them in closed form (the leaders
polished) and runs the chain over the whole arena: a
tempered burn-in, a stretch at β = 1, then annealing and a greedy ascent through those
candidates (:func:`~bayesmap.blackboard.rjmcmc.greedy_ascent`) only to read off the MAP
map; finally the chain, restarted at the MAP as the coldest replica of a parallel-tempering
ladder (:mod:`~bayesmap.blackboard.tempering`), samples at β = 1 and each MAP object's
existence probability is the fraction of those samples holding it (to the tolerance of the
map's metric, 0.2 m and 15°); the map holds the MAP objects of existence at least 1/2
(:class:`FusedMap`). See docs/blackboard.md.

Examples
--------
>>> import numpy as np
>>> from bayesmap.blackboard.fused import FusedMapper, FusedParams
>>> from bayesmap.blackboard.sweep_model import ObjectType
>>> mapper = FusedMapper((ObjectType("desk", 1.2, 0.8, 0.1),), (6.0, 6.0), FusedParams())
>>> nothing = np.array([[1.0, 0.0, 1.0, np.nan, np.nan, np.nan]])  # swept, touched nothing
>>> for _ in range(3):  # the same view three times: one stored row, counted three times
...     step = mapper.step(np.array([3.0, 3.0, 0.0]), nothing, rng=0)
>>> len(mapper.store_), mapper.store_.counts_.tolist(), step.tables.shape[1]
(1, [3.0], 4)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import binom

from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.blackboard.data_driven import (
    BirthProposal,
    LegVotes,
    fit_to_corner_bearings,
    place_on_legs,
    polish_legs,
    polish_tables,
    table_candidates,
)
from bayesmap.blackboard.evidence import EvidenceStore, check_sweeps
from bayesmap.blackboard.rjmcmc import (
    ChainState,
    Context,
    MoveRates,
    greedy_ascent,
    run,
    visit_frequencies,
)
from bayesmap.blackboard.sweep_model import (
    ObjectType,
    SweepModel,
    arena_contains,
    check_catalogue,
    contact_cutoff,
    contact_squares,
    into_arena,
    leg_contact_density,
)
from bayesmap.blackboard.tempering import geometric_ladder, tempered_run
from bayesmap.errors import ConfigError, InputError

__all__ = ["FusedMap", "FusedMapper", "FusedParams", "FusedStep"]


ONE_LEG_MISSES = 2
"""Missed sweeps (free sectors through a leg's place) that, with one touched leg, keep a
table off the map: one miss happens to a real leg with probability ``p_miss`` (0.05), two
with ``p_miss²``."""

LEG_MISS_POWER = 4
"""A leg of any MAP table is contradicted when its misses, given its touches, are as
unlikely under a real leg as this many misses of an untouched one (``p_miss⁴`` ≈ 6e-6;
binomial tail, :meth:`FusedMapper._contradicted_by_free_space`)."""


@dataclass(frozen=True)
class FusedParams:
    """Constants of the fused mapper (defaults and their reasons: docs/blackboard.md).

    Parameters
    ----------
    sigma_r, sigma_perp, sigma_phi
        Contact noise along the whisker [m], across it [m], of the normal [rad].
    clutter
        κ, density of contacts from no modelled surface [m⁻² rad⁻¹].
    p_miss
        Probability that a whisker sweeps through a leg without reporting it.
    intensity
        λ, prior density of tables of each type [m⁻² rad⁻¹].
    log_overlap
        log ε_c of the paper's overlap factor (eq. 16) per overlapping pair [nats].
    uniform_share
        Share of births drawn uniformly rather than from leg pairs.
    birth_sigma_xy, birth_sigma_theta
        Jitter of a data-driven birth about its candidate [m], [rad].
    min_votes
        Contacts' worth of votes a leg candidate needs.
    spacing_tol
        Tolerance [m] on leg spacings when pairing legs into tables.
    step_moves
        Chain moves per :meth:`FusedMapper.step`.
    burn_in, explore, anneal
        Search moves of :meth:`FusedMapper.finish`: tempered burn-in (β rising from
        ``beta_start`` to 1), a stretch at β = 1, annealing (β from 1 to ``beta_end``).
    samples
        Moves of each replica of the existence chain, started at the MAP; the β = 1
        replica's states (one per move) give the existence probabilities.
    replicas, beta_min, swap_every
        Parallel tempering of that chain (:mod:`~bayesmap.blackboard.tempering`): replicas
        at a geometric ladder of inverse temperatures from 1 down to ``beta_min``, each
        making ``samples`` moves, neighbours exchanging their maps every ``swap_every``
        moves (``replicas = 1``: the β = 1 chain alone).
    beta_start, beta_end
        Inverse temperatures at the start of the burn-in and the end of annealing.
    match_xy, match_theta
        A sample holds a MAP object if it has one of the same type this close [m], [rad]
        (the map metric's tolerances).
    rates
        Move probabilities and random-walk scales.
    reach
        Whisker length [m]: no surface farther than this from a whisker's root explains its
        contact (∞: no bound). Sweeps longer than this are refused.
    """

    sigma_r: float = 0.02
    sigma_perp: float = 0.01
    sigma_phi: float = 0.1
    clutter: float = 0.05
    p_miss: float = 0.05
    intensity: float = 0.02
    log_overlap: float = -math.inf
    uniform_share: float = 0.1
    birth_sigma_xy: float = 0.02
    birth_sigma_theta: float = 0.03
    min_votes: float = 1.5
    spacing_tol: float = 0.06
    step_moves: int = 20
    burn_in: int = 800
    explore: int = 1500
    anneal: int = 500
    samples: int = 750
    replicas: int = 4
    beta_min: float = 0.3
    swap_every: int = 2
    beta_start: float = 0.2
    beta_end: float = 10.0
    match_xy: float = 0.2
    match_theta: float = math.pi / 12
    rates: MoveRates = field(default_factory=MoveRates)
    reach: float = math.inf

    def __post_init__(self) -> None:
        positive = (
            "sigma_r sigma_perp sigma_phi clutter intensity birth_sigma_xy birth_sigma_theta "
            "spacing_tol min_votes beta_start beta_end match_xy match_theta reach"
        )
        for name in positive.split():
            if not getattr(self, name) > 0:
                raise ConfigError(f"FusedParams.{name} must be > 0, got {getattr(self, name)!r}")
        if not self.log_overlap < 0:
            raise ConfigError(f"FusedParams.log_overlap must be < 0, got {self.log_overlap}")
        if not 0 < self.p_miss < 1 or not 0 < self.uniform_share <= 1:
            raise ConfigError("FusedParams: p_miss must lie in (0, 1) and uniform_share in (0, 1]")
        for name in ("step_moves", "burn_in", "explore", "anneal", "samples"):
            if getattr(self, name) < 0:
                raise ConfigError(f"FusedParams.{name} must be >= 0, got {getattr(self, name)}")
        if not self.beta_start <= 1.0 <= self.beta_end:
            raise ConfigError("FusedParams: need beta_start <= 1 <= beta_end")
        if self.replicas < 1 or self.swap_every < 1 or not 0 < self.beta_min <= 1:
            raise ConfigError(
                "FusedParams: need replicas >= 1, swap_every >= 1 and 0 < beta_min <= 1, got "
                f"{self.replicas}, {self.swap_every} and {self.beta_min}"
            )


@dataclass(frozen=True)
class FusedStep:
    """The map after one step: ``tables`` ``(n, 4)`` rows ``x, y, θ, type index``; counters."""

    tables: FloatArray
    info: dict[str, int]


@dataclass(frozen=True)
class FusedMap:
    """The fused map of the whole run.

    Which objects are on the map: the MAP objects (the mode of the posterior, read off by
    annealing and the greedy ascent) whose existence probability is at least 1/2 — the
    median-probability map (Barbieri & Berger 2004: under a per-object 0–1 loss, report
    each object whose posterior probability exceeds 1/2). A MAP object the β = 1 chain
    holds less than half the time — one that fits its few contacts only in a narrow range
    of poses, so the posterior's mass lies mostly without it — is kept apart in
    ``doubtful``, not dropped; so is a MAP table that the free space contradicts: one
    whose contacts' best cause is one of its legs only while whiskers swept through its
    legs' places untouched, or one with a leg that whiskers crossed untouched far more
    often than a real leg is missed (:meth:`FusedMapper._contradicted_by_free_space`: the
    contacts on a box's corner or faces fit legs, and the model has no object for a box;
    docs/blackboard.md). With
    ``samples`` = 0 there are no probabilities and every MAP object is on the map, but for
    those tables.

    Attributes
    ----------
    tables
        ``(n, 4)`` mapped objects ``x, y`` [m], ``θ`` [rad] in [0, π), type index.
    existence
        ``(n,)`` each object's existence probability: the fraction of the states of a β = 1
        chain started at the MAP (the coldest replica of the tempering ladder) that hold an
        object of its type within ``match_xy`` and ``match_theta`` (NaN when ``samples`` is
        0).
    catalogue
        The object types the indices refer to.
    log_posterior
        log π of the MAP (all MAP objects, doubtful ones included; up to the constant of
        the posterior).
    info
        Counters of the final pass.
    doubtful
        ``(d, 4)`` MAP objects of existence probability below 1/2, and MAP tables the free
        space contradicts (:meth:`FusedMapper._contradicted_by_free_space`).
    doubtful_existence
        ``(d,)`` their existence probabilities.
    """

    tables: FloatArray
    existence: FloatArray
    catalogue: tuple[ObjectType, ...]
    log_posterior: float
    info: dict[str, int]
    doubtful: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))
    doubtful_existence: FloatArray = field(default_factory=lambda: np.zeros(0))

    def objects(self, *, doubtful: bool = False) -> list[dict[str, float | str]]:
        """The map (or, with ``doubtful``, the doubtful MAP objects) as records ``type,
        length, width, x, y, theta, existence_probability``."""
        out: list[dict[str, float | str]] = []
        rows, probabilities = (
            (self.doubtful, self.doubtful_existence) if doubtful else (self.tables, self.existence)
        )
        for row, p in zip(rows, probabilities, strict=True):
            kind = self.catalogue[int(row[3])]
            out.append(
                {
                    "type": kind.name,
                    "length": kind.length,
                    "width": kind.width,
                    "leg": kind.leg,
                    "x": float(row[0]),
                    "y": float(row[1]),
                    "theta": float(row[2]),
                    "existence_probability": float(p),
                }
            )
        return out


_SOLID_WEIGHT = math.exp(4.0)
"""Birth weight of a solid object from its own vote grid: that of a table whose four
corners each have a leg peak (:func:`~bayesmap.blackboard.data_driven.table_candidates`,
``exp(support_gain × (4 − 2))``), since one peak pins the whole object."""


SOLID_POLISH_EVALS = 60
"""Nelder–Mead evaluations of each solid candidate's fit (:meth:`FusedMapper._fitted_solids`)."""


def _symmetry(kind: ObjectType) -> float:
    """Rotational symmetry [rad] of a type: π/2 for a square top, π for an oblong one."""
    return 0.5 * math.pi if math.isclose(kind.length, kind.width) else math.pi


def _merge_coincident(tables: FloatArray, weights: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Tables that share a 4 cm, 0.06 rad grid point (and type) as one, the first of each
    group, with their weights summed."""
    if not len(tables):
        return np.zeros((0, 4)), np.zeros(0)
    keys = np.column_stack(
        [np.round(tables[:, :2] / 0.04), np.round(tables[:, 2] / 0.06), tables[:, 3]]
    ).astype(np.int64)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    summed = np.bincount(inverse, weights=weights, minlength=len(unique)).astype(np.float64)
    first = np.zeros(len(unique), dtype=np.int64)
    first[inverse[::-1]] = np.arange(len(inverse))[::-1]
    return tables[first], summed


def _suppress_duplicates(
    tables: FloatArray,
    weights: FloatArray,
    scores: FloatArray,
    xy: float,
    theta: float,
    periods: FloatArray,
) -> tuple[IntArray, FloatArray]:
    """Non-maximum suppression: in order of ``scores``, each table (n, 4) keeps every
    table of its type within ``xy`` [m] and ``theta`` [rad] (modulo its type's symmetry
    ``periods`` (n,)) out of the set and takes their weights. Returns the indices of the
    tables kept and their summed weights."""
    order = np.argsort(-scores, kind="stable")
    taken = np.zeros(len(tables), dtype=bool)
    keep: list[int] = []
    summed: list[float] = []
    for i in order:
        if taken[i]:
            continue
        turn = np.mod(tables[:, 2] - tables[i, 2], periods[i])
        close = (
            (np.hypot(tables[:, 0] - tables[i, 0], tables[:, 1] - tables[i, 1]) <= xy)
            & (np.minimum(turn, periods[i] - turn) <= theta)
            & (tables[:, 3] == tables[i, 3])
            & ~taken
        )
        close[i] = True
        taken |= close
        keep.append(int(i))
        summed.append(float(weights[close].sum()))
    return np.asarray(keep, dtype=np.int64), np.asarray(summed)


class FusedMapper:
    """One persistent posterior over the tables of a room, from every whisker sweep.

    Parameters
    ----------
    catalogue
        The object types the room may hold (at least one).
    arena
        ``(width, height)`` [m] of the walled arena (corner at the origin): walls explain
        contacts, and no table may cross one.
    params
        The constants.

    Attributes
    ----------
    store_
        Every sweep so far.
    state_
        The chain's current map and caches.
    """

    def __init__(
        self,
        catalogue: tuple[ObjectType, ...],
        arena: tuple[float, float],
        params: FusedParams = FusedParams(),
    ) -> None:
        if not (len(arena) == 2 and min(arena) > 0 and all(math.isfinite(v) for v in arena)):
            raise ConfigError(f"arena must be (width, height) > 0 [m], got {arena!r}")
        self.arena = (float(arena[0]), float(arena[1]))
        self.catalogue = check_catalogue(tuple(catalogue), self.arena)
        self.params = params
        self.model = SweepModel(
            params.sigma_r,
            params.sigma_perp,
            params.sigma_phi,
            params.clutter,
            params.p_miss,
            params.intensity,
            params.log_overlap,
            self.arena,
            params.reach,
        )
        self.store_ = EvidenceStore(cell=1.0)
        self.state_ = ChainState()
        self._ctx = Context(self.catalogue, self.model, self.store_)
        legged = [t.leg for t in self.catalogue if not t.solid]
        self._leg_half = 0.5 * min(legged or [t.leg for t in self.catalogue])
        """Half the side of the legs the leg detector looks for: the thinnest of the types
        with legs (solid types have their own grids)."""
        self._votes = LegVotes(self.arena, params.sigma_r, self._leg_half, params.reach)
        self._solid_votes = [
            (k, LegVotes(self.arena, params.sigma_r, kind.contact_half_side, params.reach))
            for k, kind in enumerate(self.catalogue)
            if kind.solid and params.sigma_r < 0.5 * kind.length
        ]
        """One vote grid per solid type (box or pillar), over its centre: see
        :meth:`_solid_candidates`. Only where the range noise is below half the object's
        side: votes spread 3 σ_r along each whisker then peak at the centre, while in the
        noisy condition (σ_r = 0.5 m) they form ridges whose peaks fall anywhere near the
        object: on three rooms of desks, boxes and pillars the precision was 0.48 and 0.52
        with such candidates (two variants of the model) against 0.60 and 0.66 without
        (docs/blackboard.md). Without a grid a solid type is paired from leg peaks as a
        table is."""
        self._paired: tuple[bytes, FloatArray, FloatArray] = (b"", np.zeros((0, 4)), np.zeros(0))
        """The last leg positions paired into tables and the tables with their weights:
        consecutive poses at one place often find the same legs (a third of the steps of the
        shipped noisy tour)."""

    def _polished(
        self, tables: FloatArray, weights: FloatArray, legs: FloatArray, solids: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Candidates built from the fitted ``legs`` (p, 3), each placed on its legs in
        closed form, joined by the ``solids`` (:meth:`_solid_candidates`, weight
        ``exp(2 support_gain)``, already centred by their own vote grid), thinned, and the
        few that lead their neighbourhood polished against their stored contacts.

        1. *Placement.* A candidate rests on the two to four fitted legs within
           ``spacing_tol`` of its corners; its pose is the rigid least-squares fit of those
           corners onto those legs (:func:`~bayesmap.blackboard.data_driven.place_on_legs`,
           Kabsch/Procrustes in closed form), moved inside the arena. The legs were fitted
           to the exact bearings (:meth:`_fitted_legs`), so this is where a polish against
           the contacts would take the candidate, to within a centimetre and about 0.01 rad.
        2. *Scoring, once.* Each placed candidate's log π gain over an empty room
           (:meth:`~bayesmap.blackboard.rjmcmc.Context.gain_alone`). A candidate whose gain
           is not positive can never be a MAP table (with other tables present its gain is
           no larger: each contact takes its best cause) and is dropped: the noisy
           condition's hundreds of crossings of bearings that fit no table.
        3. *Thinning* (non-maximum suppression): candidates of a type within half the map's
           tolerance (``match_xy``/2, ``match_theta``/2) of one of larger gain describe the
           same table (two such tables could not both stand: they overlap); the better one
           keeps their summed weight.
        4. *Polish of the leaders.* The candidate of largest gain within the map's whole
           tolerance of each place — the ones that compete for the map — gets one short
           Nelder–Mead round against its contacts
           (:func:`~bayesmap.blackboard.data_driven.polish_tables` at the model's noise
           scales, 12 evaluations from the placed start, contacts whose whisker line passes
           within 15 cm of a leg): the centimetre and the hundredth of a radian that legs
           fitted one by one leave, worth several nats on a well-seen table. The others
           stay where they were placed (the chain's births jitter about them, and its
           random walk refines what it keeps).

        Candidates that land on the same 4 cm, 0.06 rad grid point are merged (weights
        summed) before placement and after each move. The result depends on the stored
        data alone, never on the chain, as a proposal must. Used by :meth:`finish`.
        """
        if not len(tables) + len(solids):
            return tables, weights
        ctx, p = self._ctx, self.params
        tables, summed = _merge_coincident(tables, weights)
        # solids first: where a pair of legs lands on the same grid point, the solid's own
        # fit is the one kept (_merge_coincident keeps the first)
        placed = np.concatenate(
            [solids, place_on_legs(tables, legs, self.catalogue, p.spacing_tol)]
        )
        summed = np.concatenate([np.full(len(solids), _SOLID_WEIGHT), summed])
        tables, summed = _merge_coincident(
            into_arena(placed, self.catalogue, self.arena)[0], summed
        )
        ctx.prime(tables)
        gains = np.array([ctx.gain_alone(table) for table in tables])
        pays = gains > 0
        tables, summed, gains = tables[pays], summed[pays], gains[pays]
        periods = np.array([_symmetry(self.catalogue[int(k)]) for k in tables[:, 3]])
        keep, summed = _suppress_duplicates(
            tables, summed, gains, 0.5 * p.match_xy, 0.5 * p.match_theta, periods
        )
        tables, gains, periods = tables[keep], gains[keep], periods[keep]
        leaders, _ = _suppress_duplicates(
            tables, np.zeros(len(tables)), gains, p.match_xy, p.match_theta, periods
        )
        out = tables.copy()
        out[leaders] = self._polish_on_contacts(tables[leaders], 12)[0]
        return _merge_coincident(out, summed)

    def _fitted_legs(self, legs: FloatArray) -> FloatArray:
        """Leg candidates ``(p, 3)`` ``x, y, votes`` each moved by
        :func:`~bayesmap.blackboard.data_driven.polish_leg` against its stored contacts
        (started at the angle of its contacts' normals, their circular mean modulo π/2),
        and those that land in the same 1 cm cell merged, their votes summed.

        The leg-level fit: a vote peak sits a few centimetres off its leg (2.5 cm cells;
        with σ_r = 0.5 m the votes are ridges along the bearings), and a table built from
        two such legs is off by as much and by degrees. Fitting each leg once against the
        bearings that pass it, then pairing fitted legs, costs one small fit per leg where
        polishing from raw peaks needed a widened basin and twice the evaluations per table
        candidate — and there are many times more candidates than legs."""
        if not len(legs):
            return legs
        ctx, store = self._ctx, self.store_
        half = self._leg_half
        radius = contact_cutoff(half, self.model) + 0.1
        out = legs.copy()
        ids = [store.contacts_near(x, y, radius) for x, y, _ in legs]
        seen = [row for row, found in enumerate(ids) if len(found)]
        starts = [
            (
                legs[row, 0],
                legs[row, 1],
                0.25
                * float(np.angle(np.exp(4j * store.rows_[ids[row], 6]) @ store.counts_[ids[row]])),
            )
            for row in seen
        ]
        if seen:
            out[seen, :2] = polish_legs(
                np.array(starts),
                [store.rows_[ids[row]][:, [0, 1, 3, 5, 6]] for row in seen],
                [store.counts_[ids[row]] for row in seen],
                [ctx.floor[ids[row]] for row in seen],
                half,
                self.model,
            )[:, :2]
        keys = np.round(out[:, :2] / 0.01).astype(np.int64)
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        votes = np.bincount(inverse.reshape(-1), weights=out[:, 2])
        return np.column_stack([out[first, :2], votes])

    def _polish_on_contacts(
        self, tables: FloatArray, max_evals: int
    ) -> tuple[FloatArray, list[IntArray]]:
        """``tables`` (c, 4) each polished against the stored contacts near it
        (:func:`~bayesmap.blackboard.data_driven.polish_tables` at the model's noise scales,
        ``max_evals`` evaluations, the contacts whose whisker line passes within 15 cm of a
        leg), and those contacts' indices."""
        ctx, store = self._ctx, self.store_
        ids = [store.contacts_near(x, y, ctx.contact_radius + 0.1) for x, y in tables[:, :2]]
        polished = polish_tables(
            tables,
            [store.rows_[found][:, [0, 1, 3, 5, 6]] for found in ids],
            [store.counts_[found] for found in ids],
            [ctx.floor[found] for found in ids],
            self.catalogue,
            self.model,
            widen=(1.0,),
            max_evals=max_evals,
            line_gap=0.15,
        )
        return polished, ids

    def _fitted_solids(self, solids: FloatArray) -> FloatArray:
        """Each solid candidate ``(c, 4)`` fitted to its stored contacts, position and
        angle, twice, the fit of larger gain alone kept: polished against them
        (:meth:`_polish_on_contacts`, :data:`SOLID_POLISH_EVALS` evaluations), then moved
        onto its corners' bearings
        (:func:`~bayesmap.blackboard.data_driven.fit_to_corner_bearings`). A box's contacts
        pin it far more sharply than the vote grid's 2.5 cm cells and its normals' mean
        angle: on a 0.5 m box in the normal condition a peak 6 mm and 0.005 rad off fitted
        its contacts 300 nats worse than the truth, and the polish alone did not close
        that."""
        if not len(solids):
            return solids
        ctx, store = self._ctx, self.store_
        polished, ids = self._polish_on_contacts(solids, SOLID_POLISH_EVALS)
        fitted = np.array(
            [
                fit_to_corner_bearings(
                    solid,
                    store.rows_[found][:, [0, 1, 3, 5, 4]],
                    store.counts_[found],
                    self.catalogue[int(solid[3])].contact_half_side,
                    self.model.sigma_r,
                )
                for solid, found in zip(polished, ids, strict=True)
            ]
        ).reshape(-1, 4)
        fitted = into_arena(fitted, self.catalogue, self.arena)[0]
        ctx.prime(np.vstack([polished, fitted]))
        better = np.array(
            [ctx.gain_alone(f) > ctx.gain_alone(p) for f, p in zip(fitted, polished, strict=True)]
        )
        return np.where(better[:, None], fitted, polished)

    def _solid_candidates(self, box: tuple[float, float, float, float]) -> FloatArray:
        """``(c, 4)`` solid objects (boxes, pillars: ``ObjectType.solid``) centred on the peaks of
        their type's own vote grid in ``box``.

        Pairs of leg peaks place a solid object badly: each face votes for leg centres all
        along a ridge behind it, so pairs at the type's leg spacing fall anywhere on it, and
        the chain is offered boxes half a side off, side by side across the true one. A
        solid square of side s is one leg of side s, and :class:`LegVotes` with h = s/2
        votes, from the same contacts and the same whisking geometry, for its centre: a
        corner contact at P + (s/2)(−n̂ + t̂), a tip contact s/2 behind the face. Each
        peak's angle is the circular mean of its contacts' normals modulo π/2 (4φ̂,
        weighted by count) within its circumradius and 5 cm.
        """
        found = [np.zeros((0, 4))]
        for k, votes in self._solid_votes:
            kind = self.catalogue[k]
            peaks = votes.peaks(box, self.params.min_votes)
            radius = kind.length / math.sqrt(2.0) + 0.05
            for x, y, _ in peaks:
                ids = self.store_.contacts_near(x, y, radius)
                if not len(ids):
                    continue
                phase = np.exp(4j * self.store_.rows_[ids, 6]) @ self.store_.counts_[ids]
                theta = (0.25 * float(np.angle(phase))) % (0.5 * math.pi)
                found.append(np.array([[x, y, theta, k]]))
        return np.concatenate(found)

    def _proposal(
        self, box: tuple[float, float, float, float], *, polish: bool = False
    ) -> BirthProposal:
        """The birth mixture of ``box``: tables from pairs of the vote grid's leg peaks
        (``polish``: of fitted legs, and the tables polished, :meth:`_polished`), and solid
        objects from their own grids' peaks (:meth:`_solid_candidates`)."""
        grow = self._ctx.half_diagonal + self.params.spacing_tol
        grown = (box[0] - grow, box[1] - grow, box[2] + grow, box[3] + grow)
        legs = self._votes.peaks(grown, self.params.min_votes)
        solids = self._solid_candidates(grown)
        if polish:
            legs = self._fitted_legs(legs)
            solids = self._fitted_solids(solids)
        key = legs[:, :2].tobytes()
        if key != self._paired[0]:
            paired = table_candidates(
                legs,
                self.catalogue,
                self.arena,
                self.params.spacing_tol,
                unpaired=frozenset(k for k, _ in self._solid_votes),
            )
            self._paired = (key, *paired)
        tables, weights = self._paired[1:]
        if polish:
            tables, weights = self._polished(tables, weights, legs, solids)
        elif len(solids):
            solids = into_arena(solids, self.catalogue, self.arena)[0]
            tables = np.concatenate([tables, solids])
            weights = np.concatenate([weights, np.full(len(solids), _SOLID_WEIGHT)])
        keep = (
            (tables[:, 0] >= box[0])
            & (tables[:, 0] <= box[2])
            & (tables[:, 1] >= box[1])
            & (tables[:, 1] <= box[3])
            & arena_contains(tables, self.catalogue, self.arena)
        )
        p = self.params
        return BirthProposal(
            box,
            tables[keep],
            weights[keep],
            len(self.catalogue),
            p.uniform_share,
            p.birth_sigma_xy,
            p.birth_sigma_theta,
        )

    def step(self, pose: FloatArray, sweeps: FloatArray, *, rng: RNGLike = None) -> FusedStep:
        """Store one pose's sweeps and move the chain around the robot.

        Parameters
        ----------
        pose
            ``(3,)`` robot pose ``x, y`` [m], heading [rad]: every whisker's root.
        sweeps
            ``(w, 6)`` one row per whisker sweep (columns
            :data:`~bayesmap.blackboard.evidence.SWEEP_FIELDS`), contact or not.
        rng
            Seed or generator of the chain.
        """
        generator = as_generator(rng)
        pose, sweeps = check_sweeps(pose, sweeps)
        if (sweeps[:, 2] > self.params.reach).any():
            row = int(np.flatnonzero(sweeps[:, 2] > self.params.reach)[0])
            raise InputError(
                f"sweeps row {row}: length {sweeps[row, 2]} m exceeds the model's whisker "
                f"reach {self.params.reach} m (FusedParams.reach)"
            )
        ids = self.store_.add(pose, sweeps)
        hit = np.isfinite(sweeps[:, 3])
        if hit.any():
            contacts = sweeps[hit]
            roots = np.tile(pose[:2], (len(contacts), 1))
            counts = np.ones(len(contacts))
            for votes in (self._votes, *(grid for _, grid in self._solid_votes)):
                votes.add(
                    roots, contacts[:, 1], contacts[:, 3], counts, contacts[:, 0], contacts[:, 4]
                )
        self._ctx.update_near(self.state_, ids, float(pose[0]), float(pose[1]))
        reach = self._ctx.reach + self._ctx.half_diagonal
        box = (
            max(0.0, pose[0] - reach),
            max(0.0, pose[1] - reach),
            min(self.arena[0], pose[0] + reach),
            min(self.arena[1], pose[1] + reach),
        )
        betas = np.ones(self.params.step_moves)
        _, _, _, info = run(
            generator, self.state_, self._ctx, self._proposal(box), self.params.rates, betas
        )
        return FusedStep(self.state_.tables.copy(), info)

    def finish(self, *, rng: RNGLike = None) -> FusedMap:
        """Run the chain over the whole arena and return the fused map (MAP + existence)."""
        generator = as_generator(rng)
        p = self.params
        self._ctx.refresh(self.state_)
        proposal = self._proposal((0.0, 0.0, *self.arena), polish=True)
        betas = np.concatenate(
            [
                np.geomspace(p.beta_start, 1.0, p.burn_in) if p.burn_in else np.zeros(0),
                np.ones(p.explore),
                np.geomspace(1.0, p.beta_end, p.anneal) if p.anneal else np.zeros(0),
            ]
        )
        best, _, _, info = run(generator, self.state_, self._ctx, proposal, p.rates, betas)
        self.state_.tables = best
        self._ctx.refresh(self.state_)
        order = np.argsort(-proposal.weights, kind="stable")
        info |= greedy_ascent(self.state_, self._ctx, proposal.candidates[order])
        best, best_log_pi = self.state_.tables.copy(), self.state_.log_pi
        start = ChainState(best.copy(), self.state_.free_space.copy(), best_log_pi)
        existence, visits = self._existence(start, proposal, generator)
        info |= visits
        doubtful = existence < 0.5  # NaN (no samples) compares False: kept
        doubtful |= self._contradicted_by_free_space(best)
        return FusedMap(
            best[~doubtful],
            existence[~doubtful],
            self.catalogue,
            best_log_pi,
            info,
            best[doubtful],
            existence[doubtful],
        )

    def _contradicted_by_free_space(self, tables: FloatArray) -> BoolArray:
        """``(n,)`` whether the free space contradicts each of ``tables`` (n, 4), by either
        of two tests on its legs' touches and misses (:meth:`_leg_evidence`).

        *One touched leg*: the contacts' best cause is one leg of the table only, and
        whiskers swept through its legs' places untouched at least :data:`ONE_LEG_MISSES`
        times. One leg's contacts fit a box's corner or a pillar as well, and the model
        has no object for those. A table touched on one leg whose other legs no whisker
        reached is not contradicted (a sparse tour passing one side of a real table).

        *A leg that is not there*: some leg's misses ``m``, given its touches ``t``, lie in
        the binomial tail P(M ≥ m | t + m sweeps crossed it, p_miss) ≤ p_miss ^
        :data:`LEG_MISS_POWER`. Each sweep across a real leg touches it with probability
        1 − p_miss; a table laid over the faces of a box (the model's only explanation for
        a dense cluster of contacts) has legs that whiskers cross untouched again and again.

        A solid type is one object, whatever face was touched, and passes the first test.
        """
        touches, misses = self._leg_evidence(tables)
        solid = np.array([self.catalogue[int(t[3])].solid for t in tables], dtype=bool)
        touched = (touches > 0).sum(axis=1)
        one_leg = ~solid & (touched < 2) & (misses.sum(axis=1) >= ONE_LEG_MISSES)
        p_miss = self.params.p_miss
        tail = binom.sf(misses - 1.0, touches + misses, p_miss)
        absent = (misses > 0) & (tail <= p_miss**LEG_MISS_POWER)
        contradicted: BoolArray = one_leg | absent.any(axis=1)
        return contradicted

    def _leg_evidence(self, tables: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(n, 4)`` touches and ``(n, 4)`` misses of each leg of ``tables`` (n, 4).

        A leg's touches are the stored contacts (with their multiplicities) whose best cause,
        among the walls, clutter and every leg of ``tables``, is that leg; its misses are
        the stored sweeps whose free sector holds its place (term F3's count)."""
        ctx = self._ctx
        touches = np.zeros((len(tables), 4))
        misses = np.zeros((len(tables), 4))
        if not len(tables):
            return touches, misses
        near = [np.sort(ctx.store.contacts_near(t[0], t[1], ctx.contact_radius)) for t in tables]
        ids = np.unique(np.concatenate(near))
        best = ctx.floor[ids].copy()
        densities = []
        for table, own in zip(tables, near, strict=True):
            rows = ctx.store.rows_[own]
            legs = contact_squares(table, self.catalogue)[0]
            density = leg_contact_density(
                rows[:, :2],
                rows[:, 3],
                rows[:, 5],
                rows[:, 6],
                legs,
                np.full(4, table[2]),
                ctx.model,
            )
            at = np.searchsorted(ids, own)
            np.maximum.at(best, at, density.max(axis=1) if len(own) else np.zeros(0))
            densities.append((own, at, density))
        for n, (table, (own, at, density)) in enumerate(zip(tables, densities, strict=True)):
            cause = (density > 0) & (density >= best[at][:, None])
            touches[n] = ctx.store.counts_[own] @ cause
            misses[n] = ctx.leg_misses(table)
        return touches, misses

    def existence(self, tables: FloatArray, *, rng: RNGLike = None) -> FloatArray:
        """Existence probabilities ``(n,)`` of the objects ``tables`` (n, 4) ``x, y, θ, k``
        on the evidence stored so far (see :meth:`_existence`); the mapper's own chain is
        left as it was."""
        start = ChainState(np.asarray(tables, dtype=np.float64).reshape(-1, 4).copy())
        self._ctx.refresh(start)
        proposal = self._proposal((0.0, 0.0, *self.arena), polish=True)
        return self._existence(start, proposal, as_generator(rng))[0]

    def _existence(
        self, start: ChainState, proposal: BirthProposal, generator: np.random.Generator
    ) -> tuple[FloatArray, dict[str, int]]:
        """Visit frequencies of the objects of ``start`` in a β = 1 chain started there.

        The chain runs ``samples`` moves on the untempered posterior and every state it
        visits is a sample; an object's existence probability is the fraction of samples
        holding one of its type within ``match_xy`` and ``match_theta``. Its births draw
        from ``proposal``'s candidates *and* the start's objects (the proposal is fixed
        before the chain starts, so it is a valid Metropolis–Hastings proposal): an object
        the data support weakly dies and is born again at the rate its posterior odds
        allow, which the search's candidates alone (pairs of legs) could not offer for an
        object seen by one leg. With ``replicas`` > 1 the β = 1 chain is the coldest of a
        parallel-tempering ladder (:func:`~bayesmap.blackboard.tempering.tempered_run`),
        every replica started at ``start``: hotter replicas cross the barriers between
        layouts that the β = 1 chain alone would not, and exchanges bring what they find
        down to β = 1. Returns the probabilities and the counters (the β = 1 chain's moves
        prefixed ``sampling_``, the exchanges ``tempering_``).
        """
        p = self.params
        weight = float(proposal.weights.mean()) if len(proposal.weights) else 1.0
        births = proposal._replace(
            candidates=np.vstack([proposal.candidates.reshape(-1, 4), start.tables]),
            weights=np.concatenate([proposal.weights, np.full(len(start.tables), weight)]),
        )
        reference = start.tables.copy()
        betas = geometric_ladder(p.replicas, p.beta_min)
        states = [start] + [
            ChainState(start.tables.copy(), start.free_space.copy(), start.log_pi)
            for _ in betas[1:]
        ]
        samples, visits = tempered_run(
            generator,
            states,
            self._ctx,
            births,
            p.rates,
            betas,
            moves=p.samples,
            every=p.swap_every,
        )
        periods = np.array([_symmetry(self.catalogue[int(k)]) for k in reference[:, 3]])
        existence = visit_frequencies(samples, reference, p.match_xy, p.match_theta, periods)
        return existence, {
            (f"tempering_{key}" if key.startswith("swaps_") else f"sampling_{key}"): value
            for key, value in visits.items()
        }
