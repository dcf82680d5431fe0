"""MAP questions: the most probable joint state of every unobserved variable (MPE, Post et
al. 2016 eq. 13) and marginal MAP over a subset (eq. 14), in float64 or fixed point.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import opt_einsum

from bayesmap._typing import FloatArray
from bayesmap.bn import contraction, elimination, posteriors
from bayesmap.bn.fixed_point import (
    Fixed,
    FixedAlgebra,
    FixedResult,
    QFormat,
    constant,
    ratio,
)
from bayesmap.bn.plans import Plan, QueryKind, symbol
from bayesmap.errors import InputError

if TYPE_CHECKING:
    from bayesmap.bn.inference import Engine, Evidence


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


def mpe(engine: Engine, evidence: Evidence) -> tuple[dict[str, str], float]:
    """Most probable joint state of all unobserved variables (eq. 13), by max-product.

    Returns the assignment and its posterior probability ``P(x | evidence)``.
    """
    compiled = engine.compiled
    ev = engine.evidence_ids(evidence)
    free = tuple(v for v in range(len(compiled.names)) if v not in ev)
    plan = engine.plan(QueryKind.WHOLE, free, frozenset(ev))
    ev_idx = [ev[v] for v in plan.evidence]
    names = engine.source_evidence(ev)
    log_scale = sum(log(contraction.slice_case(compiled, f, ev_idx, names)) for f in plan.checks)
    operands = [log(contraction.slice_case(compiled, f, ev_idx, names)) for f in plan.factors]
    path = plan.cache.scalar_path
    if path is None:
        path = plan.cache.scalar_path = elimination.find_path(
            [f.term for f in plan.factors],
            "",
            [np.shape(op) for op in operands],
            tuning=engine.tuning,
        )
    best: FloatArray = np.zeros(())
    records: list[elimination.Record] = []
    if operands:
        best, _, records = elimination.run(path, operands, elimination.LogMax())
    log_best = float(best) + log_scale
    if not math.isfinite(log_best):
        raise InputError(contraction.impossible(evidence))
    choice = elimination.traceback(records)
    assignment = {compiled.names[v]: compiled.states[v][choice[symbol(v)]] for v in free}
    probability = math.exp(
        log_best - math.log(posteriors.probability_of_evidence(engine, evidence))
    )
    return assignment, min(probability, 1.0)


def marginal_map(
    engine: Engine, variables: Sequence[str], evidence: Evidence
) -> tuple[dict[str, str], float]:
    """Marginal MAP (eq. 14): ``argmax_x Σ_Z P(x, Z | evidence)`` over ``variables``.

    Exact: the other variables are summed out first (one opt_einsum contraction per
    connected group of them), then the resulting factors are maximised jointly.
    Returns the assignment and ``P(x | evidence)``.
    """
    compiled = engine.compiled
    ev, query, fixed = map_query(engine, variables, evidence)
    if not query:
        return fixed, 1.0 if posteriors.probability_of_evidence(engine, evidence) > 0 else 0.0
    plan = engine.plan(QueryKind.MARGINAL, query, frozenset(ev))
    ev_idx = [ev[v] for v in plan.evidence]
    names = engine.source_evidence(ev)
    log_scale = sum(log(contraction.slice_case(compiled, f, ev_idx, names)) for f in plan.checks)
    sliced = [contraction.slice_case(compiled, f, ev_idx, names) for f in plan.factors]
    groups = plan.cache.groups
    if groups is None:
        groups = plan.cache.groups = sum_groups(plan, set(query))
    operands: list[FloatArray] = []
    terms: list[str] = []
    for members, boundary in groups:
        part = [sliced[k] for k in members]
        if boundary is None:  # a factor over query variables only
            operands.append(log(part[0]))
            terms.append(plan.factors[members[0]].term)
            continue
        equation = ",".join(plan.factors[k].term for k in members) + "->" + boundary
        operands.append(log(opt_einsum.contract(equation, *part)))
        terms.append(boundary)
    path = elimination.find_path(terms, "", [np.shape(op) for op in operands], tuning=engine.tuning)
    best, _, records = elimination.run(path, operands, elimination.LogMax())
    if not (math.isfinite(log_scale) and math.isfinite(float(best))):
        raise InputError(contraction.impossible(evidence))
    choice = elimination.traceback(records)
    assignment = dict(fixed)
    for v in query:
        assignment[compiled.names[v]] = compiled.states[v][choice[symbol(v)]]
    equation = ",".join(f.term for f in plan.factors) + "->"
    total = float(opt_einsum.contract(equation, *sliced))
    probability = math.exp(float(best) - math.log(total))
    return assignment, min(probability, 1.0)


def fixed_mpe(engine: Engine, evidence: Evidence, q: QFormat) -> tuple[dict[str, str], FixedResult]:
    """:func:`mpe` by max-product in Q-format integers.

    The probability returned is ``P(x | evidence)`` as a 0-d :class:`FixedResult`; its
    bound covers both the exact probability of the returned assignment and the exact
    maximum.
    """
    compiled = engine.compiled
    ev = engine.evidence_ids(evidence)
    free = tuple(v for v in range(len(compiled.names)) if v not in ev)
    algebra = FixedAlgebra(q, "max")
    best, records = contraction.fixed_scalar(
        engine, engine.plan(QueryKind.WHOLE, free, frozenset(ev)), ev, algebra
    )
    total, _ = contraction.fixed_scalar(
        engine, engine.plan(QueryKind.EVIDENCE, (), frozenset(ev)), ev, FixedAlgebra(q)
    )
    choice = elimination.traceback(records)
    assignment = {compiled.names[v]: compiled.states[v][choice[symbol(v)]] for v in free}
    return assignment, ratio(q, best, total, "MAP")


def fixed_marginal_map(
    engine: Engine, variables: Sequence[str], evidence: Evidence, q: QFormat
) -> tuple[dict[str, str], FixedResult]:
    """:func:`marginal_map` in Q-format integers: the same sum groups, summed then
    maximised in block floating point; ``P(x | evidence)`` as a 0-d :class:`FixedResult`."""
    compiled = engine.compiled
    ev, query, fixed = map_query(engine, variables, evidence)
    if not query:
        posteriors.probability_of_evidence(engine, evidence)
        return fixed, constant(q, np.ones(()))
    plan = engine.plan(QueryKind.MARGINAL, query, frozenset(ev))
    operands = contraction.fixed_operands(engine, plan, ev, evidence, q)
    groups = plan.cache.groups
    if groups is None:
        groups = plan.cache.groups = sum_groups(plan, set(query))
    sums = FixedAlgebra(q)
    parts: list[Fixed] = []
    terms: list[str] = []
    for k, (members, boundary) in enumerate(groups):
        if boundary is None:  # a factor over query variables only
            parts.append(operands[members[0]])
            terms.append(plan.factors[members[0]].term)
            continue
        group = [operands[m] for m in members]
        path = plan.cache.group_paths.get(k)
        if path is None:
            path = plan.cache.group_paths[k] = elimination.find_path(
                [plan.factors[m].term for m in members],
                boundary,
                [o.raw.shape for o in group],
                tuning=engine.tuning,
            )
        part, term, _ = elimination.run(path, group, sums)
        parts.append(part)
        terms.append(term)
    shapes = [p.raw.shape for p in parts]
    best, _, records = elimination.run(
        elimination.find_path(terms, "", shapes, tuning=engine.tuning),
        parts,
        FixedAlgebra(q, "max"),
    )
    total, _, _ = elimination.run(
        elimination.find_path(terms, "", shapes, tuning=engine.tuning), parts, sums
    )
    choice = elimination.traceback(records)
    assignment = dict(fixed)
    for v in query:
        assignment[compiled.names[v]] = compiled.states[v][choice[symbol(v)]]
    return assignment, ratio(q, best, total, "marginal MAP")


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


def log(values: FloatArray | float) -> Any:
    with np.errstate(divide="ignore"):
        return np.log(values)
