"""MAP questions: the most probable joint state of every unobserved variable (MPE, Post et
al. 2016 eq. 13) and marginal MAP over a subset (eq. 14), in float64 or fixed point.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from bayesmap.bn import elimination, posteriors
from bayesmap.bn.plans import Plan, QueryKind, symbol

if TYPE_CHECKING:
    from bayesmap.bn.inference import Engine, Evidence
    from bayesmap.bn.numbers import Numbers, S


def map_query(
    engine: Engine, variables: Sequence[str], evidence: Evidence
) -> tuple[dict[int, int], tuple[int, ...], dict[str, str]]:
    """``(evidence ids, unobserved MAP variable ids, observed MAP variables' states)``."""
    compiled = engine.compiled
    ids = tuple(compiled.id(v) for v in variables)
    ev = engine.evidence_ids(evidence)
    query = tuple(v for v in dict.fromkeys(ids) if v not in ev)
    fixed = {compiled.names[v]: compiled.states[v][ev[v]] for v in ids if v in ev}
    return ev, query, fixed


def mpe(
    engine: Engine, evidence: Evidence, numbers: Numbers[Any, Any, S]
) -> tuple[dict[str, str], S]:
    """Most probable joint state of all unobserved variables (eq. 13), by max-product in
    ``numbers``.

    Returns the assignment and its posterior probability ``P(x | evidence)`` (in fixed
    point, its bound covers both the exact probability of the returned assignment and the
    exact maximum; ties are broken by the lowest state index).
    """
    compiled = engine.compiled
    ev = engine.evidence_ids(evidence)
    free = tuple(v for v in range(len(compiled.names)) if v not in ev)
    plan = engine.plan(QueryKind.WHOLE, free, frozenset(ev))
    best, records = numbers.max_product(engine, plan, ev, evidence)
    choice = elimination.traceback(records)
    assignment = {compiled.names[v]: compiled.states[v][choice[symbol(v)]] for v in free}
    return assignment, numbers.map_probability(engine, best, ev, evidence)


def marginal_map(
    engine: Engine, variables: Sequence[str], evidence: Evidence, numbers: Numbers[Any, Any, S]
) -> tuple[dict[str, str], S]:
    """Marginal MAP (eq. 14): ``argmax_x Σ_Z P(x, Z | evidence)`` over ``variables``.

    Exact: the other variables are summed out first (one contraction per connected group
    of them, :func:`sum_groups`), then the resulting factors are maximised jointly.
    Returns the assignment and ``P(x | evidence)``.
    """
    compiled = engine.compiled
    ev, query, fixed = map_query(engine, variables, evidence)
    if not query:
        posteriors.probability_of_evidence(engine, evidence)  # raises on impossible evidence
        return fixed, numbers.sure()
    plan = engine.plan(QueryKind.MARGINAL, query, frozenset(ev))
    groups = plan.cache.groups
    if groups is None:
        groups = plan.cache.groups = sum_groups(plan, set(query))
    answer, records = numbers.marginal_map(engine, plan, groups, ev, evidence)
    choice = elimination.traceback(records)
    assignment = dict(fixed)
    for v in query:
        assignment[compiled.names[v]] = compiled.states[v][choice[symbol(v)]]
    return assignment, answer


def sum_groups(plan: Plan, query: set[int]) -> list[tuple[list[int], str | None]]:
    """Group the plan's factors for marginal MAP.

    Factors linked through summed-out variables form one group, contracted to a factor
    over the query variables it touches (its boundary); a factor over query variables
    only is its own group (boundary ``None``).
    """
    parent: dict[int, int] = {}

    def find(k: int) -> int:
        while parent.setdefault(k, k) != k:
            k = parent[k]
        return k

    owner: dict[int, int] = {}
    for k, f in enumerate(plan.factors):
        find(k)
        for v in f.free:
            if v not in query:
                if v in owner:
                    parent[find(k)] = find(owner[v])
                else:
                    owner[v] = k
    members: dict[int, list[int]] = {}
    for k in range(len(plan.factors)):
        members.setdefault(find(k), []).append(k)
    groups: list[tuple[list[int], str | None]] = []
    for group in members.values():
        summed = any(v not in query for k in group for v in plan.factors[k].free)
        if not summed:
            groups.extend(([k], None) for k in group)
            continue
        touched = dict.fromkeys(v for k in group for v in plan.factors[k].free if v in query)
        groups.append((group, "".join(symbol(v) for v in touched)))
    return groups
