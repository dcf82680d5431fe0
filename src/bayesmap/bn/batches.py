"""Batches: many evidence cases of one network at once (one contraction per pattern of
observed columns, a leading case axis), soft evidence per case, the memo of answers, every
variable's posterior per case, and the E-step of EM learning.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray, IntArray
from bayesmap.bn import contraction, marginals, plans, posteriors
from bayesmap.bn.plans import Plan, QueryKind
from bayesmap.bn.soft import check_weights
from bayesmap.errors import InputError

if TYPE_CHECKING:
    from bayesmap.bn.inference import BatchEvidence, Engine, Evidence
    from bayesmap.bn.numbers import A, Numbers


def posteriors_batch(
    engine: Engine,
    evidence: BatchEvidence,
    columns: Sequence[str] | None,
    targets: Sequence[str] | None = None,
) -> dict[int, FloatArray]:
    """:func:`~bayesmap.bn.posteriors.posteriors` of many cases: ``{variable id: (n_cases,
    n_states)}`` of every variable, or of ``targets`` (observed: one-hot).

    Cases are grouped by their pattern of observed columns, one two-pass contraction
    per pattern; when the cases spread over more than ``tuning.many_patterns`` patterns, all
    are answered by one contraction with evidence indicators instead
    (:func:`indicator_batch`).
    """
    compiled = engine.compiled
    table, cols = batch_array(engine, evidence, columns)
    n = table.shape[0]
    wanted = range(len(compiled.names)) if targets is None else [compiled.id(t) for t in targets]
    groups = contraction.patterns(table) if n else []
    if len(groups) > engine.tuning.many_patterns and not compiled.sources:
        return indicator_batch(engine, tuple(dict.fromkeys(wanted)), table, cols)
    out = {v: np.zeros((n, compiled.card[v])) for v in range(len(compiled.names))}
    for rows, pattern in groups:
        ev_vars = [cols[j] for j in pattern]
        values = table[np.ix_(rows, pattern)]
        contraction.batch_contract(
            engine, engine.plan(QueryKind.EVIDENCE, (), frozenset(ev_vars)), ev_vars, values, rows
        )
        for k, v in enumerate(ev_vars):
            out[v][rows, values[:, k]] = 1.0
        free = tuple(v for v in range(len(compiled.names)) if v not in set(ev_vars))
        if not free:
            continue
        plan = engine.plan(QueryKind.WHOLE, free, frozenset(ev_vars))
        if not posteriors.two_pass_pays(engine, plan, free):
            for v in free:
                out[v][rows] = batch_answers(engine, v, ev_vars, values, rows)
            continue
        if not any(f.observed for f in plan.factors):  # the free part ignores the evidence
            answers = posteriors.posteriors(engine, {})
            for v in free:
                out[v][rows] = answers[v]
            continue
        order = [ev_vars.index(v) for v in plan.evidence]
        cols_k = [values[:, j] for j in order]
        case_names = contraction.case_namer(compiled, plan.evidence, cols_k)
        operands = [
            contraction.slice_batch(compiled, f, cols_k, case_names)
            for f in plan.factors
            if f.observed
        ]
        size_class = 1 << max(len(rows), engine.tuning.batch_class).bit_length()
        program, pairs = posteriors.two_pass(engine, plan, free, (contraction.CASE,), size_class)
        _, joints = program(operands)
        for (_, v), joint in zip(pairs, joints, strict=True):
            out[v][rows] = joint / joint.sum(axis=1, keepdims=True)
    return {v: out[v] for v in wanted}


def indicator_batch(
    engine: Engine, targets: tuple[int, ...], table: IntArray, cols: Sequence[int]
) -> dict[int, FloatArray]:
    """Posteriors of ``targets`` for cases with many patterns of blanks, all at once.

    Each observed column becomes a factor over the case axis and its variable — one-hot
    where the case observes it, ones where it is blank — so every case shares one
    contraction of the (evidence-free, pruned) network with these indicators, and its
    reverse gives every target's joint with the case's evidence (:mod:`marginals`).
    """
    compiled = engine.compiled
    n = table.shape[0]
    used = [j for j in range(table.shape[1]) if np.any(table[:, j] >= 0)]
    observed = tuple(cols[j] for j in used)
    keep = tuple(dict.fromkeys((*targets, *observed)))
    plan = engine.plan(QueryKind.MARGINAL, keep, frozenset())
    size_class = 1 << max(n, engine.tuning.batch_class).bit_length()
    key = (observed, targets, size_class)
    entry = plan.cache.indicators.get(key)
    if entry is None:
        scopes = [f.free for f in plan.factors] + [(contraction.CASE, v) for v in observed]
        constants: list[FloatArray | None] = [f.array for f in plan.factors]
        constants += [None] * len(observed)
        sizes: dict[Any, int] = dict(enumerate(compiled.card))
        sizes[contraction.CASE] = size_class
        path, _, _ = plans.order_steps(
            compiled,
            scopes,
            (contraction.CASE,),
            {contraction.CASE: size_class},
            search=True,
            tuning=engine.tuning,
        )
        own = {f.var: k for k, f in enumerate(plan.factors) if f.var in targets}
        pairs = [(own[t], t) for t in targets]
        entry = plan.cache.indicators[key] = marginals.TwoPass(
            scopes, constants, path, (contraction.CASE,), sizes, pairs, tuning=engine.tuning
        )
    indicators = []
    for j in used:
        values = table[:, j]
        indicator = np.ones((n, compiled.card[cols[j]]))
        seen = np.flatnonzero(values >= 0)
        indicator[seen] = 0.0
        indicator[seen, values[seen]] = 1.0
        indicators.append(indicator)
    totals, joints = entry(indicators)
    bad = np.flatnonzero(~(totals > 0.0))
    if bad.size:
        i = int(bad[0])
        case = {
            compiled.names[cols[j]]: compiled.states[cols[j]][table[i, j]]
            for j in used
            if table[i, j] >= 0
        }
        raise InputError(f"batched evidence case {i}: " + contraction.impossible(case))
    return {
        t: np.asarray(joint / totals[:, np.newaxis])
        for t, joint in zip(targets, joints, strict=True)
    }


class Pattern(NamedTuple):
    """The cases of a batch that observe the same variables."""

    rows: IntArray
    """Their rows in the batch."""
    ev_vars: list[int]
    """The observed variables' ids."""
    values: IntArray
    """``(len(rows), len(ev_vars))`` observed state indices."""


def posterior_batch(
    engine: Engine,
    target: str,
    evidence: BatchEvidence,
    numbers: Numbers[Any, A, Any],
    *,
    columns: Sequence[str] | None = None,
    soft: Mapping[str, npt.ArrayLike] | None = None,
) -> A:
    """``P(target | case)`` for many evidence cases at once, in ``numbers`` (float64 or fixed
    point, :mod:`bayesmap.bn.numbers`): shape ``(n_cases, n_states)``.

    Cases with the same observed variables are answered together (cases are grouped by
    their pattern of observed columns); each pattern's answers are the number system's
    (:meth:`~bayesmap.bn.numbers.Numbers.batch_marginal`).

    Parameters
    ----------
    target
        The queried variable.
    evidence
        An ``(n_cases, n_columns)`` integer array of state indices, −1 where a
        variable is unobserved, or a sequence of ``{variable: state}`` mappings.
    numbers
        The number system of the answers.
    columns
        Variable of each array column; default: all variables in network order.
    soft
        Soft evidence per case, ``{variable: (n_cases, n_states) weights}``.
    """
    compiled = engine.compiled
    t = compiled.id(target)
    table, cols = batch_array(engine, evidence, columns)
    weights = soft_weights(engine, table, cols, soft) if soft else {}
    groups = contraction.patterns(table) if table.shape[0] else []
    if not weights:
        whole = numbers.all_at_once(engine, t, table, cols, len(groups))
        if whole is not None:
            return whole
    parts: list[tuple[IntArray, A]] = []
    for rows, pattern in groups:
        ev_vars = [cols[j] for j in pattern]
        values = table[np.ix_(rows, pattern)]
        if t in ev_vars:
            contraction.batch_contract(
                engine,
                engine.plan(QueryKind.EVIDENCE, (), frozenset(ev_vars)),
                ev_vars,
                values,
                rows,
            )
            state = values[:, ev_vars.index(t)]
            parts.append((rows, numbers.one_hot_batch(compiled.card[t], state)))
            continue
        cases = Pattern(rows, ev_vars, values)
        parts.append((rows, numbers.batch_marginal(engine, t, cases, weights)))
    return numbers.stack(parts, table.shape[0], compiled.card[t])


def soft_marginal(
    engine: Engine, t: int, cases: Pattern, weights: Mapping[int, FloatArray]
) -> FloatArray:
    """``P(t | case)`` with soft evidence, for the cases of one pattern: ``P(t, S | case)``
    weighted by each case's likelihoods of the softly observed variables ``S`` and summed
    over ``S``."""
    compiled = engine.compiled
    rows, ev_vars, values = cases
    targets = (t, *(v for v in weights if v != t))
    plan = engine.plan(QueryKind.MARGINAL, targets, frozenset(ev_vars))
    joint = contraction.batch_contract(engine, plan, ev_vars, values, rows)
    for axis, v in enumerate(targets, start=1):
        if v in weights:
            shape = [len(rows)] + [1] * len(targets)
            shape[axis] = compiled.card[v]
            joint = joint * weights[v][rows].reshape(shape)
    answer = joint.reshape(len(rows), compiled.card[t], -1).sum(axis=2)
    totals = answer.sum(axis=1)
    bad = np.flatnonzero(~(totals > 0.0))
    if bad.size:
        raise InputError(
            f"batched evidence case {int(rows[bad[0]])}: the evidence and soft "
            "evidence have probability zero together"
        )
    return np.asarray(answer / totals[:, np.newaxis])


def soft_weights(
    engine: Engine, table: IntArray, cols: list[int], soft: Mapping[str, npt.ArrayLike]
) -> dict[int, FloatArray]:
    """Checked per-case likelihoods ``{variable id: (n_cases, n_states)}`` of a batch.

    Raises
    ------
    InputError
        A wrong shape; a negative, NaN or infinite weight, or all of a case's zero; or a
        variable observed in some case that also has soft evidence.
    """
    compiled = engine.compiled
    n = table.shape[0]
    weights: dict[int, FloatArray] = {}
    for name, value in soft.items():
        v = compiled.id(name)
        w = np.asarray(value, dtype=np.float64)
        if w.shape != (n, compiled.card[v]):
            raise InputError(
                f"soft evidence on {name!r}: need shape ({n}, {compiled.card[v]}) "
                f"(cases, states), got {w.shape}"
            )
        check_weights(name, w)
        if v in cols and np.any(table[:, cols.index(v)] >= 0):
            case = int(np.flatnonzero(table[:, cols.index(v)] >= 0)[0])
            raise InputError(
                f"batched evidence case {case}: {name!r} has both an observed state "
                "and soft evidence"
            )
        weights[v] = w
    return weights


def batch_answers(
    engine: Engine, t: int, ev_vars: Sequence[int], values: IntArray, rows: IntArray
) -> FloatArray:
    """``P(t | case)`` for the cases of one pattern, each distinct case contracted once.

    Cases are deduplicated (a robot's observations repeat), and the answers of each
    combination of observed states are memoised per network version (up to
    ``tuning.max_lookup`` entries per target and pattern), so a later batch contracts only
    the combinations it has not met before. Networks with data nodes skip both (a data
    node's table may change between calls).
    """
    compiled = engine.compiled
    plan = engine.plan(QueryKind.MARGINAL, (t,), frozenset(ev_vars))
    cards = [compiled.card[v] for v in ev_vars]
    combos = math.prod(cards)
    if compiled.sources or not ev_vars or combos >= 1 << 62:
        unnormalised = contraction.batch_contract(engine, plan, ev_vars, values, rows)
        return np.asarray(unnormalised / unnormalised.sum(axis=1, keepdims=True))
    codes = np.ravel_multi_index(tuple(values.T), cards)
    n_states = compiled.card[t]
    memo: FloatArray | None = None
    if combos * n_states <= engine.tuning.max_lookup:
        key = (t, tuple(ev_vars))
        memo = engine.answers.get(key)
        if memo is None:
            memo = engine.answers[key] = np.full((combos, n_states), np.nan)
    if memo is None:
        unique, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
        need = np.argsort(first)  # so an error names the earliest case
        unnormalised = contraction.batch_contract(
            engine, plan, ev_vars, values[first[need]], rows[first[need]]
        ).reshape(unique.size, n_states)
        table = np.empty((unique.size, n_states))
        table[need] = unnormalised / unnormalised.sum(axis=1, keepdims=True)
        return table[inverse.reshape(-1)]
    result = memo[codes]
    missing = np.flatnonzero(np.isnan(result[:, 0]))
    if missing.size:
        unique, first = np.unique(codes[missing], return_index=True)
        first = missing[first]
        need = np.argsort(first)
        unique, first = unique[need], first[need]
        if unique.size < 2 or not fill_from_joint(engine, plan, ev_vars, t, memo, unique.size):
            unnormalised = contraction.batch_contract(
                engine, plan, ev_vars, values[first], rows[first]
            )
            answers = unnormalised.reshape(unique.size, n_states)
            memo[unique] = answers / answers.sum(axis=1, keepdims=True)
        result[missing] = memo[codes[missing]]
    bad = np.flatnonzero(result[:, 0] < 0.0)
    if bad.size:
        case = {
            compiled.names[v]: compiled.states[v][values[bad[0], j]] for j, v in enumerate(ev_vars)
        }
        raise InputError(
            f"batched evidence case {int(rows[bad[0]])}: " + contraction.impossible(case)
        )
    return np.asarray(result)


def fill_from_joint(
    engine: Engine, plan: Plan, ev_vars: Sequence[int], t: int, memo: FloatArray, n_new: int
) -> bool:
    """Fill ``memo`` from one contraction of ``P(E, t)`` if that is the cheaper way.

    Contracting ``n_new`` cases with a case axis can cost far more than contracting the
    evidence-free joint of the observed variables and the target once (when the case
    axis multiplies a large intermediate). The multiply-adds of both orders are
    compared; impossible combinations get −1 (reported when a case uses them).
    """
    compiled = engine.compiled
    if not any(f.observed for f in plan.factors):
        return False
    cost = contraction.batch_order(plan, compiled, n_new, engine.tuning)[-1]
    per_case = cost * n_new / (1 << max(n_new, engine.tuning.batch_class).bit_length())
    if per_case <= engine.tuning.joint_above:
        return False
    joint_plan = engine.plan(QueryKind.MARGINAL, (*ev_vars, t), frozenset())
    _, joint_cost = plans.order(
        compiled, [f.free for f in joint_plan.factors], joint_plan.targets, tuning=engine.tuning
    )
    if joint_cost >= per_case:
        return False
    joint = np.asarray(contraction.contract(engine, joint_plan, {})).reshape(memo.shape)
    totals = joint.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        memo[:] = joint / totals[:, np.newaxis]
    memo[~(totals > 0.0)] = -1.0
    return True


def batch_array(
    engine: Engine, evidence: BatchEvidence, columns: Sequence[str] | None
) -> tuple[IntArray, list[int]]:
    """Checked ``(n_cases, n_columns)`` state indices of batched evidence, and the
    variable id of each column."""
    compiled = engine.compiled
    if not is_mapping_list(evidence):
        table = np.asarray(evidence)
        names = list(columns) if columns is not None else list(compiled.names)
        cols = [compiled.id(n) for n in names]
        if table.ndim != 2 or table.shape[1] != len(cols):
            raise InputError(
                f"batched evidence must have shape (n_cases, {len(cols)}) for columns "
                f"{names[:5]}{'...' if len(names) > 5 else ''}; got {table.shape}"
            )
        if not np.issubdtype(table.dtype, np.integer):
            raise InputError(f"batched evidence must hold integer state indices, got {table.dtype}")
        card = np.array([compiled.card[c] for c in cols])
        bad = np.argwhere((table < -1) | (table >= card))
        if bad.size:
            i, j = bad[0]
            raise InputError(
                f"batched evidence case {i}: {table[i, j]} is not a state index of "
                f"{names[j]!r} (0..{card[j] - 1}, or -1 for unobserved)"
            )
        return table.astype(np.int64), cols
    cases: Sequence[Evidence] = evidence  # type: ignore[assignment]
    cols = sorted({compiled.id(name) for case in cases for name in case})
    where = {c: j for j, c in enumerate(cols)}
    table = np.full((len(cases), len(cols)), -1, dtype=np.int64)
    for i, case in enumerate(cases):
        for name, state in case.items():
            v = compiled.id(name)
            table[i, where[v]] = compiled.state(v, state)
    return table, cols


def expected_counts(
    engine: Engine, table: IntArray, cols: Sequence[int], weights: FloatArray
) -> tuple[list[FloatArray], float]:
    """The E-step of EM: expected family counts of weighted cases, and their log-likelihood.

    For every variable ``v`` an array shaped like its CPT, ``(v, *parents)``, holds
    ``Σ_cases w · P(v, parents | case)`` (observed members fixed, unobserved ones
    weighted by their joint posterior); the float is ``Σ_cases w · log P(case)``. Cases
    are grouped by their pattern of observed columns, and each family's posterior of
    a pattern is one batched contraction.
    """
    compiled = engine.compiled
    n_vars = len(compiled.names)
    counts = [np.zeros(compiled.cpts[v].shape) for v in range(n_vars)]
    log_likelihood = 0.0
    for rows, pattern in contraction.patterns(table):
        ev_vars = [cols[j] for j in pattern]
        values = table[np.ix_(rows, pattern)]
        w = weights[rows]
        observed = frozenset(ev_vars)
        if ev_vars:
            plan = engine.plan(QueryKind.EVIDENCE, (), observed)
            p_case = contraction.batch_contract(engine, plan, ev_vars, values, rows).reshape(-1)
            log_likelihood += float(w @ np.log(p_case))
        where = {v: values[:, k] for k, v in enumerate(ev_vars)}
        for v in range(n_vars):
            if v in compiled.sources:  # a data node's table is not learned
                continue
            family = (v, *compiled.parents[v])
            free = tuple(m for m in family if m not in observed)
            fixed = [m for m in family if m in observed]
            if free:
                joint = contraction.batch_contract(
                    engine, engine.plan(QueryKind.MARGINAL, free, observed), ev_vars, values, rows
                )
                totals = joint.reshape(len(rows), -1).sum(axis=1)
                shape = (-1, *[1] * len(free))
                share = joint * (w / totals).reshape(shape)
            else:
                share = w
            view = counts[v].transpose([family.index(m) for m in (*fixed, *free)])
            if fixed:
                np.add.at(view, tuple(where[m] for m in fixed), share)
            else:
                view += share.sum(axis=0)
    return counts, log_likelihood


def is_mapping_list(evidence: object) -> bool:
    """Whether batched evidence is a non-empty sequence of ``{variable: state}`` mappings."""
    return (
        isinstance(evidence, Sequence)
        and not isinstance(evidence, (str, bytes))
        and len(evidence) > 0
        and all(isinstance(case, Mapping) for case in evidence)
    )
