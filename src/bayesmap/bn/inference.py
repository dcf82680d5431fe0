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

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.bn import ancestral, elimination, marginals, plans
from bayesmap.bn.compiled import Compiled, NetworkLike
from bayesmap.bn.fixed_point import (
    Fixed,
    FixedAlgebra,
    FixedResult,
    QFormat,
    constant,
    normalise,
    ratio,
)
from bayesmap.bn.plans import BATCH, BatchOrder, Factor, Plan, QueryKind, symbol
from bayesmap.bn.propositions import Proposition, parse
from bayesmap.bn.soft import check_weights
from bayesmap.bn.tuning import TUNING, Tuning
from bayesmap.errors import InputError

Evidence = Mapping[str, str | int]
"""Observed values: ``{variable name: state name or index}``."""

BatchEvidence = npt.ArrayLike | Sequence[Evidence]
"""Many evidence cases: an ``(n_cases, n_columns)`` int array (−1 = unobserved) or mappings."""

_CASE = -1
"""Label of the case axis in batched contractions (variable ids are >= 0)."""


class Engine:
    """Exact inference with caches for one network (``BayesNet`` keeps one per network).

    Parameters
    ----------
    net
        The network; its ``version`` counter invalidates every cache on change.
    tuning
        Where the engine switches between equally exact ways to answer.
    """

    def __init__(self, net: NetworkLike, tuning: Tuning = TUNING) -> None:
        self._net = net
        self.tuning = tuning
        self._compiled: Compiled | None = None
        self._plans: dict[Any, Plan] = {}
        self._priors: dict[int, FloatArray] = {}
        self._all_priors = False
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
            self._all_priors = False
            self._tables.clear()
        return compiled

    def plan(self, kind: QueryKind, targets: tuple[int, ...], evidence: frozenset[int]) -> Plan:
        """The cached plan of a question of ``kind`` about ``targets`` (none for
        :attr:`QueryKind.EVIDENCE`) given which variables are observed."""
        key = (kind, targets, evidence)
        plan = self._plans.get(key)
        if plan is None:
            compiled = self.compiled
            ev = tuple(sorted(evidence))
            if kind is QueryKind.MARGINAL:
                self._compute_priors()
                plan = plans.build(compiled, kind, targets, ev, prior=self.prior)
                plan.cache.ancestral = ancestral.is_exact(compiled, targets, evidence)
            else:
                plan = plans.build(compiled, kind, targets, ev)
            self._plans[key] = plan
        return plan

    def prior(self, var: int) -> FloatArray:
        """Prior marginal ``P(var)`` (no evidence), computed once per network version."""
        compiled = self.compiled
        cached = self._priors.get(var)
        if cached is None:
            if var in compiled.sources:
                raise AssertionError("data nodes have no evidence-independent prior")
            plan = plans.build(compiled, QueryKind.MARGINAL, (var,), (), prior=self.prior)
            table, _ = _single_program(plan, compiled, self.tuning)
            cached = self._priors[var] = np.asarray(table / table.sum())
        return cached

    def _compute_priors(self) -> None:
        """Compute the prior marginal of every variable once per network version.

        The first new pattern of a network pays for it (1–250 ms on the bnlearn networks);
        every later plan then replaces evidence-free ancestral sub-networks by cached priors
        and checks dropped evidence without contracting anything new. Variables at or below
        a data node have no evidence-independent prior and are skipped.
        """
        if self._all_priors:
            return
        compiled = self.compiled
        for v in compiled.topo:
            if not compiled.source_mask & (compiled.ancestor_masks[v] | 1 << v):
                self.prior(v)
        self._all_priors = True

    def _check_dropped(
        self, plan: Plan, values: Callable[[int], Any], case: Callable[[], str]
    ) -> None:
        """Raise if an observed state left out of the contraction has prior probability 0.

        Evidence in a component d-separated from the targets does not change the answer and
        is not contracted; each such observed state (``values(v)``: an index or an index
        array) must still have a nonzero prior marginal. Variables below a data node have no
        cached prior and are not checked; nor are zero-probability *combinations* of states
        that are each possible.
        """
        compiled = self.compiled
        checkable = plan.cache.checkable
        if checkable is None:
            checkable = plan.cache.checkable = tuple(
                v
                for v in plan.dropped
                if not compiled.source_mask & (compiled.ancestor_masks[v] | 1 << v)
            )
        for v in checkable:
            if not np.all(self.prior(v)[values(v)] > 0.0):
                raise InputError(case())

    def _evidence_ids(self, evidence: Evidence) -> dict[int, int]:
        compiled = self.compiled
        return {
            compiled.id(name): compiled.state(compiled.id(name), s) for name, s in evidence.items()
        }

    def _joint_query(
        self, targets: Sequence[str], evidence: Evidence
    ) -> tuple[dict[int, int], tuple[int, ...], tuple[int, ...]]:
        """``(evidence ids, target ids, unobserved target ids)`` of a joint posterior."""
        compiled = self.compiled
        ids = tuple(compiled.id(t) for t in targets)
        if len(set(ids)) != len(ids):
            raise InputError(f"joint posterior: a target is listed twice in {list(targets)}")
        ev = self._evidence_ids(evidence)
        return ev, ids, tuple(t for t in ids if t not in ev)

    def _map_query(
        self, variables: Sequence[str], evidence: Evidence
    ) -> tuple[dict[int, int], tuple[int, ...], dict[str, str]]:
        """``(evidence ids, unobserved MAP variable ids, observed MAP variables' states)``."""
        compiled = self.compiled
        ids = tuple(compiled.id(v) for v in variables)
        ev = self._evidence_ids(evidence)
        query = tuple(v for v in dict.fromkeys(ids) if v not in ev)
        fixed = {compiled.names[v]: compiled.states[v][ev[v]] for v in ids if v in ev}
        return ev, query, fixed

    # --------------------------------------------------------------- posteriors
    def posterior(self, target: str, evidence: Evidence) -> FloatArray:
        """``P(target | evidence)`` as an array over the target's states (eq. 25)."""
        compiled = self.compiled
        t = compiled.id(target)
        ev = self._evidence_ids(evidence)
        if t in ev:
            self.probability_of_evidence(evidence)  # raises on impossible evidence
            return _one_hot(compiled.card[t], ev[t])
        plan = self.plan(QueryKind.MARGINAL, (t,), frozenset(ev))
        if plan.dropped:
            self._check_dropped(plan, ev.__getitem__, lambda: _impossible(evidence))
        order = plan.cache.ancestral
        if order is not None:
            names = self._source_evidence(ev)
            return ancestral.marginal(compiled, t, ev, self._priors, names, order)
        return _normalised(self._contract(plan, ev), evidence)

    def joint_posterior(self, targets: Sequence[str], evidence: Evidence) -> FloatArray:
        """``P(targets | evidence)`` as an array with one axis per target, in the given order."""
        compiled = self.compiled
        ev, ids, free = self._joint_query(targets, evidence)
        if free:
            plan = self.plan(QueryKind.MARGINAL, free, frozenset(ev))
            if plan.dropped:
                self._check_dropped(plan, ev.__getitem__, lambda: _impossible(evidence))
            table = _normalised(self._contract(plan, ev), evidence)
        else:
            self.probability_of_evidence(evidence)
            table = np.ones(())
        return _embed(table, ids, free, ev, compiled.card)

    def posteriors(self, evidence: Evidence) -> dict[int, FloatArray]:
        """``P(v | evidence)`` of every unobserved variable ``v`` from one two-pass
        contraction (:mod:`bayesmap.bn.marginals`), by variable id."""
        compiled = self.compiled
        ev = self._evidence_ids(evidence)
        free = tuple(v for v in range(len(compiled.names)) if v not in ev)
        if not free:
            self.probability_of_evidence(evidence)
            return {}
        plan = self.plan(QueryKind.WHOLE, free, frozenset(ev))  # every variable, nothing pruned
        if not self._two_pass_pays(plan, free):
            return {v: self.posterior(compiled.names[v], evidence) for v in free}
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        scale = 1.0
        for factor in plan.checks:
            scale *= float(_slice(compiled, factor, ev_idx, names))
        program, wanted = self._two_pass(plan, free, ())
        operands = [_slice(compiled, f, ev_idx, names) for f in plan.factors if f.observed]
        total, joints = program(operands)
        if not float(total) * scale > 0.0:
            raise InputError(_impossible(evidence))
        return {v: np.asarray(j / j.sum()) for (_, v), j in zip(wanted, joints, strict=True)}

    def posteriors_batch(
        self,
        evidence: BatchEvidence,
        columns: Sequence[str] | None,
        targets: Sequence[str] | None = None,
    ) -> dict[int, FloatArray]:
        """:meth:`posteriors` of many cases: ``{variable id: (n_cases, n_states)}`` of every
        variable, or of ``targets`` (observed: one-hot).

        Cases are grouped by their pattern of observed columns, one two-pass contraction
        per pattern; when the cases spread over more than ``tuning.many_patterns`` patterns, all
        are answered by one contraction with evidence indicators instead
        (:meth:`_indicator_batch`).
        """
        compiled = self.compiled
        table, cols = self.batch_array(evidence, columns)
        n = table.shape[0]
        wanted = (
            range(len(compiled.names)) if targets is None else [compiled.id(t) for t in targets]
        )
        groups = _patterns(table) if n else []
        if len(groups) > self.tuning.many_patterns and not compiled.sources:
            return self._indicator_batch(tuple(dict.fromkeys(wanted)), table, cols)
        out = {v: np.zeros((n, compiled.card[v])) for v in range(len(compiled.names))}
        for rows, pattern in groups:
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            self._batch_contract(
                self.plan(QueryKind.EVIDENCE, (), frozenset(ev_vars)), ev_vars, values, rows
            )
            for k, v in enumerate(ev_vars):
                out[v][rows, values[:, k]] = 1.0
            free = tuple(v for v in range(len(compiled.names)) if v not in set(ev_vars))
            if not free:
                continue
            plan = self.plan(QueryKind.WHOLE, free, frozenset(ev_vars))
            if not self._two_pass_pays(plan, free):
                names = [compiled.names[v] for v in ev_vars]
                for v in free:
                    out[v][rows] = self.posterior_batch(compiled.names[v], values, columns=names)
                continue
            if not any(f.observed for f in plan.factors):  # the free part ignores the evidence
                answers = self.posteriors({})
                for v in free:
                    out[v][rows] = answers[v]
                continue
            order = [ev_vars.index(v) for v in plan.evidence]
            cols_k = [values[:, j] for j in order]
            case_names = _case_names(compiled, plan.evidence, cols_k)
            operands = [
                _slice_batch(compiled, f, cols_k, case_names) for f in plan.factors if f.observed
            ]
            size_class = 1 << max(len(rows), self.tuning.batch_class).bit_length()
            program, pairs = self._two_pass(plan, free, (_CASE,), size_class)
            _, joints = program(operands)
            for (_, v), joint in zip(pairs, joints, strict=True):
                out[v][rows] = joint / joint.sum(axis=1, keepdims=True)
        return {v: out[v] for v in wanted}

    def _indicator_batch(
        self, targets: tuple[int, ...], table: IntArray, cols: Sequence[int]
    ) -> dict[int, FloatArray]:
        """Posteriors of ``targets`` for cases with many patterns of blanks, all at once.

        Each observed column becomes a factor over the case axis and its variable — one-hot
        where the case observes it, ones where it is blank — so every case shares one
        contraction of the (evidence-free, pruned) network with these indicators, and its
        reverse gives every target's joint with the case's evidence (:mod:`marginals`).
        """
        compiled = self.compiled
        n = table.shape[0]
        used = [j for j in range(table.shape[1]) if np.any(table[:, j] >= 0)]
        observed = tuple(cols[j] for j in used)
        keep = tuple(dict.fromkeys((*targets, *observed)))
        plan = self.plan(QueryKind.MARGINAL, keep, frozenset())
        size_class = 1 << max(n, self.tuning.batch_class).bit_length()
        key = (observed, targets, size_class)
        entry = plan.cache.indicators.get(key)
        if entry is None:
            scopes = [f.free for f in plan.factors] + [(_CASE, v) for v in observed]
            constants: list[FloatArray | None] = [f.array for f in plan.factors]
            constants += [None] * len(observed)
            sizes: dict[Any, int] = dict(enumerate(compiled.card))
            sizes[_CASE] = size_class
            path, _, _ = plans.order_steps(
                compiled, scopes, (_CASE,), {_CASE: size_class}, tuning=self.tuning
            )
            own = {f.var: k for k, f in enumerate(plan.factors) if f.var in targets}
            pairs = [(own[t], t) for t in targets]
            entry = plan.cache.indicators[key] = marginals.TwoPass(
                scopes, constants, path, (_CASE,), sizes, pairs, tuning=self.tuning
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
            raise InputError(f"batched evidence case {i}: " + _impossible(case))
        return {
            t: np.asarray(joint / totals[:, np.newaxis])
            for t, joint in zip(targets, joints, strict=True)
        }

    def _two_pass_pays(self, plan: Plan, free: tuple[int, ...]) -> bool:
        """Whether one two-pass contraction of the whole network costs less than one pruned
        contraction per variable (decided once per pattern, by multiply-adds plus a fixed
        cost per call: the per-variable plans prune barren nodes and reuse priors, which on
        some networks — munin1 — beats three contractions of everything)."""
        decision = plan.cache.two_pass_pays
        if decision is None:
            compiled = self.compiled
            ev = frozenset(plan.evidence)
            _, _, forward = self._two_pass_order(plan, ())
            call_cost = self.tuning.call_cost
            budget = 3 * forward + 3 * len(plan.factors) * call_cost
            loop = 0
            for v in free:
                single = self.plan(QueryKind.MARGINAL, (v,), ev)
                loop += call_cost * self.tuning.calls_per_question
                if single.cache.ancestral is None and single.factors:
                    scopes = [f.free for f in single.factors]
                    loop += plans.order(compiled, scopes, single.targets, tuning=self.tuning)[1]
                if loop > budget:
                    break
            decision = plan.cache.two_pass_pays = budget <= loop
        return decision

    def _two_pass_order(
        self, plan: Plan, output: tuple[int, ...], cases: int = 1
    ) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]], int]:
        """Scopes, contraction order and multiply-adds of a plan's two-pass contraction."""
        entry = plan.cache.two_pass_order.get((output, cases))
        if entry is None:
            batched = bool(output)
            scopes = [(_CASE, *f.free) if batched and f.observed else f.free for f in plan.factors]
            path, _, cost = plans.order_steps(
                self.compiled, scopes, output, {_CASE: cases}, tuning=self.tuning
            )
            entry = plan.cache.two_pass_order[output, cases] = (scopes, path, cost)
        return entry

    def _two_pass(
        self, plan: Plan, free: tuple[int, ...], output: tuple[int, ...], cases: int = 1
    ) -> tuple[marginals.TwoPass, list[tuple[int, int]]]:
        """The compiled two-pass contraction of a plan and its wanted ``(factor, variable)``
        pairs (cached in the plan; a batch's per size class of ``cases``)."""
        entry = plan.cache.two_pass.get((output, cases))
        if entry is None:
            compiled = self.compiled
            scopes, path, _ = self._two_pass_order(plan, output, cases)
            sizes: dict[Any, int] = dict(enumerate(compiled.card))
            sizes[_CASE] = cases
            own = {f.var: k for k, f in enumerate(plan.factors)}
            wanted = [(own[v], v) for v in free]
            constants = [None if f.observed else f.array for f in plan.factors]
            program = marginals.TwoPass(
                scopes, constants, path, output, sizes, wanted, tuning=self.tuning
            )
            entry = plan.cache.two_pass[output, cases] = (program, wanted)
        return entry

    def probability_of_evidence(self, evidence: Evidence) -> float:
        """``P(evidence)``, the normalising constant Σ of eq. 24 (1 for no evidence)."""
        ev = self._evidence_ids(evidence)
        plan = self.plan(QueryKind.EVIDENCE, (), frozenset(ev))
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
        entry = plan.cache.single
        if entry is None:
            entry = plan.cache.single = _single_program(plan, compiled, self.tuning)
        expression, observed = entry
        if not observed:
            result: FloatArray = expression
        else:
            result = expression(*[_slice(compiled, f, ev_idx, names) for f in observed])
        return result if check else result * scale

    # --------------------------------------------------------------------- batch
    def posterior_batch(
        self,
        target: str,
        evidence: BatchEvidence,
        *,
        columns: Sequence[str] | None = None,
        soft: Mapping[str, npt.ArrayLike] | None = None,
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
        soft
            Soft evidence per case, ``{variable: (n_cases, n_states) weights}``: the joint
            posterior of the target and these variables is weighted by them and summed
            (its size grows with the product of their state counts).
        """
        compiled = self.compiled
        t = compiled.id(target)
        table, cols = self.batch_array(evidence, columns)
        if table.shape[0] == 0:
            return np.empty((0, compiled.card[t]))
        if soft:
            return self._soft_batch(t, table, cols, soft)
        groups = _patterns(table)
        if len(groups) > self.tuning.many_patterns and not compiled.sources:
            return self._indicator_batch((t,), table, cols)[t]
        out = np.empty((table.shape[0], compiled.card[t]))
        for rows, pattern in groups:
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            if t in ev_vars:
                col = ev_vars.index(t)
                self._batch_contract(
                    self.plan(QueryKind.EVIDENCE, (), frozenset(ev_vars)), ev_vars, values, rows
                )
                out[rows] = np.eye(compiled.card[t])[values[:, col]]
                continue
            out[rows] = self._batch_answers(t, ev_vars, values, rows)
        return out

    def _soft_batch(
        self, t: int, table: IntArray, cols: list[int], soft: Mapping[str, npt.ArrayLike]
    ) -> FloatArray:
        """:meth:`posterior_batch` with soft evidence: ``P(t, S | case)`` weighted by each
        case's likelihoods of the softly observed variables ``S`` and summed over ``S``."""
        compiled = self.compiled
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
        out = np.empty((n, compiled.card[t]))
        for rows, pattern in _patterns(table):
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            if t in ev_vars:
                out[rows] = self.posterior_batch(
                    compiled.names[t], values, columns=[compiled.names[v] for v in ev_vars]
                )
                continue
            targets = (t, *(v for v in weights if v != t))
            plan = self.plan(QueryKind.MARGINAL, targets, frozenset(ev_vars))
            joint = self._batch_contract(plan, ev_vars, values, rows)
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
            out[rows] = answer / totals[:, np.newaxis]
        return out

    def _batch_answers(
        self, t: int, ev_vars: Sequence[int], values: IntArray, rows: IntArray
    ) -> FloatArray:
        """``P(t | case)`` for the cases of one pattern, each distinct case contracted once.

        Cases are deduplicated (a robot's observations repeat), and the answers of each
        combination of observed states are memoised per network version (up to
        ``tuning.max_lookup`` entries per target and pattern), so a later batch contracts only
        the combinations it has not met before. Networks with data nodes skip both (a data
        node's table may change between calls).
        """
        compiled = self.compiled
        plan = self.plan(QueryKind.MARGINAL, (t,), frozenset(ev_vars))
        cards = [compiled.card[v] for v in ev_vars]
        combos = math.prod(cards)
        if compiled.sources or not ev_vars or combos >= 1 << 62:
            unnormalised = self._batch_contract(plan, ev_vars, values, rows)
            return np.asarray(unnormalised / unnormalised.sum(axis=1, keepdims=True))
        codes = np.ravel_multi_index(tuple(values.T), cards)
        n_states = compiled.card[t]
        memo: FloatArray | None = None
        if combos * n_states <= self.tuning.max_lookup:
            key = ("answers", t, tuple(ev_vars))
            memo = self._tables.get(key)
            if memo is None:
                memo = self._tables[key] = np.full((combos, n_states), np.nan)
        if memo is None:
            unique, first, inverse = np.unique(codes, return_index=True, return_inverse=True)
            need = np.argsort(first)  # so an error names the earliest case
            unnormalised = self._batch_contract(
                plan, ev_vars, values[first[need]], rows[first[need]]
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
            if unique.size < 2 or not self._fill_from_joint(plan, ev_vars, t, memo, unique.size):
                unnormalised = self._batch_contract(plan, ev_vars, values[first], rows[first])
                answers = unnormalised.reshape(unique.size, n_states)
                memo[unique] = answers / answers.sum(axis=1, keepdims=True)
            result[missing] = memo[codes[missing]]
        bad = np.flatnonzero(result[:, 0] < 0.0)
        if bad.size:
            case = {
                compiled.names[v]: compiled.states[v][values[bad[0], j]]
                for j, v in enumerate(ev_vars)
            }
            raise InputError(f"batched evidence case {int(rows[bad[0]])}: " + _impossible(case))
        return np.asarray(result)

    def _fill_from_joint(
        self, plan: Plan, ev_vars: Sequence[int], t: int, memo: FloatArray, n_new: int
    ) -> bool:
        """Fill ``memo`` from one contraction of ``P(E, t)`` if that is the cheaper way.

        Contracting ``n_new`` cases with a case axis can cost far more than contracting the
        evidence-free joint of the observed variables and the target once (when the case
        axis multiplies a large intermediate). The multiply-adds of both orders are
        compared; impossible combinations get −1 (reported when a case uses them).
        """
        compiled = self.compiled
        if not any(f.observed for f in plan.factors):
            return False
        cost = _batch_order(plan, compiled, n_new, self.tuning)[-1]
        per_case = cost * n_new / (1 << max(n_new, self.tuning.batch_class).bit_length())
        if per_case <= self.tuning.joint_above:
            return False
        joint_plan = self.plan(QueryKind.MARGINAL, (*ev_vars, t), frozenset())
        _, joint_cost = plans.order(
            compiled, [f.free for f in joint_plan.factors], joint_plan.targets, tuning=self.tuning
        )
        if joint_cost >= per_case:
            return False
        joint = np.asarray(self._contract(joint_plan, {})).reshape(memo.shape)
        totals = joint.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            memo[:] = joint / totals[:, np.newaxis]
        memo[~(totals > 0.0)] = -1.0
        return True

    def batch_array(
        self, evidence: BatchEvidence, columns: Sequence[str] | None
    ) -> tuple[IntArray, list[int]]:
        """Checked ``(n_cases, n_columns)`` state indices of batched evidence, and the
        variable id of each column."""
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

    def expected_counts(
        self, table: IntArray, cols: Sequence[int], weights: FloatArray
    ) -> tuple[list[FloatArray], float]:
        """The E-step of EM: expected family counts of weighted cases, and their log-likelihood.

        For every variable ``v`` an array shaped like its CPT, ``(v, *parents)``, holds
        ``Σ_cases w · P(v, parents | case)`` (observed members fixed, unobserved ones
        weighted by their joint posterior); the float is ``Σ_cases w · log P(case)``. Cases
        are grouped by their pattern of observed columns, and each family's posterior of
        a pattern is one batched contraction.
        """
        compiled = self.compiled
        n_vars = len(compiled.names)
        counts = [np.zeros(compiled.cpts[v].shape) for v in range(n_vars)]
        log_likelihood = 0.0
        for rows, pattern in _patterns(table):
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            w = weights[rows]
            observed = frozenset(ev_vars)
            if ev_vars:
                plan = self.plan(QueryKind.EVIDENCE, (), observed)
                p_case = self._batch_contract(plan, ev_vars, values, rows).reshape(-1)
                log_likelihood += float(w @ np.log(p_case))
            where = {v: values[:, k] for k, v in enumerate(ev_vars)}
            for v in range(n_vars):
                if v in compiled.sources:  # a data node's table is not learned
                    continue
                family = (v, *compiled.parents[v])
                free = tuple(m for m in family if m not in observed)
                fixed = [m for m in family if m in observed]
                if free:
                    joint = self._batch_contract(
                        self.plan(QueryKind.MARGINAL, free, observed), ev_vars, values, rows
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

    def _batch_contract(
        self, plan: Plan, ev_vars: Sequence[int], values: IntArray, rows: IntArray
    ) -> FloatArray:
        """Unnormalised answers of many cases sharing ``plan``: shape ``(n, *targets)``."""
        compiled = self.compiled
        n = values.shape[0]
        order = [list(ev_vars).index(v) for v in plan.evidence]
        cols = [values[:, j] for j in order]
        case_names = _case_names(compiled, plan.evidence, cols)
        if plan.dropped:
            where = dict(zip(plan.evidence, cols, strict=True))

            def first_bad() -> str:
                ok = np.logical_and.reduce(
                    [self.prior(v)[where[v]] > 0.0 for v in plan.cache.checkable or ()]
                )
                i = int(np.flatnonzero(~ok)[0])
                return f"batched evidence case {int(rows[i])}: " + _impossible(case_names(i))

            self._check_dropped(plan, where.__getitem__, first_bad)
        scale = np.ones(n)
        for factor in plan.checks:
            scale *= _slice_batch(compiled, factor, cols, case_names)
        observed = [f for f in plan.factors if f.observed]
        if observed:
            expression = _batch_expression(plan, compiled, n, self.tuning)
            result = expression(*[_slice_batch(compiled, f, cols, case_names) for f in observed])
        else:
            single, _ = plan.cache.single or _single_program(plan, compiled, self.tuning)
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
        plan = self.plan(QueryKind.WHOLE, free, frozenset(ev))
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        log_scale = sum(_log(_slice(compiled, f, ev_idx, names)) for f in plan.checks)
        operands = [_log(_slice(compiled, f, ev_idx, names)) for f in plan.factors]
        path = plan.cache.scalar_path
        if path is None:
            path = plan.cache.scalar_path = elimination.find_path(
                [f.term for f in plan.factors],
                "",
                [np.shape(op) for op in operands],
                tuning=self.tuning,
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
        ev, query, fixed = self._map_query(variables, evidence)
        if not query:
            return fixed, 1.0 if self.probability_of_evidence(evidence) > 0 else 0.0
        plan = self.plan(QueryKind.MARGINAL, query, frozenset(ev))
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        log_scale = sum(_log(_slice(compiled, f, ev_idx, names)) for f in plan.checks)
        sliced = [_slice(compiled, f, ev_idx, names) for f in plan.factors]
        groups = plan.cache.groups
        if groups is None:
            groups = plan.cache.groups = _sum_groups(plan, set(query))
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
        path = elimination.find_path(
            terms, "", [np.shape(op) for op in operands], tuning=self.tuning
        )
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

    def probability(
        self,
        proposition: Proposition | str,
        evidence: Evidence,
        given: Proposition | str | None = None,
    ) -> float:
        """``P(proposition | given, evidence)`` (§2.4, eqs. 15–21): the joint posterior of
        the mentioned variables summed where both hold, over the sum where ``given`` holds."""
        names, holds, condition = self._truth(proposition, given)
        joint = self.joint_posterior(names, evidence)
        if condition is None:
            return float(joint[holds].sum())
        total = float(joint[condition].sum())
        if not total > 0.0:
            raise InputError(f"the condition {given} has probability zero given the evidence")
        return float(joint[holds & condition].sum()) / total

    def _truth(
        self, proposition: Proposition | str, given: Proposition | str | None
    ) -> tuple[tuple[str, ...], BoolArray, BoolArray | None]:
        """Variables mentioned by a proposition and its condition, and where each holds on
        the grid of their joint states (condition ``None`` when there is none)."""
        prop = parse(proposition) if isinstance(proposition, str) else proposition
        cond = parse(given) if isinstance(given, str) else given
        names = prop.variables() if cond is None else (*prop.variables(), *cond.variables())
        names = tuple(dict.fromkeys(names))
        compiled = self.compiled
        ids = [compiled.id(n) for n in names]
        shape = [compiled.card[v] for v in ids]
        grids: dict[str, IntArray] = dict(zip(names, np.indices(shape), strict=True))

        def index(var: str, state: str) -> int:
            return compiled.state(compiled.id(var), state)

        holds = np.broadcast_to(prop.holds(grids, index), shape)
        if cond is None:
            return names, holds, None
        return names, holds, np.broadcast_to(cond.holds(grids, index), shape)

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
        return self.fixed_joint_posterior([target], evidence, q)

    def fixed_joint_posterior(
        self, targets: Sequence[str], evidence: Evidence, q: QFormat
    ) -> FixedResult:
        """:meth:`joint_posterior` in Q-format integers: same plan, block floating point."""
        compiled = self.compiled
        ev, ids, free = self._joint_query(targets, evidence)
        if not free:
            self.probability_of_evidence(evidence)
            answer = constant(q, np.ones(()))
        else:
            joint = self._fixed_sum(
                self.plan(QueryKind.MARGINAL, free, frozenset(ev)), ev, evidence, q
            )
            what = f"posterior of {list(targets)}"
            answer = normalise(q, joint, tuple(range(len(free))), what)
        raw = _embed(answer.raw.astype(np.float64), ids, free, ev, compiled.card).astype(np.int64)
        bound = _embed(answer.bound, ids, free, ev, compiled.card)
        return FixedResult(q, raw, q.to_float(raw), bound)

    def fixed_posterior_batch(
        self,
        target: str,
        evidence: BatchEvidence,
        q: QFormat,
        *,
        columns: Sequence[str] | None = None,
    ) -> FixedResult:
        """:meth:`posterior_batch` in Q-format integers: one contraction per evidence pattern,
        one block exponent per case."""
        compiled = self.compiled
        t = compiled.id(target)
        table, cols = self.batch_array(evidence, columns)
        n_states = compiled.card[t]
        raw = np.empty((table.shape[0], n_states), dtype=np.int64)
        bound = np.empty((table.shape[0], n_states))
        for rows, pattern in _patterns(table):
            ev_vars = [cols[j] for j in pattern]
            values = table[np.ix_(rows, pattern)]
            plan = (
                self.plan(QueryKind.MARGINAL, (t,), frozenset(ev_vars))
                if t not in ev_vars
                else None
            )
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
                sliced = _slice_batch(compiled, f, cols_k, case_names)
                operands.append(q.quantise(sliced, case_axis=f.observed))
                terms.append(BATCH + f.term if f.observed else f.term)
            path = plan.cache.fixed_batch_path
            if path is None:
                path = plan.cache.fixed_batch_path = elimination.find_path(
                    terms, BATCH + plan.output, [o.raw.shape for o in operands], tuning=self.tuning
                )
            result, term, _ = elimination.run(path, operands, FixedAlgebra(q))
            if term != BATCH + plan.output:
                result = result.transpose([term.index(ch) for ch in BATCH + plan.output])
            answer = normalise(q, result, (1,), f"posterior of {target!r}")
            raw[rows], bound[rows] = answer.raw, answer.bound
        return FixedResult(q, raw, q.to_float(raw), bound)

    def fixed_mpe(self, evidence: Evidence, q: QFormat) -> tuple[dict[str, str], FixedResult]:
        """:meth:`mpe` by max-product in Q-format integers.

        The probability returned is ``P(x | evidence)`` as a 0-d :class:`FixedResult`; its
        bound covers both the exact probability of the returned assignment and the exact
        maximum.
        """
        compiled = self.compiled
        ev = self._evidence_ids(evidence)
        free = tuple(v for v in range(len(compiled.names)) if v not in ev)
        algebra = FixedAlgebra(q, "max")
        best, records = self._fixed_scalar(
            self.plan(QueryKind.WHOLE, free, frozenset(ev)), ev, algebra
        )
        total, _ = self._fixed_scalar(
            self.plan(QueryKind.EVIDENCE, (), frozenset(ev)), ev, FixedAlgebra(q)
        )
        choice = elimination.traceback(records)
        assignment = {compiled.names[v]: compiled.states[v][choice[symbol(v)]] for v in free}
        return assignment, ratio(q, best, total, "MAP")

    def fixed_marginal_map(
        self, variables: Sequence[str], evidence: Evidence, q: QFormat
    ) -> tuple[dict[str, str], FixedResult]:
        """:meth:`marginal_map` in Q-format integers: the same sum groups, summed then
        maximised in block floating point; ``P(x | evidence)`` as a 0-d :class:`FixedResult`."""
        compiled = self.compiled
        ev, query, fixed = self._map_query(variables, evidence)
        if not query:
            self.probability_of_evidence(evidence)
            return fixed, constant(q, np.ones(()))
        plan = self.plan(QueryKind.MARGINAL, query, frozenset(ev))
        operands = self._fixed_operands(plan, ev, evidence, q)
        groups = plan.cache.groups
        if groups is None:
            groups = plan.cache.groups = _sum_groups(plan, set(query))
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
                    tuning=self.tuning,
                )
            part, term, _ = elimination.run(path, group, sums)
            parts.append(part)
            terms.append(term)
        shapes = [p.raw.shape for p in parts]
        best, _, records = elimination.run(
            elimination.find_path(terms, "", shapes, tuning=self.tuning),
            parts,
            FixedAlgebra(q, "max"),
        )
        total, _, _ = elimination.run(
            elimination.find_path(terms, "", shapes, tuning=self.tuning), parts, sums
        )
        choice = elimination.traceback(records)
        assignment = dict(fixed)
        for v in query:
            assignment[compiled.names[v]] = compiled.states[v][choice[symbol(v)]]
        return assignment, ratio(q, best, total, "marginal MAP")

    def fixed_probability(
        self,
        proposition: Proposition | str,
        evidence: Evidence,
        q: QFormat,
        given: Proposition | str | None = None,
    ) -> FixedResult:
        """:meth:`probability` in Q-format integers: the unnormalised joint of the mentioned
        variables, summed where the proposition holds and where it does not (within the
        condition, if any), then divided."""
        compiled = self.compiled
        names, holds, condition = self._truth(proposition, given)
        ids = tuple(compiled.id(n) for n in names)
        ev = self._evidence_ids(evidence)
        observed = tuple(ev.get(v, slice(None)) for v in ids)
        mask = holds[observed]
        inside = None if condition is None else condition[observed]
        free = tuple(v for v in ids if v not in ev)
        what = f"probability of {proposition}" + ("" if given is None else f" given {given}")
        if not free:
            self.probability_of_evidence(evidence)
            if inside is not None and not inside:
                raise InputError(f"the condition {given} is false for the evidence")
            return constant(q, np.asarray(float(mask)))
        joint = self._fixed_sum(self.plan(QueryKind.MARGINAL, free, frozenset(ev)), ev, evidence, q)
        if inside is None:
            yes, no = mask, ~mask
        else:
            if not np.any(joint.raw[inside] > 0):
                raise InputError(f"the condition {given} has probability zero given the evidence")
            yes, no = mask & inside, ~mask & inside
        split = Fixed(
            np.array([joint.raw[yes].sum(), joint.raw[no].sum()]),
            joint.exp.reshape(1),
            np.array([joint.error[yes].sum(), joint.error[no].sum()]),
        )
        answer = normalise(q, split, (0,), what)
        return FixedResult(q, answer.raw[0], answer.values[0], answer.bound[0])

    def _fixed_operands(
        self, plan: Plan, ev: Mapping[int, int], evidence: Evidence, q: QFormat
    ) -> list[Fixed]:
        """The plan's factors sliced by one case and quantised; raises on impossible evidence."""
        compiled = self.compiled
        if plan.dropped:
            self._check_dropped(plan, ev.__getitem__, lambda: _impossible(evidence))
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        if any(not float(_slice(compiled, f, ev_idx, names)) > 0.0 for f in plan.checks):
            raise InputError(_impossible(evidence))
        return [q.quantise(_slice(compiled, f, ev_idx, names)) for f in plan.factors]

    def _fixed_sum(
        self, plan: Plan, ev: Mapping[int, int], evidence: Evidence, q: QFormat
    ) -> Fixed:
        """Unnormalised sum-product of one case, axes in ``plan.output`` order."""
        operands = self._fixed_operands(plan, ev, evidence, q)
        result, term, _ = elimination.run(self.fixed_path(plan), operands, FixedAlgebra(q))
        if term != plan.output:
            result = result.transpose([term.index(ch) for ch in plan.output])
        return result

    def fixed_path(self, plan: Plan) -> elimination.Path:
        """The order of a plan's one-case fixed-point sum-product (cached on the plan).

        The generated C code (:mod:`bayesmap.bn.codegen`) replays this same order.
        """
        path = plan.cache.fixed_path
        if path is None:
            card = self.compiled.card
            path = plan.cache.fixed_path = elimination.find_path(
                [f.term for f in plan.factors],
                plan.output,
                [tuple(card[v] for v in f.free) for f in plan.factors],
                tuning=self.tuning,
            )
        return path

    def _fixed_scalar(
        self, plan: Plan, ev: Mapping[int, int], algebra: FixedAlgebra
    ) -> tuple[Fixed, list[elimination.Record]]:
        compiled, q = self.compiled, algebra.q
        ev_idx = [ev[v] for v in plan.evidence]
        names = self._source_evidence(ev)
        operands = [q.quantise(_slice(compiled, f, ev_idx, names)) for f in plan.factors]
        path = plan.cache.scalar_path
        if path is None:
            path = plan.cache.scalar_path = elimination.find_path(
                [f.term for f in plan.factors],
                "",
                [op.raw.shape for op in operands],
                tuning=self.tuning,
            )
        value = Fixed(np.ones((), dtype=np.int64), np.zeros((), dtype=np.int64), np.zeros(()))
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


def _single_program(plan: Plan, compiled: Compiled, tuning: Tuning) -> tuple[Any, list[Factor]]:
    """The compiled contraction of one case, or the constant result if nothing is observed."""
    if not plan.factors:
        return np.ones(()), []
    observed = [f for f in plan.factors if f.observed]
    scopes = [f.free for f in plan.factors]
    specs: list[Any] = [
        tuple(compiled.card[v] for v in f.free) if f.observed else f.array for f in plan.factors
    ]
    card = compiled.card
    labels = dict.fromkeys(v for scope in scopes for v in scope)
    few = len(scopes) <= tuning.one_step_operands
    if few and math.prod([card[v] for v in labels]) <= tuning.one_step:
        # small enough for one np.einsum call over all variables: no order to compute
        path: list[tuple[int, ...]] = [tuple(range(len(scopes)))]
        kept: list[tuple[int, ...]] | None = [plan.targets]
    else:
        path, kept, _ = plans.order_steps(compiled, scopes, plan.targets, tuning=tuning)
    program = elimination.SumProgram(
        scopes, plan.targets, specs, path, kept, memo=compiled.constants, tuning=tuning
    )
    if not observed:
        return program(), []
    return program, observed


def _batch_expression(plan: Plan, compiled: Compiled, n: int, tuning: Tuning) -> Any:
    """The compiled contraction of a batch (case axis first), cached per size class."""
    cache = plan.cache.batch
    size_class = max(n, tuning.batch_class).bit_length()
    program = cache.get(size_class)
    if program is None:
        scopes, output, specs, path, kept, _ = _batch_order(plan, compiled, n, tuning)
        program = cache[size_class] = elimination.SumProgram(
            scopes, output, specs, path, kept, memo=compiled.constants, tuning=tuning
        )
    return program


def _batch_order(plan: Plan, compiled: Compiled, n: int, tuning: Tuning) -> BatchOrder:
    """Scopes, output, operand specs, order and cost of a batch contraction (cached).

    The order depends on the number of cases (a large case axis favours other orders), so
    one is kept per size class — up to 511 cases, then each power of two — chosen for the
    largest size of its class (the cost returned is for that size). Ordering for many cases
    keeps the case axis out of large intermediates, which also suits small batches.
    """
    cache = plan.cache.batch_order
    size_class = max(n, tuning.batch_class).bit_length()
    entry = cache.get(size_class)
    if entry is None:
        n = 1 << size_class
        scopes: list[tuple[int, ...]] = []
        specs: list[Any] = []
        for f in plan.factors:
            if f.observed:
                scopes.append((_CASE, *f.free))
                specs.append((n, *(compiled.card[v] for v in f.free)))
            else:
                scopes.append(f.free)
                specs.append(f.array)
        output = (_CASE, *plan.targets)
        path, kept, cost = plans.order_steps(compiled, scopes, output, {_CASE: n}, tuning=tuning)
        entry = cache[size_class] = (scopes, output, specs, path, kept, cost)
    return entry


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
