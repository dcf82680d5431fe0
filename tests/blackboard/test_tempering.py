"""Parallel tempering of the fused mapper's chain: exchanges against the joint, caches that
travel with their maps, mixing between two separated modes of known odds, reproducibility."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayesmap.blackboard import tempering
from bayesmap.blackboard.data_driven import BirthProposal
from bayesmap.blackboard.evidence import EvidenceStore
from bayesmap.blackboard.fused import FusedParams
from bayesmap.blackboard.rjmcmc import ChainState, Context, MoveRates, holding, run
from bayesmap.blackboard.sweep_model import ObjectType, SweepModel, arena_contains, log_posterior
from bayesmap.blackboard.tempering import (
    exchange,
    geometric_ladder,
    swap_log_ratio,
    tempered_run,
)
from bayesmap.errors import ConfigError
from bayesmap.sim.tables_world import build_mixed
from bayesmap.sim.whiskers import WhiskerParams, observe

DESK = ObjectType("desk", 1.2, 0.8, 0.1)
STOOL = ObjectType("stool", 0.8, 0.8, 0.08)


def _joint(ctx: Context, tables: np.ndarray) -> float:
    return log_posterior(tables, ctx.catalogue, ctx.model, ctx.store.rows_, ctx.store.counts_)


def _room() -> tuple[Context, BirthProposal]:
    """A desk and a stool in a 5 × 4 m room, seen from 20 poses; births near both."""
    arena = (5.0, 4.0)
    truth = np.array([[1.6, 1.5, 0.3, 0.0], [3.5, 2.4, 1.1, 1.0]])
    world = build_mixed(
        truth[:, :3], np.array([[1.2, 0.8, 0.1], [0.8, 0.8, 0.08]]), np.full(2, 0.3), arena
    )
    rng = np.random.default_rng(0)
    store = EvidenceStore()
    for x in np.linspace(0.4, 4.6, 5):
        for y in (0.4, 3.6):
            for heading in (0.0, 0.5 * math.pi):
                pose = np.array([x, y, heading])
                store.add(pose, observe(world, pose, WhiskerParams(), rng=rng).sweeps)
    model = SweepModel(0.02, 0.01, 0.1, 0.05, 0.05, 0.02, -12.0, arena)
    ctx = Context((DESK, STOOL), model, store)
    birth = BirthProposal((0.0, 0.0, *arena), truth, np.ones(2), 2, 0.3, 0.05, 0.05)
    return ctx, birth


def _replicas(ctx: Context, betas: np.ndarray, tables: np.ndarray) -> list[ChainState]:
    states = [ChainState(tables.copy()) for _ in betas]
    for state in states:
        ctx.refresh(state)
    return states


def _stale(ctx: Context, state: ChainState) -> bool:
    """Whether ``state``'s cached free-space terms or log π differ from a fresh computation."""
    fresh = ChainState(state.tables.copy())
    ctx.refresh(fresh)
    return not (
        np.allclose(state.free_space, fresh.free_space, atol=1e-6)
        and math.isclose(state.log_pi, fresh.log_pi, abs_tol=1e-6)
    )


def test_the_ladder_is_geometric_from_one() -> None:
    betas = geometric_ladder(4, 0.125)
    assert betas.tolist() == pytest.approx([1.0, 0.5, 0.25, 0.125])
    assert geometric_ladder(1, 0.3).tolist() == [1.0]
    with pytest.raises(ConfigError, match="beta_min"):
        geometric_ladder(3, 0.0)


def test_exchange_ratio_and_acceptance_match_the_full_joint() -> None:
    """On random maps reached by tempered chains, the exchange's log ratio (from the states'
    tracked log π) equals log[π^β_i(X_j) π^β_j(X_i) / (π^β_i(X_i) π^β_j(X_j))] computed from
    scratch, and exchanges are accepted at min(1, exp(that)) (binomial tolerance, 4 σ)."""
    ctx, birth = _room()
    rates = MoveRates(step_xy=(0.02, 0.2), step_theta=(0.05, 0.3))
    rng = np.random.default_rng(11)
    betas = geometric_ladder(4, 0.05)
    checked = 0
    for trial in range(4):
        states = _replicas(ctx, betas, np.zeros((0, 4)))
        tempered_run(rng, states, ctx, birth, rates, betas, moves=30 + 20 * trial, every=5)
        for i in range(len(betas) - 1):
            j = i + 1
            xi, xj = states[i].tables, states[j].tables
            direct = (
                betas[i] * _joint(ctx, xj)
                + betas[j] * _joint(ctx, xi)
                - betas[i] * _joint(ctx, xi)
                - betas[j] * _joint(ctx, xj)
            )
            ratio = swap_log_ratio(betas[i], betas[j], states[i].log_pi, states[j].log_pi)
            assert ratio == pytest.approx(direct, abs=1e-6)
            pair = [states[i], states[j]]
            n = 300
            swapped = sum(exchange(rng, list(pair), betas[i : j + 1], 0)[0] for _ in range(n))
            p = min(1.0, math.exp(direct))
            assert abs(swapped / n - p) <= 4 * math.sqrt(p * (1 - p) / n) + 1e-9
            checked += int(0 < p < 1)
    assert checked >= 2  # some exchanges were neither certain nor impossible


def test_a_swap_carries_each_maps_cached_terms_with_it() -> None:
    """After tempered runs with hundreds of exchanges, every replica's cached free-space terms
    and log π are those of its own map. The check is not vacuous: an exchange that swapped
    the tables and their free-space terms but left log π behind (each replica then holds
    another map's log π) fails it."""
    ctx, birth = _room()
    rates = MoveRates(step_xy=(0.02, 0.2), step_theta=(0.05, 0.3))
    betas = geometric_ladder(4, 0.05)
    states = _replicas(ctx, betas, np.zeros((0, 4)))
    _, info = tempered_run(
        np.random.default_rng(2), states, ctx, birth, rates, betas, moves=150, every=3
    )
    assert sum(info[f"swaps_accepted_{r}"] for r in range(3)) > 10
    assert not any(_stale(ctx, state) for state in states)

    def log_pi_left_behind(
        rng: np.random.Generator, states: list[ChainState], betas: np.ndarray, first: int
    ) -> dict[int, bool]:
        swapped = {}
        for i in range(first, len(states) - 1, 2):
            a, b = states[i], states[i + 1]
            a.tables, b.tables = b.tables, a.tables
            a.free_space, b.free_space = b.free_space, a.free_space
            swapped[i] = True
        return swapped

    patch = pytest.MonkeyPatch()
    patch.setattr(tempering, "exchange", log_pi_left_behind)
    try:
        states = _replicas(ctx, betas, np.zeros((0, 4)))
        tempered_run(np.random.default_rng(2), states, ctx, birth, rates, betas, moves=60, every=3)
    finally:
        patch.undo()
    assert any(_stale(ctx, state) for state in states)


def _two_modes() -> tuple[Context, BirthProposal, np.ndarray, np.ndarray, float]:
    """A desk whose two contacted legs lie on the line y = 2 (the paper's Fig. 3 ambiguity):
    placement A stands above the line, B (its mirror image) below. The contacts and their
    whiskers are symmetric about the line, so the posterior near B is the posterior near A
    reflected, except for one whisker that swept through A's two far legs and touched
    nothing: each costs p_miss. The odds A : B are exactly p_miss², P(A | A or B) =
    p²/(1 + p²) (the empty room is e⁻¹⁴ as likely; a small λ makes extra tables elsewhere,
    which could favour one side through overlaps, negligible).
    """
    arena = (4.0, 4.0)
    p_miss = 0.5
    model = SweepModel(0.02, 0.01, 0.1, 0.05, p_miss, 1e-3, -math.inf, arena)
    store = EvidenceStore()
    # zero-extent sweeps along the line itself, onto the legs' outer faces (normals along it)
    store.add(np.array([1.0, 2.0, 0.0]), np.array([[0.0, 0.0, 0.6, 0.4, math.pi, 0.3]]))
    store.add(np.array([3.0, 2.0, math.pi]), np.array([[math.pi, math.pi, 0.6, 0.4, 0.0, 0.3]]))
    # a whisker above the line sweeps through A's far legs and touches nothing
    down = -0.5 * math.pi
    nothing = np.array([[down - 1.2, down + 1.2, 1.0, np.nan, np.nan, np.nan]])
    store.add(np.array([2.0, 3.3, down]), nothing)
    ctx = Context((DESK,), model, store)
    a, b = DESK.half_spacing
    del a
    above, below = np.array([2.0, 2.0 + b, 0.0, 0.0]), np.array([2.0, 2.0 - b, 0.0, 0.0])
    birth = BirthProposal(
        (0.0, 0.0, *arena), np.vstack([above, below]), np.ones(2), 1, 0.1, 0.02, 0.03
    )
    return ctx, birth, above, below, p_miss**2 / (1 + p_miss**2)


_NO_JUMPS = MoveRates(
    birth=0.3, death=0.3, refine=0.4, mirror=0, corner=0, type=0, switch=0, split=0, merge=0
)
"""Births, deaths and random walks only: the moves that map A onto B in one step (mirror,
switch) are off, so the two placements are separated as two layouts no single move links."""


def test_the_two_modes_differ_by_the_free_space_factor_alone() -> None:
    """The premise of the odds: log π(B') − log π(A') = −2 log p_miss for A' near A and B' its
    mirror image, for random perturbations."""
    ctx, _, above, below, _ = _two_modes()
    rng = np.random.default_rng(0)
    for _ in range(20):
        d = rng.normal(0.0, [0.02, 0.02, 0.03])
        a, b = above.copy(), below.copy()
        a[:3] += d
        b[0] += d[0]
        b[1] -= d[1]
        b[2] -= d[2]
        a[2] %= math.pi
        b[2] %= math.pi
        gap = _joint(ctx, a[None]) - _joint(ctx, b[None])
        assert gap == pytest.approx(2 * math.log(ctx.model.p_miss), abs=1e-9)


def _visits(samples: list[np.ndarray], table: np.ndarray) -> float:
    period = np.array([math.pi])
    return float(np.mean([holding(s, table[None], 0.2, math.pi / 12, period)[0] for s in samples]))


def test_the_beta_one_chain_alone_stays_in_the_mode_it_starts_in() -> None:
    """Started at A, the untempered chain never reaches B: leaving A costs its death (14 nats
    at β = 1), and B overlaps A so it cannot be born beside it."""
    ctx, birth, above, below, _ = _two_modes()
    state = ChainState(above[None].copy())
    ctx.refresh(state)
    _, _, samples, _ = run(
        np.random.default_rng(1), state, ctx, birth, _NO_JUMPS, np.ones(800), record_every=1
    )
    assert _visits(samples, below) == 0.0
    assert _visits(samples, above) > 0.99  # at most a death and rebirth of A in place


@pytest.mark.slow
def test_tempered_visits_match_the_exact_odds_of_two_separated_modes() -> None:
    """From A, the mapper's default ladder (4 replicas, β down to 0.3) reaches B, and the
    β = 1 replica's visit frequency of A, pooled over three seeds (2,500 moves per replica
    each, the first 500 dropped), matches the exact P(A) = p²/(1 + p²) = 0.2 within 0.08.

    The tolerance is about three times the spread of such pooled estimates: five single runs
    of 3,000 moves (seeds 0–4) read 0.14–0.24, mean 0.17, their 500-move blocks 0.03–0.56;
    the β = 1 chain changes mode only when exchanges bring the other placement down the
    ladder, so its samples are strongly correlated.
    """
    ctx, birth, above, below, exact = _two_modes()
    params = FusedParams()
    betas = geometric_ladder(params.replicas, params.beta_min)
    kept: list[np.ndarray] = []
    for seed in range(3):
        states = _replicas(ctx, betas, above[None])
        samples, info = tempered_run(
            np.random.default_rng(seed), states, ctx, birth, _NO_JUMPS, betas, moves=2500, every=1
        )
        kept += samples[500:]
        assert all(info[f"swaps_accepted_{r}"] > 0 for r in range(len(betas) - 1))
    p_above, p_below = _visits(kept, above), _visits(kept, below)
    assert p_above == pytest.approx(exact, abs=0.08)
    assert p_above + p_below == pytest.approx(1.0, abs=0.01)


def test_same_seed_same_numbers_and_one_replica_is_the_plain_chain() -> None:
    """A tempered run is a function of its seed; with one replica it is exactly the β = 1
    chain of :func:`~bayesmap.blackboard.rjmcmc.run` on the same stream."""
    ctx, birth = _room()
    rates = MoveRates()
    betas = geometric_ladder(3, 0.2)

    def tempered(seed: int) -> tuple[list[np.ndarray], dict[str, int]]:
        states = _replicas(ctx, betas, np.zeros((0, 4)))
        return tempered_run(
            np.random.default_rng(seed), states, ctx, birth, rates, betas, moves=100
        )

    first, second = tempered(5), tempered(5)
    assert first[1] == second[1]
    assert all(np.array_equal(a, b) for a, b in zip(first[0], second[0], strict=True))

    state = _replicas(ctx, np.ones(1), np.zeros((0, 4)))
    alone, _ = tempered_run(
        np.random.default_rng(9), state, ctx, birth, rates, np.ones(1), moves=80
    )
    plain = _replicas(ctx, np.ones(1), np.zeros((0, 4)))[0]
    _, _, reference, _ = run(
        np.random.default_rng(9), plain, ctx, birth, rates, np.ones(80), record_every=1
    )
    assert len(alone) == len(reference) == 80
    assert all(np.array_equal(a, b) for a, b in zip(alone, reference, strict=True))


def test_bad_ladders_are_config_errors() -> None:
    ctx, birth = _room()
    states = _replicas(ctx, np.ones(2), np.zeros((0, 4)))
    with pytest.raises(ConfigError, match="first 1"):
        tempered_run(
            np.random.default_rng(0), states, ctx, birth, MoveRates(), np.array([0.5, 0.2]), moves=5
        )
    with pytest.raises(ConfigError, match="every"):
        tempered_run(
            np.random.default_rng(0), states, ctx, birth, MoveRates(), np.ones(2), moves=5, every=0
        )


@pytest.mark.parametrize(
    "bad", [{"replicas": 0}, {"beta_min": 0.0}, {"beta_min": 1.5}, {"swap_every": 0}]
)
def test_bad_tempering_params_are_config_errors(bad: dict[str, float]) -> None:
    with pytest.raises(ConfigError, match="replicas >= 1"):
        FusedParams(**bad)  # type: ignore[arg-type]


@pytest.mark.slow
def test_a_replica_at_beta_samples_the_tempered_prior() -> None:
    """β multiplies the whole log posterior, the table prior included: with no evidence a
    replica at β samples tables at intensity λ^β (the reference measure, not π, holds the
    1/n! of unordered sets, so it is not tempered). In a 2 × 2 m room the odds of one desk
    against none are then λ^β · |{(x, y, θ) inside}| (measured here by Monte Carlo); the
    chain's odds at β = 0.5 match them (0.17 against 0.16 when written), ten times the
    untempered odds (0.018 against 0.016)."""
    arena = (2.0, 2.0)
    model = SweepModel(0.02, 0.01, 0.1, 0.05, 0.05, 0.01, -math.inf, arena)
    ctx = Context((DESK,), model, EvidenceStore())
    rng = np.random.default_rng(3)
    poses = np.column_stack(
        [rng.uniform(0, 2, (40000, 2)), rng.uniform(0, math.pi, 40000), np.zeros(40000)]
    )
    volume = 4.0 * math.pi * float(arena_contains(poses, (DESK,), arena).mean())
    birth = BirthProposal((0.0, 0.0, *arena), np.zeros((0, 4)), np.zeros(0), 1, 1.0, 0.1, 0.1)
    rates = MoveRates(birth=0.4, death=0.4, refine=0.2, mirror=0, corner=0, type=0, switch=0)
    for beta in (0.5, 1.0):
        state = ChainState()
        ctx.refresh(state)
        n = np.zeros(2500, dtype=np.int64)
        for i in range(len(n)):  # a state every 8 moves (run records states at β = 1 only)
            run(rng, state, ctx, birth, rates, np.full(8, beta))
            n[i] = len(state.tables)
        odds = np.mean(n == 1) / np.mean(n == 0)
        # about 370 one-desk states at β = 0.5, 45 at β = 1: tolerances of about 3 σ
        assert odds == pytest.approx(model.intensity**beta * volume, rel=0.2 if beta < 1 else 0.45)
