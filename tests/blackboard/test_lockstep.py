"""Nelder–Mead in lockstep against SciPy's Nelder–Mead, run by run."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize

from bayesmap.blackboard.lockstep import minimise_together


def _problems(rng: np.random.Generator, k: int) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Random 3-D objectives: a bowl of random shape and centre with a ripple on top, every
    fifth one flat (ties everywhere, ripple NaN); each with a random simplex of random
    size."""
    out = []
    for index in range(k):
        bowl = np.vstack([rng.normal(size=(3, 3)), rng.normal(size=3)])
        ripple = math.nan if index % 5 == 4 else rng.uniform(0.0, 0.5)
        simplex = rng.normal(size=3) + np.vstack([np.zeros(3), np.diag(rng.uniform(0.01, 0.5, 3))])
        out.append((bowl, simplex, ripple))
    return out


def _value(x: np.ndarray, bowl: np.ndarray, ripple: float) -> float:
    if math.isnan(ripple):
        return 0.0
    d = bowl[:3] @ (x - bowl[3])
    return float(d @ d + ripple * np.sin(5.0 * x).sum())


@pytest.mark.parametrize("max_evals", [1, 4, 5, 12, 24, 400])
def test_each_lockstep_run_is_scipys_nelder_mead(max_evals: int) -> None:
    """On random objectives (flat ones included: every comparison a tie), each problem run
    in lockstep with the others returns exactly SciPy's minimiser and makes exactly SciPy's
    evaluations, in order, for budgets that stop it in the first simplex, mid-step and
    after convergence."""
    rng = np.random.default_rng(max_evals)
    problems = _problems(rng, 10)
    asked: list[list[bytes]] = [[] for _ in problems]

    def objective(points: np.ndarray, which: np.ndarray) -> np.ndarray:
        values = []
        for x, i in zip(points, which.tolist(), strict=True):
            asked[i].append(x.tobytes())
            values.append(_value(x, problems[i][0], problems[i][2]))
        return np.array(values)

    found = minimise_together(
        objective, np.stack([p[1] for p in problems]), max_evals=max_evals, xatol=1e-3, fatol=1e-2
    )
    for i, (params, simplex, ripple) in enumerate(problems):
        seen: list[bytes] = []

        def one(
            x: np.ndarray, bowl: np.ndarray = params, ripple: float = ripple, seen: list = seen
        ) -> float:
            seen.append(x.tobytes())
            return _value(x, bowl, ripple)

        want = optimize.minimize(
            one,
            simplex[0],
            method="Nelder-Mead",
            options={"initial_simplex": simplex, "maxfev": max_evals, "xatol": 1e-3, "fatol": 1e-2},
        )
        assert np.array_equal(found[i], want.x)
        assert asked[i] == seen
