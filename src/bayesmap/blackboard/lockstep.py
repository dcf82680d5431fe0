"""Nelder–Mead on many small problems in lockstep: one batched objective call per step.

The fused mapper's final pass polishes a few hundred leg and table candidates, each by a
dozen or two Nelder–Mead steps on its own contacts (:mod:`~bayesmap.blackboard.data_driven`).
One candidate's objective is a small numpy computation whose cost is mostly numpy's
per-call overhead; here every candidate's simplex advances at once and the objective is
called once per step on one point of each candidate still running, so those small
computations become one large one.

Each candidate follows exactly the steps of SciPy's Nelder–Mead
(``scipy.optimize.minimize(method="Nelder-Mead")`` without bounds or adaptive
parameters: Nelder & Mead 1965 with reflection ρ = 1, expansion χ = 2, contraction ψ = 1/2
and shrink σ = 1/2): the same points in the same order, the same tests of ``xatol``,
``fatol`` and the evaluation budget, so the same result, bit for bit (the tests compare
the two).
"""

from __future__ import annotations

from collections.abc import Callable, Generator

import numpy as np

from bayesmap._typing import FloatArray, IntArray

__all__ = ["minimise_together"]

_Run = Generator[FloatArray, float, FloatArray]


class _Spent(Exception):
    """The evaluation budget of one run is used up."""


def minimise_together(
    objective: Callable[[FloatArray, IntArray], FloatArray],
    simplices: FloatArray,
    *,
    max_evals: int,
    xatol: float,
    fatol: float,
) -> FloatArray:
    """Minimise ``k`` problems by Nelder–Mead in lockstep; returns ``(k, n)`` minimisers.

    Parameters
    ----------
    objective
        ``objective(points, problems)``: ``(a, n)`` points, one for each of the ``(a,)``
        problem indices ``problems``; returns their ``(a,)`` values.
    simplices
        ``(k, n + 1, n)`` initial simplex of each problem.
    max_evals, xatol, fatol
        SciPy's ``maxfev``, ``xatol`` and ``fatol``, per problem.

    Examples
    --------
    >>> import numpy as np
    >>> centres = np.array([[1.0, 2.0], [-3.0, 0.5]])
    >>> def bowl(points, problems):
    ...     return ((points - centres[problems]) ** 2).sum(axis=1)
    >>> start = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]])
    >>> found = minimise_together(
    ...     bowl, np.stack([start, start]), max_evals=400, xatol=1e-6, fatol=1e-9
    ... )
    >>> np.round(found, 4).tolist()
    [[1.0, 2.0], [-3.0, 0.5]]
    """
    simplices = np.asarray(simplices, dtype=np.float64)
    out = np.empty(simplices.shape[::2])
    runs = [_nelder_mead(simplex, max_evals, xatol, fatol) for simplex in simplices]
    asked: dict[int, FloatArray] = {}
    for problem, run in enumerate(runs):
        try:
            asked[problem] = next(run)
        except StopIteration as done:
            out[problem] = done.value
    while asked:
        problems = np.fromiter(asked, dtype=np.int64, count=len(asked))
        values = objective(np.array(list(asked.values())), problems)
        for problem, value in zip(problems.tolist(), values.tolist(), strict=True):
            try:
                asked[problem] = runs[problem].send(value)
            except StopIteration as done:
                out[problem] = done.value
                del asked[problem]
    return out


def _nelder_mead(simplex: FloatArray, max_evals: int, xatol: float, fatol: float) -> _Run:
    """One problem's Nelder–Mead as a generator: it yields each point to evaluate, is sent
    its value, and returns the minimiser — SciPy's ``_minimize_neldermead`` step for step."""
    rho, chi, psi, sigma = 1, 2, 0.5, 0.5
    sim = simplex.copy()
    n = sim.shape[1]
    fsim = np.full((n + 1,), np.inf, dtype=float)
    calls = 0

    def value(x: FloatArray) -> Generator[FloatArray, float, float]:
        nonlocal calls
        if calls >= max_evals:
            raise _Spent
        calls += 1
        return (yield np.copy(x))

    try:
        for k in range(n + 1):
            fsim[k] = yield from value(sim[k])
    except _Spent:
        pass
    finally:
        ind = np.argsort(fsim)
        sim = np.take(sim, ind, 0)
        fsim = np.take(fsim, ind, 0)
    ind = np.argsort(fsim)
    fsim = np.take(fsim, ind, 0)
    sim = np.take(sim, ind, 0)
    while calls < max_evals:
        try:
            if (
                np.max(np.ravel(np.abs(sim[1:] - sim[0]))) <= xatol
                and np.max(np.abs(fsim[0] - fsim[1:])) <= fatol
            ):
                break
            xbar = np.add.reduce(sim[:-1], 0) / n
            xr = (1 + rho) * xbar - rho * sim[-1]
            fxr = yield from value(xr)
            shrink = False
            if fxr < fsim[0]:
                xe = (1 + rho * chi) * xbar - rho * chi * sim[-1]
                fxe = yield from value(xe)
                if fxe < fxr:
                    sim[-1], fsim[-1] = xe, fxe
                else:
                    sim[-1], fsim[-1] = xr, fxr
            elif fxr < fsim[-2]:
                sim[-1], fsim[-1] = xr, fxr
            elif fxr < fsim[-1]:
                xc = (1 + psi * rho) * xbar - psi * rho * sim[-1]
                fxc = yield from value(xc)
                if fxc <= fxr:
                    sim[-1], fsim[-1] = xc, fxc
                else:
                    shrink = True
            else:
                xcc = (1 - psi) * xbar + psi * sim[-1]
                fxcc = yield from value(xcc)
                if fxcc < fsim[-1]:
                    sim[-1], fsim[-1] = xcc, fxcc
                else:
                    shrink = True
            if shrink:
                for j in range(1, n + 1):
                    sim[j] = sim[0] + sigma * (sim[j] - sim[0])
                    fsim[j] = yield from value(sim[j])
        except _Spent:
            pass
        ind = np.argsort(fsim)
        sim = np.take(sim, ind, 0)
        fsim = np.take(fsim, ind, 0)
    return np.asarray(sim[0])
