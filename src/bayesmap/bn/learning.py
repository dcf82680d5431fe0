"""Parameter learning: CPTs from data, by maximum likelihood or Bayesian Dirichlet counts.

Post et al. 2016 store "learned probability data" in their networks, and the rover's map is
"updated as part of a learning process with the original map serving as the prior". For a
variable ``X`` with parents ``Pa`` and counts ``N(x, pa)`` of the cases,

- **maximum likelihood**: ``P(x | pa) = N(x, pa) / N(pa)``;
- **Bayesian** (the posterior mean under a Dirichlet prior with pseudo-counts ``α(x, pa)``):
  ``P(x | pa) = (N(x, pa) + α(x, pa)) / (N(pa) + α(pa))``, with
  *BDeu* ``α = S / (r q)`` (``S`` the equivalent sample size, ``r`` the states of ``X``, ``q``
  its parent configurations; Heckerman, Geiger & Chickering 1995), or the *network's current
  CPTs as the prior* ``α(x, pa) = S · P₀(x | pa) / q`` (the paper's map learning).

A parent configuration with no cases and no pseudo-counts keeps its current column.
Missing values (blanks) are filled in by expectation–maximisation (Dempster, Laird &
Rubin 1977): the E-step replaces counts by their expectations under the current CPTs
(:meth:`~bayesmap.bn.inference.Engine.expected_counts`), the M-step applies the rule
above, until the log-likelihood of the observed data gains less than ``tol`` per case.
EM starts from the network's current CPTs and finds a local maximum (of the likelihood,
or of the posterior with a prior).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from bayesmap._typing import CPT, FloatArray, IntArray
from bayesmap.errors import ConfigError

Prior = Literal["none", "bdeu", "cpt"]
"""Pseudo-counts of :meth:`~bayesmap.bn.model.BayesNet.fit`: none (maximum likelihood), BDeu,
or the network's current CPTs; the last two carry ``equivalent_sample_size`` cases."""

PRIORS: tuple[Prior, ...] = ("none", "bdeu", "cpt")


@dataclass(frozen=True)
class FitReport:
    """What :meth:`~bayesmap.bn.model.BayesNet.fit` did.

    Attributes
    ----------
    cases
        Number of cases learned from (the sum of their weights).
    iterations
        EM iterations (0 when no value was missing).
    log_likelihood
        ``Σ_cases log P(observed values)`` under the CPTs of the last E-step (complete
        data: under the fitted CPTs).
    converged
        Whether EM stopped by its tolerance rather than its iteration limit.
    """

    cases: float
    iterations: int
    log_likelihood: float
    converged: bool


def pseudo_counts(cpt: CPT, prior: Prior, equivalent_sample_size: float) -> FloatArray:
    """Dirichlet pseudo-counts ``α`` shaped like ``cpt``, for the given prior (module doc)."""
    if prior not in PRIORS:
        raise ConfigError(f"unknown prior {prior!r}; use one of {list(PRIORS)}")
    if prior == "none":
        return np.zeros(cpt.shape)
    if not (math.isfinite(equivalent_sample_size) and equivalent_sample_size > 0):
        raise ConfigError(
            f"equivalent_sample_size must be a positive number, got {equivalent_sample_size}"
        )
    configurations = cpt.size // cpt.shape[0]
    if prior == "bdeu":
        return np.full(cpt.shape, equivalent_sample_size / cpt.size)
    return np.asarray(cpt * (equivalent_sample_size / configurations))


def estimate(counts: FloatArray, pseudo: FloatArray, current: CPT) -> CPT:
    """``(N + α) / Σ_x (N + α)`` per parent configuration; empty columns keep ``current``."""
    total = counts + pseudo
    sums = total.sum(axis=0, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        table = total / sums
    return np.asarray(np.where(sums > 0.0, table, current))


def family_counts(
    table: IntArray, family: tuple[int, ...], cards: tuple[int, ...], weights: FloatArray | None
) -> FloatArray:
    """Counts ``N(x, pa)`` of complete cases: ``table`` columns are variable ids' values."""
    codes = np.ravel_multi_index(tuple(table[:, v] for v in family), cards)
    return (
        np.bincount(codes, weights=weights, minlength=math.prod(cards))
        .reshape(cards)
        .astype(np.float64)
    )


def complete_log_likelihood(counts: list[FloatArray], cpts: list[CPT]) -> float:
    """``Σ N(x, pa) log P(x | pa)`` (``0 log 0 = 0``)."""
    total = 0.0
    for n, p in zip(counts, cpts, strict=True):
        used = n > 0
        with np.errstate(divide="ignore"):
            total += float((n[used] * np.log(p[used])).sum())
    return total
