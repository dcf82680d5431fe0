"""Posteriors: of one variable (eq. 25), jointly of several, of every variable at once, and
the probability of the evidence (eq. 24's normaliser Σ), in float64 or fixed point.

Every variable at once is one two-pass contraction (:mod:`bayesmap.bn.marginals`) where that
costs less than one pruned question per variable (decided once per pattern).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from bayesmap._typing import FloatArray
from bayesmap.bn import ancestral, contraction, marginals, plans
from bayesmap.bn.plans import Plan, QueryKind
from bayesmap.errors import InputError

if TYPE_CHECKING:
    from bayesmap.bn.inference import Engine, Evidence
    from bayesmap.bn.numbers import A, Numbers


def joint_query(
    engine: Engine, targets: Sequence[str], evidence: Evidence
) -> tuple[dict[int, int], tuple[int, ...], tuple[int, ...]]:
    """``(evidence ids, target ids, unobserved target ids)`` of a joint posterior."""
    compiled = engine.compiled
    ids = tuple(compiled.id(t) for t in targets)
    if len(set(ids)) != len(ids):
        raise InputError(f"joint posterior: a target is listed twice in {list(targets)}")
    ev = engine.evidence_ids(evidence)
    return ev, ids, tuple(t for t in ids if t not in ev)


def posterior(engine: Engine, target: str, evidence: Evidence) -> FloatArray:
    """``P(target | evidence)`` as an array over the target's states (eq. 25)."""
    compiled = engine.compiled
    t = compiled.id(target)
    ev = engine.evidence_ids(evidence)
    if t in ev:
        probability_of_evidence(engine, evidence)  # raises on impossible evidence
        return contraction.one_hot(compiled.card[t], ev[t])
    plan = engine.plan(QueryKind.MARGINAL, (t,), frozenset(ev))
    if plan.dropped:
        engine.check_dropped(plan, ev.__getitem__, lambda: contraction.impossible(evidence))
    order = plan.cache.ancestral
    if order is not None:
        names = engine.source_evidence(ev)
        return ancestral.marginal(compiled, t, ev, engine.priors, names, order)
    return contraction.normalised(contraction.contract(engine, plan, ev), evidence)


def joint_posterior(
    engine: Engine, targets: Sequence[str], evidence: Evidence, numbers: Numbers[Any, A, Any]
) -> A:
    """``P(targets | evidence)`` with one axis per target, in the given order (observed
    targets one-hot), in ``numbers``: float64 or fixed point (:mod:`bayesmap.bn.numbers`)."""
    compiled = engine.compiled
    ev, ids, free = joint_query(engine, targets, evidence)
    if free:
        plan = engine.plan(QueryKind.MARGINAL, free, frozenset(ev))
        table = numbers.sum_product(engine, plan, ev, evidence)
        answer = numbers.posterior(table, evidence, f"posterior of {list(targets)}")
    else:
        probability_of_evidence(engine, evidence)
        answer = numbers.certain()
    return numbers.place(answer, lambda a: contraction.embed(a, ids, free, ev, compiled.card))


def posteriors(engine: Engine, evidence: Evidence) -> dict[int, FloatArray]:
    """``P(v | evidence)`` of every unobserved variable ``v`` from one two-pass
    contraction (:mod:`bayesmap.bn.marginals`), by variable id."""
    compiled = engine.compiled
    ev = engine.evidence_ids(evidence)
    free = tuple(v for v in range(len(compiled.names)) if v not in ev)
    if not free:
        probability_of_evidence(engine, evidence)
        return {}
    plan = engine.plan(QueryKind.WHOLE, free, frozenset(ev))  # every variable, nothing pruned
    if not two_pass_pays(engine, plan, free):
        return {v: posterior(engine, compiled.names[v], evidence) for v in free}
    ev_idx = [ev[v] for v in plan.evidence]
    names = engine.source_evidence(ev)
    scale = 1.0
    for factor in plan.checks:
        scale *= float(contraction.slice_case(compiled, factor, ev_idx, names))
    program, wanted = two_pass(engine, plan, free, ())
    operands = [
        contraction.slice_case(compiled, f, ev_idx, names) for f in plan.factors if f.observed
    ]
    total, joints = program(operands)
    if not float(total) * scale > 0.0:
        raise InputError(contraction.impossible(evidence))
    return {v: np.asarray(j / j.sum()) for (_, v), j in zip(wanted, joints, strict=True)}


def two_pass_pays(engine: Engine, plan: Plan, free: tuple[int, ...]) -> bool:
    """Whether one two-pass contraction of the whole network costs less than one pruned
    contraction per variable (decided once per pattern, by multiply-adds plus a fixed
    cost per call: the per-variable plans prune barren nodes and reuse priors, which on
    some networks — munin1 — beats three contractions of everything).

    When the fixed costs of the calls alone exceed the two-pass budget, no per-variable
    order is computed (alarm, pathfinder, andes: the first all-posteriors question would
    otherwise order a plan per variable); the orders that are computed stay on their plans
    for the per-variable questions to reuse."""
    decision = plan.cache.two_pass_pays
    if decision is None:
        ev = frozenset(plan.evidence)
        _, _, forward = two_pass_order(engine, plan, ())
        call_cost = engine.tuning.call_cost
        budget = 3 * forward + 3 * len(plan.factors) * call_cost
        per_call = call_cost * engine.tuning.calls_per_question
        loop = per_call * len(free)
        if loop < budget:
            for v in free:
                single = engine.plan(QueryKind.MARGINAL, (v,), ev)
                if single.cache.ancestral is None and single.factors:
                    loop += contraction.single_order(single, engine.compiled, engine.tuning)[2]
                if loop > budget:
                    break
        decision = plan.cache.two_pass_pays = budget <= loop
    return decision


def two_pass_order(
    engine: Engine, plan: Plan, output: tuple[int, ...], cases: int = 1
) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]], int]:
    """Scopes, contraction order and multiply-adds of a plan's two-pass contraction."""
    entry = plan.cache.two_pass_order.get((output, cases))
    if entry is None:
        batched = bool(output)
        scopes = [
            (contraction.CASE, *f.free) if batched and f.observed else f.free for f in plan.factors
        ]
        path, _, cost = plans.order_steps(
            engine.compiled,
            scopes,
            output,
            {contraction.CASE: cases},
            search=True,
            tuning=engine.tuning,
        )
        entry = plan.cache.two_pass_order[output, cases] = (scopes, path, cost)
    return entry


def two_pass(
    engine: Engine, plan: Plan, free: tuple[int, ...], output: tuple[int, ...], cases: int = 1
) -> tuple[marginals.TwoPass, list[tuple[int, int]]]:
    """The compiled two-pass contraction of a plan and its wanted ``(factor, variable)``
    pairs (cached in the plan; a batch's per size class of ``cases``)."""
    entry = plan.cache.two_pass.get((output, cases))
    if entry is None:
        compiled = engine.compiled
        scopes, path, _ = two_pass_order(engine, plan, output, cases)
        sizes: dict[Any, int] = dict(enumerate(compiled.card))
        sizes[contraction.CASE] = cases
        own = {f.var: k for k, f in enumerate(plan.factors)}
        wanted = [(own[v], v) for v in free]
        constants = [None if f.observed else f.array for f in plan.factors]
        program = marginals.TwoPass(
            scopes, constants, path, output, sizes, wanted, tuning=engine.tuning
        )
        entry = plan.cache.two_pass[output, cases] = (program, wanted)
    return entry


def probability_of_evidence(engine: Engine, evidence: Evidence) -> float:
    """``P(evidence)``, the normalising constant Σ of eq. 24 (1 for no evidence)."""
    ev = engine.evidence_ids(evidence)
    plan = engine.plan(QueryKind.EVIDENCE, (), frozenset(ev))
    value = float(contraction.contract(engine, plan, ev, check=False))
    if value <= 0.0:
        raise InputError(contraction.impossible(evidence))
    return value


def ancestral_posterior(engine: Engine, target: str, evidence: Evidence) -> FloatArray:
    """The paper's recursive query (eq. 27); exact only where :func:`ancestral.is_exact`."""
    compiled = engine.compiled
    t = compiled.id(target)
    ev = engine.evidence_ids(evidence)
    if t in ev:
        return contraction.one_hot(compiled.card[t], ev[t])
    return ancestral.marginal(compiled, t, ev, engine.priors, engine.source_evidence(ev))


def ancestral_is_exact(engine: Engine, target: str, evidence: Evidence) -> bool:
    """Whether the recursive query is exact for this target and these observed variables."""
    compiled = engine.compiled
    ev = engine.evidence_ids(evidence)
    return ancestral.is_exact(compiled, (compiled.id(target),), ev) is not None
