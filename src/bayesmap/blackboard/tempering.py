"""Replica exchange (parallel tempering) for the fused mapper's reversible-jump chain.

R replicas of the map run the moves of :mod:`~bayesmap.blackboard.rjmcmc` on tempered
targets π^β_r, at inverse temperatures 1 = β_0 > β_1 > … > β_{R−1} (a geometric ladder,
:func:`geometric_ladder`). Tempering multiplies the *whole* log posterior — priors, overlap
factors, contacts and free space alike — while each move's proposal ratio stays untempered
(``log α = β Δlog π + log q-ratio`` in :func:`~bayesmap.blackboard.rjmcmc.run`), so each
replica's kernel leaves its own π^β invariant. Between rounds of moves, neighbouring replicas
i and j = i + 1 exchange their maps with probability (Geyer 1991; Earl & Deem 2005)::

    α_swap = min(1, exp((β_i − β_j) (log π(X_j) − log π(X_i))))

on the untempered log posterior, which leaves the product ∏_r π^β_r(X_r) invariant. The pairs
tried alternate between (0, 1), (2, 3), … and (1, 2), (3, 4), … (each a product of exchanges
that each keep the product target). The hot replicas cross barriers the β = 1 chain cannot
(the death of a table that dozens of contacts support costs it tens of nats; at β = 0.1 a
tenth of that), and swaps carry what they find down to β = 1, whose visits alone are
samples of the posterior: the fused mapper's existence probabilities
(:meth:`~bayesmap.blackboard.fused.FusedMapper.finish`) are their frequencies. A swap
exchanges whole :class:`~bayesmap.blackboard.rjmcmc.ChainState` objects — the tables with
their cached free-space terms and log π — and the shared
:class:`~bayesmap.blackboard.rjmcmc.Context` keeps only per-table terms (keyed on a table's
exact ``x, y, θ, k``), so no replica can keep another map's terms.

This is the paper's §II-C "future work" (Fox & Prescott 2011 sample with annealed
Metropolis–Hastings, Algorithm 1, and read off only the MAP).
"""

from __future__ import annotations

import math

import numpy as np

from bayesmap._typing import FloatArray
from bayesmap.blackboard.data_driven import BirthProposal
from bayesmap.blackboard.rjmcmc import ChainState, Context, MoveRates, run
from bayesmap.errors import ConfigError

__all__ = ["exchange", "geometric_ladder", "swap_log_ratio", "tempered_run"]


def geometric_ladder(replicas: int, beta_min: float) -> FloatArray:
    """``(replicas,)`` inverse temperatures from 1 down to ``beta_min``, in geometric steps.

    A geometric ladder keeps the swap acceptance about even along it when log π's spread at
    temperature 1/β grows like 1/β (a posterior that is near Gaussian in each table's pose).
    """
    if replicas < 1 or not 0 < beta_min <= 1:
        raise ConfigError(
            f"a tempering ladder needs replicas >= 1 and 0 < beta_min <= 1, "
            f"got {replicas} and {beta_min}"
        )
    if replicas == 1:
        return np.ones(1)
    return np.asarray(np.geomspace(1.0, beta_min, replicas))


def swap_log_ratio(beta_i: float, beta_j: float, log_pi_i: float, log_pi_j: float) -> float:
    """log of the exchange ratio of replicas at ``beta_i``, ``beta_j`` holding maps of
    untempered log posteriors ``log_pi_i``, ``log_pi_j``: (β_i − β_j)(log π_j − log π_i).

    It is log [π^β_i(X_j) π^β_j(X_i) / (π^β_i(X_i) π^β_j(X_j))]; the posterior's unknown
    constant cancels.
    """
    return (beta_i - beta_j) * (log_pi_j - log_pi_i)


def exchange(
    rng: np.random.Generator, states: list[ChainState], betas: FloatArray, first: int
) -> dict[int, bool]:
    """Try to swap the maps of replicas (first, first + 1), (first + 2, first + 3), ….

    ``states[r]`` is the map at ``betas[r]``; an accepted swap exchanges the list's entries
    (whole states, their cached terms with them). Returns, for each pair tried (keyed by
    its lower index), whether it swapped.
    """
    swapped: dict[int, bool] = {}
    for i in range(first, len(states) - 1, 2):
        log_alpha = swap_log_ratio(
            float(betas[i]), float(betas[i + 1]), states[i].log_pi, states[i + 1].log_pi
        )
        swapped[i] = bool(log_alpha >= 0 or rng.uniform() < math.exp(log_alpha))
        if swapped[i]:
            states[i], states[i + 1] = states[i + 1], states[i]
    return swapped


def tempered_run(
    rng: np.random.Generator,
    states: list[ChainState],
    ctx: Context,
    birth: BirthProposal,
    rates: MoveRates,
    betas: FloatArray,
    *,
    moves: int,
    every: int = 10,
) -> tuple[list[FloatArray], dict[str, int]]:
    """Run ``moves`` moves on each replica, with neighbour exchanges every ``every`` moves.

    Parameters
    ----------
    states
        One :class:`~bayesmap.blackboard.rjmcmc.ChainState` per entry of ``betas`` (their
        caches up to date, see :meth:`~bayesmap.blackboard.rjmcmc.Context.refresh`);
        modified in place, ``states[0]`` ending as the β = 1 replica's map.
    betas
        The ladder, ``betas[0] == 1``, decreasing.
    every
        Moves per replica between two exchange rounds (the rounds alternate between the even
        and the odd neighbour pairs).

    Returns
    -------
    samples
        The β = 1 replica's map after each of its moves (``moves`` samples).
    info
        The β = 1 replica's move counters (``proposed_<kind>``, ``accepted_<kind>``) and, per
        neighbour pair r, ``swaps_tried_<r>``, ``swaps_accepted_<r>``.
    """
    if len(states) != len(betas) or not len(betas) or betas[0] != 1.0:
        raise ConfigError("tempered_run needs one state per inverse temperature, the first 1")
    if every < 1:
        raise ConfigError(f"tempered_run: every must be >= 1, got {every}")
    samples: list[FloatArray] = []
    info: dict[str, int] = {}
    for r in range(len(betas) - 1):
        info[f"swaps_tried_{r}"] = info[f"swaps_accepted_{r}"] = 0
    done, round_index = 0, 0
    while done < moves:
        length = min(every, moves - done)
        for r, beta in enumerate(betas):
            record = 1 if r == 0 else 0
            _, _, drawn, counters = run(
                rng, states[r], ctx, birth, rates, np.full(length, float(beta)), record_every=record
            )
            if r == 0:
                samples.extend(drawn)
                for key, value in counters.items():
                    info[key] = info.get(key, 0) + value
        done += length
        for i, swapped in exchange(rng, states, betas, round_index % 2).items():
            info[f"swaps_tried_{i}"] += 1
            info[f"swaps_accepted_{i}"] += int(swapped)
        round_index += 1
    return samples, info
