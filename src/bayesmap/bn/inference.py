"""Exact inference on a :class:`~bayesmap.bn.model.BayesNet` (Post et al. 2016 §2.3, §3.2).

All questions reduce to contracting the network's CPTs, sliced by the evidence:

- posterior of one or several variables, eqs. 22–25: ``P(Se | Kn) ∝ Σ_Un Π_i P(X_i | Pa_i)``;
- the probability of the evidence, the denominator Σ of eq. 24;
- MAP/MPE over all non-evidence variables, eq. 13: ``argmax_x P(x ∩ e)`` by max-product;
- marginal MAP over a subset, eq. 14: ``argmax_x Σ_Z P(x ∩ Z | e)``, summing first, then
  maximising;
- batched evidence: many cases of the same observed variables as one leading array axis.

:class:`Engine` holds every cache (the compiled network, one :class:`~bayesmap.bn.plans.Plan`
per question and pattern of observed variables, compiled contractions with the
evidence-independent sub-trees pre-contracted) and is rebuilt when the network changes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import opt_einsum

from bayesmap._typing import FloatArray, IntArray
from bayesmap.bn import ancestral, elimination, plans
from bayesmap.bn.compiled import Compiled, NetworkLike
from bayesmap.bn.fixed_point import Fixed, FixedAlgebra, FixedResult, QFormat, normalise, ratio
from bayesmap.bn.plans import BATCH, Factor, Plan, symbol
from bayesmap.bn.propositions import Proposition, parse
from bayesmap.errors import InputError

Evidence = Mapping[str, str | int]
"""Observed values: ``{variable name: state name or index}``."""

BatchEvidence = npt.ArrayLike | Sequence[Evidence]
"""Many evidence cases: an ``(n_cases, n_columns)`` int array (−1 = unobserved) or mappings."""

_MAX_BATCH_EXPRESSIONS = 8
_MAX_LOOKUP = 1 << 16
"""Largest ``P(target | observed)`` table a batch may build instead of contracting per case."""


class Engine:
    """Exact inference with caches for one network (``BayesNet`` keeps one per network).

    Parameters
    ----------
    net
        The network; its ``version`` counter invalidates every cache on change.
    """

    def __init__(self, net: NetworkLike) -> None:
        self._net = net
        self._compiled: Compiled | None = None
        self._plans: dict[Any, Plan] = {}
        self._priors: dict[int, FloatArray] = {}
        self._tables: dict[Any, FloatArray] = {}

    # ----------------------------------------------------------------- plumbing
    @property
    def compiled(self) -> Compiled:
        """The compiled network, rebuilt (and all caches dropped) after a change."""
        compiled = self._compiled
        if compiled is None or compiled.version != self._net.version:
            compiled = self._compiled = Compiled(self._net)
            self._plans.clear()
            self._priors.clear()
            self._tables.clear()
        return compiled

    def plan(self, kind: str, targets: tuple[int, ...], evidence: frozenset[int]) -> Plan:
        """The cached plan of a question (``kind``: "sum", "evidence", "mpe")."""
        key = (kind, targets, evidence)
        plan = self._plans.get(key)
        if plan is None:
            compiled = self.compiled
            ev = tuple(sorted(evidence))
            if kind == "sum":
                plan = plans.build(compiled, targets, ev, prior=self.prior)
                plan.cache["ancestral"] = ancestral.is_exact(compiled, targets, evidence)
            elif kind == "evidence":
                plan = plans.build(compiled, (), ev, keep_all_components=True)
            else:
                plan = plans.build(
                    compiled, targets, ev, prune_barren=False, keep_all_components=True
                )
            self._plans[key] = plan
        return plan

    def prior(self, var: int) -> FloatArray:
        """Prior marginal ``P(var)`` (no evidence), computed once per network version."""
        compiled = self.compiled
        cached = self._priors.get(var)
        if cached is None:
            if var in compiled.sources:
                raise AssertionError("data nodes have no evidence-independent prior")
            plan = plans.build(compiled, (var,), (), prior=self.prior)
            equation = ",".join(f.term for f in plan.factors) + "->" + plan.output
            table = opt_einsum.contract(equation, *[f.array for f in plan.factors])
            cached = self._priors[var] = np.asarray(table / table.sum())
        return cached

    def _evidence_ids(self, evidence: Evidence) -> dict[int, int]:
        compiled = self.compiled
        return {
            compiled.id(name): compiled.state(compiled.id(name), s) for name, s in evidence.items()
        }

    # --------------------------------------------------------------- posteriors
    def posterior(self, target: str, evidence: Evidence) -> FloatArray:
        """``P(target | evidence)`` as an array over the target's states (eq. 25)."""
        compiled = self.compiled
        t = compiled.id(target)
        ev = self._evidence_ids(evidence)
        if t in ev:
            self.probability_of_evidence(evidence)  # raises on impossible evidence
            return _one_hot(compiled.card[t], ev[t])
        plan = self.plan("sum", (t,), frozenset(ev))
        order = plan.cache["ancestral"]
        if order is not None:
            names = self._source_evidence(ev)
            return ancestral.marginal(compiled, t, ev, self._priors, names, order)
        return _normalised(self._contract(plan, ev), evidence)

    def joint_posterior(self, targets: Sequence[str], evidence: Evidence) -> FloatArray:
        """``P(targets | evidence)`` as an array with one axis per target, in the given order."""
        compiled = self.compiled
        ids = tuple(compiled.id(t) for t in targets)
        if len(set(ids)) != len(ids):
            raise InputError(f"joint posterior: a target is listed twice in {list(targets)}")
        ev = self._evidence_ids(evidence)
        free = tuple(t for t in ids if t not in ev)
        if free:
            plan = self.plan("sum", free, frozenset(ev))
            table = _normalised(self._contract(plan, ev), evidence)
        else:
            self.probability_of_evidence(evidence)
            table = np.ones(())
        return _embed(table, ids, free, ev, compiled.card)

    def probability_of_evidence(self, evidence: Evidence) -> float:
        """``P(evidence)``, the normalising constant Σ of eq. 24 (1 for no evidence)."""
        ev = self._evidence_ids(evidence)
        plan = self.plan("evidence", (), frozenset(ev))
        value = float(self._contract(plan, ev, check=False))
        if value <= 0.0:
            raise InputError(_impossible(evidence))
        return value

    def _source_evidence(self, ev: Mapping[int, int]) -> Callable[[], dict[str, str]]:
        compiled = self.compiled
        return lambda: compiled.evidence_names(ev)

    def _contract(self, plan: Plan, ev: Mapping[int, int], *, check: bool = True) -> FloatArray:
        """Unnormalised contraction of one case (checks multiplied in unless ``check``)."""
        compiled = self.compiled
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        scale = 1.0
        for factor in plan.checks:
            scale *= float(_slice(compiled, factor, ev_idx, names))
        if check and scale == 0.0:
            raise InputError(_impossible(compiled.evidence_names(ev)))
        entry = plan.cache.get("single")
        if entry is None:
            entry = plan.cache["single"] = _single_program(plan, compiled)
        expression, observed = entry
        if not observed:
            result: FloatArray = expression
        else:
            result = expression(*[_slice(compiled, f, ev_idx, names) for f in observed])
        return result if check else result * scale

    # --------------------------------------------------------------------- batch
    def posterior_batch(
        self, target: str, evidence: BatchEvidence, *, columns: Sequence[str] | None = None
    ) -> FloatArray:
        """``P(target | case)`` for many evidence cases at once: shape ``(n_cases, n_states)``.

        Cases with the same observed variables are answered by one contraction with a
        leading case axis (cases are grouped by their pattern of observed columns).

        Parameters
        ----------
        target
            The queried variable.
        evidence
            An ``(n_cases, n_columns)`` integer array of state indices, −1 where a
            variable is unobserved, or a sequence of ``{variable: state}`` mappings.
        columns
            Variable of each array column; default: all variables in network order.
        """
        compiled = self.compiled
        t = compiled.id(target)
        table, cols = self._batch_array(evidence, columns)
        out = np.empty((table.shape[0], compiled.card[t]))
        for rows, pattern in _patterns(table):
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            if t in ev_vars:
                col = ev_vars.index(t)
                self._batch_contract(
                    self.plan("evidence", (), frozenset(ev_vars)), ev_vars, values, rows
                )
                out[rows] = np.eye(compiled.card[t])[values[:, col]]
                continue
            lookup = self._lookup_table(t, ev_vars, rows.size)
            if lookup is not None:
                answers = (
                    lookup[tuple(values.T)]
                    if ev_vars
                    else np.broadcast_to(lookup, (rows.size, lookup.shape[-1]))
                )
                bad = np.flatnonzero(np.isnan(answers[:, 0]))
                if bad.size:
                    case = {
                        compiled.names[v]: compiled.states[v][values[bad[0], j]]
                        for j, v in enumerate(ev_vars)
                    }
                    raise InputError(f"batched evidence case {rows[bad[0]]}: " + _impossible(case))
                out[rows] = answers
                continue
            plan = self.plan("sum", (t,), frozenset(ev_vars))
            unnormalised = self._batch_contract(plan, ev_vars, values, rows)
            out[rows] = unnormalised / unnormalised.sum(axis=1, keepdims=True)
        return out

    def _lookup_table(self, t: int, ev_vars: Sequence[int], n_cases: int) -> FloatArray | None:
        """``P(t | e)`` for every combination of the observed values, if that is cheaper.

        When a batch has at least as many cases as there are combinations of the observed
        variables' states, one contraction of the joint ``P(t, E)`` (evidence-independent,
        so cached per network version) answers every case by a table lookup. Axes: the
        observed variables in ``ev_vars`` order, then ``t``; NaN rows are impossible evidence.
        """
        compiled = self.compiled
        combos = math.prod(compiled.card[v] for v in ev_vars)
        if compiled.sources or combos > n_cases or combos * compiled.card[t] > _MAX_LOOKUP:
            return None
        key = ("lookup", t, tuple(ev_vars))
        cached = self._tables.get(key)
        if cached is None:
            plan = self.plan("sum", (*ev_vars, t), frozenset())
            joint = np.asarray(self._contract(plan, {}))
            with np.errstate(invalid="ignore", divide="ignore"):
                cached = joint / joint.sum(axis=-1, keepdims=True)
            cached[~(joint.sum(axis=-1) > 0)] = np.nan
            self._tables[key] = cached
        return cached

    def _batch_array(
        self, evidence: BatchEvidence, columns: Sequence[str] | None
    ) -> tuple[IntArray, list[int]]:
        compiled = self.compiled
        if not _is_mapping_list(evidence):
            table = np.asarray(evidence)
            names = list(columns) if columns is not None else list(compiled.names)
            cols = [compiled.id(n) for n in names]
            if table.ndim != 2 or table.shape[1] != len(cols):
                raise InputError(
                    f"batched evidence must have shape (n_cases, {len(cols)}) for columns "
                    f"{names[:5]}{'...' if len(names) > 5 else ''}; got {table.shape}"
                )
            if not np.issubdtype(table.dtype, np.integer):
                raise InputError(
                    f"batched evidence must hold integer state indices, got {table.dtype}"
                )
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

    def _batch_contract(
        self, plan: Plan, ev_vars: Sequence[int], values: IntArray, rows: IntArray
    ) -> FloatArray:
        """Unnormalised answers of many cases sharing ``plan``: shape ``(n, *targets)``."""
        compiled = self.compiled
        n = values.shape[0]
        order = [list(ev_vars).index(v) for v in plan.evidence]
        cols = [values[:, j] for j in order]
        case_names = _case_names(compiled, plan.evidence, cols)
        scale = np.ones(n)
        for factor in plan.checks:
            scale *= _slice_batch(compiled, factor, cols, case_names)
        observed = [f for f in plan.factors if f.observed]
        if observed:
            expression = _batch_expression(plan, compiled, n)
            result = expression(*[_slice_batch(compiled, f, cols, case_names) for f in observed])
        else:
            single, _ = plan.cache.get("single") or _single_program(plan, compiled)
            result = np.broadcast_to(single, (n, *np.shape(single)))
        totals = scale * result.reshape(n, -1).sum(axis=1)
        bad = np.flatnonzero(totals <= 0.0)
        if bad.size:
            case = {
                compiled.names[v]: compiled.states[v][c[bad[0]]]
                for v, c in zip(plan.evidence, cols, strict=True)
            }
            raise InputError(f"batched evidence case {int(rows[bad[0]])}: " + _impossible(case))
        return np.asarray(result)

    # ----------------------------------------------------------------------- MAP
    def mpe(self, evidence: Evidence) -> tuple[dict[str, str], float]:
        """Most probable joint state of all unobserved variables (eq. 13), by max-product.

        Returns the assignment and its posterior probability ``P(x | evidence)``.
        """
        compiled = self.compiled
        ev = self._evidence_ids(evidence)
        free = tuple(v for v in range(len(compiled.names)) if v not in ev)
        plan = self.plan("mpe", free, frozenset(ev))
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        log_scale = sum(_log(_slice(compiled, f, ev_idx, names)) for f in plan.checks)
        operands = [_log(_slice(compiled, f, ev_idx, names)) for f in plan.factors]
        path = plan.cache.get("path")
        if path is None:
            path = plan.cache["path"] = elimination.find_path(
                [f.term for f in plan.factors], "", [np.shape(op) for op in operands]
            )
        best: FloatArray = np.zeros(())
        records: list[elimination.Record] = []
        if operands:
            best, _, records = elimination.run(path, operands, elimination.LogMax())
        log_best = float(best) + log_scale
        if not math.isfinite(log_best):
            raise InputError(_impossible(evidence))
        choice = elimination.traceback(records)
        assignment = {compiled.names[v]: compiled.states[v][choice[symbol(v)]] for v in free}
        probability = math.exp(log_best - math.log(self.probability_of_evidence(evidence)))
        return assignment, min(probability, 1.0)

    def marginal_map(
        self, variables: Sequence[str], evidence: Evidence
    ) -> tuple[dict[str, str], float]:
        """Marginal MAP (eq. 14): ``argmax_x Σ_Z P(x, Z | evidence)`` over ``variables``.

        Exact: the other variables are summed out first (one opt_einsum contraction per
        connected group of them), then the resulting factors are maximised jointly.
        Returns the assignment and ``P(x | evidence)``.
        """
        compiled = self.compiled
        ids = tuple(compiled.id(v) for v in variables)
        ev = self._evidence_ids(evidence)
        query = tuple(v for v in dict.fromkeys(ids) if v not in ev)
        fixed = {compiled.names[v]: compiled.states[v][ev[v]] for v in ids if v in ev}
        if not query:
            return fixed, 1.0 if self.probability_of_evidence(evidence) > 0 else 0.0
        plan = self.plan("sum", query, frozenset(ev))
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        log_scale = sum(_log(_slice(compiled, f, ev_idx, names)) for f in plan.checks)
        sliced = [_slice(compiled, f, ev_idx, names) for f in plan.factors]
        groups = plan.cache.get("mmap")
        if groups is None:
            groups = plan.cache["mmap"] = _sum_groups(plan, set(query))
        operands: list[FloatArray] = []
        terms: list[str] = []
        for members, boundary in groups:
            part = [sliced[k] for k in members]
            if boundary is None:  # a factor over query variables only
                operands.append(_log(part[0]))
                terms.append(plan.factors[members[0]].term)
                continue
            equation = ",".join(plan.factors[k].term for k in members) + "->" + boundary
            operands.append(_log(opt_einsum.contract(equation, *part)))
            terms.append(boundary)
        path = elimination.find_path(terms, "", [np.shape(op) for op in operands])
        best, _, records = elimination.run(path, operands, elimination.LogMax())
        if not (math.isfinite(log_scale) and math.isfinite(float(best))):
            raise InputError(_impossible(evidence))
        choice = elimination.traceback(records)
        assignment = dict(fixed)
        for v in query:
            assignment[compiled.names[v]] = compiled.states[v][choice[symbol(v)]]
        equation = ",".join(f.term for f in plan.factors) + "->"
        total = float(opt_einsum.contract(equation, *sliced))
        probability = math.exp(float(best) - math.log(total))
        return assignment, min(probability, 1.0)

    def probability(self, proposition: Proposition | str, evidence: Evidence) -> float:
        """``P(proposition | evidence)`` (§2.4): the joint posterior summed where it holds."""
        prop = parse(proposition) if isinstance(proposition, str) else proposition
        names = prop.variables()
        joint = self.joint_posterior(names, evidence)
        grids: dict[str, IntArray] = dict(zip(names, np.indices(joint.shape), strict=True))
        compiled = self.compiled
        mask = prop.holds(grids, lambda var, state: compiled.state(compiled.id(var), state))
        return float(joint[mask].sum())

    def ancestral_posterior(self, target: str, evidence: Evidence) -> FloatArray:
        """The paper's recursive query (eq. 27); exact only where :func:`ancestral.is_exact`."""
        compiled = self.compiled
        t = compiled.id(target)
        ev = self._evidence_ids(evidence)
        if t in ev:
            return _one_hot(compiled.card[t], ev[t])
        return ancestral.marginal(compiled, t, ev, self._priors, self._source_evidence(ev))

    def ancestral_is_exact(self, target: str, evidence: Evidence) -> bool:
        """Whether the recursive query is exact for this target and these observed variables."""
        compiled = self.compiled
        ev = self._evidence_ids(evidence)
        return ancestral.is_exact(compiled, (compiled.id(target),), ev) is not None

    # --------------------------------------------------------------- fixed point
    def fixed_posterior(self, target: str, evidence: Evidence, q: QFormat) -> FixedResult:
        """``P(target | evidence)`` computed in Q-format integers, with its error bound."""
        compiled = self.compiled
        t = compiled.id(target)
        ev = self._evidence_ids(evidence)
        if t in ev:
            self.probability_of_evidence(evidence)
            one = _one_hot(compiled.card[t], ev[t])
            return FixedResult(q, (one * q.scale).astype(np.int64), one, np.zeros_like(one))
        plan = self.plan("sum", (t,), frozenset(ev))
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        if any(not float(_slice(compiled, f, ev_idx, names)) > 0.0 for f in plan.checks):
            raise InputError(_impossible(evidence))
        operands = [q.quantise(_slice(compiled, f, ev_idx, names)) for f in plan.factors]
        path = plan.cache.get("fixed_path")
        if path is None:
            path = plan.cache["fixed_path"] = elimination.find_path(
                [f.term for f in plan.factors], plan.output, [op.raw.shape for op in operands]
            )
        result, _, _ = elimination.run(path, operands, FixedAlgebra(q))
        return normalise(q, result, (0,), f"posterior of {target!r}")

    def fixed_posterior_batch(
        self,
        target: str,
        evidence: BatchEvidence,
        q: QFormat,
        *,
        columns: Sequence[str] | None = None,
    ) -> FixedResult:
        """:meth:`posterior_batch` in Q-format integers: one contraction per evidence pattern."""
        compiled = self.compiled
        t = compiled.id(target)
        table, cols = self._batch_array(evidence, columns)
        n_states = compiled.card[t]
        raw = np.empty((table.shape[0], n_states), dtype=np.int64)
        bound = np.empty((table.shape[0], n_states))
        for rows, pattern in _patterns(table):
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            plan = self.plan("sum", (t,), frozenset(ev_vars)) if t not in ev_vars else None
            if plan is None or not any(f.observed for f in plan.factors):
                for i, row in zip(rows, values, strict=True):
                    case = {compiled.names[v]: int(s) for v, s in zip(ev_vars, row, strict=True)}
                    one = self.fixed_posterior(target, case, q)
                    raw[i], bound[i] = one.raw, one.bound
                continue
            self._batch_contract(plan, ev_vars, values, rows)  # float check of the evidence
            order = [ev_vars.index(v) for v in plan.evidence]
            cols_k = [values[:, j] for j in order]
            case_names = _case_names(compiled, plan.evidence, cols_k)
            operands, terms = [], []
            for f in plan.factors:
                operands.append(q.quantise(_slice_batch(compiled, f, cols_k, case_names)))
                terms.append(BATCH + f.term if f.observed else f.term)
            path = elimination.find_path(
                terms, BATCH + plan.output, [o.raw.shape for o in operands]
            )
            result, term, _ = elimination.run(path, operands, FixedAlgebra(q))
            if term != BATCH + plan.output:
                axes = [term.index(ch) for ch in BATCH + plan.output]
                result = Fixed(result.raw.transpose(axes), result.error.transpose(axes))
            answer = normalise(q, result, (1,), f"posterior of {target!r}")
            raw[rows], bound[rows] = answer.raw, answer.bound
        return FixedResult(q, raw, q.to_float(raw), bound)

    def fixed_mpe(self, evidence: Evidence, q: QFormat) -> tuple[dict[str, str], FixedResult]:
        """:meth:`mpe` by max-product in Q-format integers.

        The probability returned is ``P(x | evidence)`` as a 0-d :class:`FixedResult`.
        """
        compiled = self.compiled
        ev = self._evidence_ids(evidence)
        free = tuple(v for v in range(len(compiled.names)) if v not in ev)
        algebra = FixedAlgebra(q, "max")
        best, records = self._fixed_scalar(self.plan("mpe", free, frozenset(ev)), ev, algebra)
        total, _ = self._fixed_scalar(self.plan("evidence", (), frozenset(ev)), ev, FixedAlgebra(q))
        choice = elimination.traceback(records)
        assignment = {compiled.names[v]: compiled.states[v][choice[symbol(v)]] for v in free}
        return assignment, ratio(q, best, total, "MAP")

    def _fixed_scalar(
        self, plan: Plan, ev: Mapping[int, int], algebra: FixedAlgebra
    ) -> tuple[Fixed, list[elimination.Record]]:
        compiled, q = self.compiled, algebra.q
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        operands = [q.quantise(_slice(compiled, f, ev_idx, names)) for f in plan.factors]
        key = ("fixed_scalar", algebra.reduce)
        path = plan.cache.get(key)
        if path is None:
            path = plan.cache[key] = elimination.find_path(
                [f.term for f in plan.factors], "", [op.raw.shape for op in operands]
            )
        value = Fixed(np.array(q.scale, dtype=np.int64), np.zeros(()))
        records: list[elimination.Record] = []
        if operands:
            value, _, records = elimination.run(path, operands, algebra)
        for f in plan.checks:
            value = algebra.multiply(value, q.quantise(_slice(compiled, f, ev_idx, names)))
        return value, records


# ------------------------------------------------------------------ helpers
def _slice(
    compiled: Compiled, factor: Factor, ev_idx: Sequence[int], names: Callable[[], dict[str, str]]
) -> FloatArray:
    """The factor's values for one evidence case."""
    array = factor.array
    if array is None:
        array = compiled.table(factor.var, names()).transpose(factor.perm)
    return array[factor.pick(ev_idx)] if factor.pick is not None else array


def _slice_batch(
    compiled: Compiled,
    factor: Factor,
    cols: Sequence[IntArray],
    case_names: Callable[[int], dict[str, str]],
) -> FloatArray:
    """The factor's values for many cases: a leading case axis if it depends on them."""
    index = tuple(cols[p] for p in factor.ev_pos)
    if factor.array is not None:
        return factor.array[index]
    n = len(cols[0]) if cols else 1
    stacked = np.stack([compiled.table(factor.var, case_names(i)) for i in range(n)])
    stacked = stacked.transpose(0, *(p + 1 for p in factor.perm))
    return stacked[(np.arange(n), *index)] if index else stacked


def _case_names(
    compiled: Compiled, evidence: Sequence[int], cols: Sequence[IntArray]
) -> Callable[[int], dict[str, str]]:
    return lambda i: {
        compiled.names[v]: compiled.states[v][int(c[i])]
        for v, c in zip(evidence, cols, strict=True)
    }


def _single_program(plan: Plan, compiled: Compiled) -> tuple[Any, list[Factor]]:
    """The compiled contraction of one case, or the constant result if nothing is observed."""
    equation = ",".join(f.term for f in plan.factors) + "->" + plan.output
    observed = [f for f in plan.factors if f.observed]
    if not plan.factors:
        return np.ones(()), []
    if not observed:
        arrays = [f.array for f in plan.factors]
        return np.asarray(opt_einsum.contract(equation, *arrays)), []
    specs: list[Any] = [
        tuple(compiled.card[v] for v in f.free) if f.observed else f.array for f in plan.factors
    ]
    program = elimination.SumProgram([f.term for f in plan.factors], plan.output, specs)
    return program, observed


def _batch_expression(plan: Plan, compiled: Compiled, n: int) -> Any:
    """A contraction expression for ``n`` cases (cached for a few batch sizes)."""
    cache: dict[int, Any] = plan.cache.setdefault("batch", {})
    expression = cache.get(n)
    if expression is None:
        terms: list[str] = []
        specs: list[Any] = []
        constants: list[int] = []
        for k, f in enumerate(plan.factors):
            if f.observed:
                terms.append(BATCH + f.term)
                specs.append((n, *(compiled.card[v] for v in f.free)))
            else:
                terms.append(f.term)
                specs.append(f.array)
                constants.append(k)
        equation = ",".join(terms) + "->" + BATCH + plan.output
        expression = opt_einsum.contract_expression(equation, *specs, constants=constants)
        if len(cache) >= _MAX_BATCH_EXPRESSIONS:
            cache.pop(next(iter(cache)))
        cache[n] = expression
    return expression


def _sum_groups(plan: Plan, query: set[int]) -> list[tuple[list[int], str | None]]:
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


def _patterns(table: IntArray) -> list[tuple[IntArray, IntArray]]:
    """Group batch rows by which columns are observed: ``[(rows, observed columns)]``."""
    observed = table >= 0
    used = np.flatnonzero(observed.any(axis=0))
    mask = observed[:, used]
    if mask.all():
        return [(np.arange(table.shape[0]), used)]
    if used.size <= 62:
        codes = mask.astype(np.int64) @ (np.int64(1) << np.arange(used.size, dtype=np.int64))
        keys, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
        patterns = mask[first]
    else:
        patterns, inverse = np.unique(mask, axis=0, return_inverse=True)
        keys = patterns
    inverse = inverse.reshape(-1)
    return [(np.flatnonzero(inverse == k), used[patterns[k]]) for k in range(len(keys))]


def _is_mapping_list(evidence: object) -> bool:
    return (
        isinstance(evidence, Sequence)
        and not isinstance(evidence, (str, bytes))
        and len(evidence) > 0
        and all(isinstance(case, Mapping) for case in evidence)
    )


def _log(values: FloatArray | float) -> Any:
    with np.errstate(divide="ignore"):
        return np.log(values)


def _normalised(table: FloatArray, evidence: Mapping[str, object]) -> FloatArray:
    total = table.sum()
    if not total > 0.0:
        raise InputError(_impossible(evidence))
    return np.asarray(table / total)


def _one_hot(size: int, index: int) -> FloatArray:
    out = np.zeros(size)
    out[index] = 1.0
    return out


def _embed(
    table: FloatArray,
    ids: tuple[int, ...],
    free: tuple[int, ...],
    ev: Mapping[int, int],
    card: Sequence[int],
) -> FloatArray:
    """Place a joint over the free targets into the full target grid (observed = one-hot)."""
    if len(free) == len(ids):
        return table
    out = np.zeros([card[v] for v in ids])
    index = tuple(slice(None) if v not in ev else ev[v] for v in ids)
    out[index] = table
    return out


def _impossible(evidence: Mapping[str, object]) -> str:
    shown = ", ".join(f"{k}={v}" for k, v in evidence.items())
    return (
        f"the evidence {{{shown}}} has probability zero under the network; "
        "check the observed states or the CPTs"
    )
