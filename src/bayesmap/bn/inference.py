"""Exact inference on a :class:`~bayesmap.bn.model.BayesNet` (Post et al. 2016 §2.3, §3.2).

All questions reduce to contracting the network's CPTs, sliced by the evidence:

- posterior of one or several variables, eqs. 22–25: ``P(Se | Kn) ∝ Σ_Un Π_i P(X_i | Pa_i)``;
- the probability of the evidence, the denominator Σ of eq. 24;
- MAP/MPE over all non-evidence variables, eq. 13: ``argmax_x P(x ∩ e)`` by max-product;
- marginal MAP over a subset, eq. 14: ``argmax_x Σ_Z P(x ∩ Z | e)``, summing first, then
  maximising;
- batched evidence: many cases of the same observed variables as one leading array axis.

:class:`Engine` is the shell: it holds every cache of one network (the compiled network, one
:class:`~bayesmap.bn.plans.Plan` per question kind and pattern of observed variables, the
prior marginals, the memo of batch answers) and is rebuilt when the network changes. Each
family of questions lives in its own module, as functions of the engine:
:mod:`~bayesmap.bn.posteriors` (one, joint, every variable, P(e)), :mod:`~bayesmap.bn.batches`,
:mod:`~bayesmap.bn.maps` (MPE, marginal MAP) and :mod:`~bayesmap.bn.probabilities`
(propositions), on :mod:`~bayesmap.bn.contraction` (slicing and contracting a plan).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray, IntArray
from bayesmap.bn import (
    ancestral,
    batches,
    contraction,
    elimination,
    maps,
    plans,
    posteriors,
    probabilities,
)
from bayesmap.bn.compiled import Compiled, NetworkLike
from bayesmap.bn.fixed_point import FixedResult, QFormat
from bayesmap.bn.numbers import FLOATS, FixedPoint
from bayesmap.bn.plans import Plan, QueryKind
from bayesmap.bn.propositions import Proposition
from bayesmap.bn.tuning import TUNING, Tuning
from bayesmap.errors import InputError

Evidence = Mapping[str, str | int]
"""Observed values: ``{variable name: state name or index}``."""

BatchEvidence = npt.ArrayLike | Sequence[Evidence]
"""Many evidence cases: an ``(n_cases, n_columns)`` int array (−1 = unobserved) or mappings."""


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
        self._plans: dict[tuple[QueryKind, tuple[int, ...], frozenset[int]], Plan] = {}
        self.priors: dict[int, FloatArray] = {}
        """Prior marginals by variable id (no evidence), for this network version."""
        self.answers: dict[tuple[int, tuple[int, ...]], FloatArray] = {}
        """Memo of batch answers by (target, observed variables), for this network version."""

    @property
    def compiled(self) -> Compiled:
        """The compiled network, rebuilt (and all caches dropped) after a change."""
        compiled = self._compiled
        if compiled is None or compiled.version != self._net.version:
            compiled = self._compiled = Compiled(self._net)
            self._plans.clear()
            self.priors.clear()
            self.answers.clear()
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
                plan = plans.build(compiled, kind, targets, ev, prior=self.prior)
                plan.cache.ancestral = ancestral.is_exact(compiled, targets, evidence)
            else:
                plan = plans.build(compiled, kind, targets, ev)
            self._plans[key] = plan
        return plan

    def prior(self, var: int) -> FloatArray:
        """Prior marginal ``P(var)`` (no evidence), computed once per network version.

        Priors are computed when a plan first needs one (to stand for an evidence-free
        ancestral sub-network, or to check dropped evidence), after the priors that one
        uses (:meth:`_prior_inputs`), by a work list rather than recursion, so that a long
        chain of ancestors cannot exhaust the stack. A network's first question pays only
        for the priors it uses; each variable's inputs are found once per call, and the
        compiled network is looked up once (a deep network's question may compute hundreds
        of priors).
        """
        priors = self.priors
        cached = priors.get(var)
        if cached is not None:
            return cached
        compiled = self.compiled
        if var in compiled.sources:
            raise AssertionError("data nodes have no evidence-independent prior")
        todo = [var]
        inputs: dict[int, tuple[bool, list[int]]] = {}
        while todo:
            v = todo[-1]
            if v in priors:
                todo.pop()
                continue
            found = inputs.get(v)
            if found is None:
                found = inputs[v] = self._prior_inputs(compiled, v)
            missing = [u for u in found[1] if u not in priors]
            if missing:
                todo.extend(missing)
                continue
            priors[v] = self._marginal(compiled, v, found[0])
            todo.pop()
        return priors[var]

    def _prior_inputs(self, compiled: Compiled, var: int) -> tuple[bool, list[int]]:
        """Whether the parents of ``var`` are independent a priori, and the variables whose
        priors :meth:`_marginal` uses for ``P(var)``: its parents if they are, else the roots
        its plan replaces by their priors."""
        if compiled.independent_parents(var):
            return True, list(compiled.parents[var])
        return False, plans.replaced_roots(compiled, var)

    def _marginal(self, compiled: Compiled, var: int, independent: bool) -> FloatArray:
        """``P(var)`` once the priors it uses are cached: one ``einsum``
        ``Σ_pa P(var | pa) Π P(parent)`` when its parents are ``independent`` a priori
        (:meth:`Compiled.independent_parents`), else a plan of its own."""
        if independent:
            parents = compiled.parents[var]
            priors = self.priors
            operands: list[Any] = [compiled.cpts[var], list(range(len(parents) + 1))]
            for axis, parent in enumerate(parents, start=1):
                operands += [priors[parent], [axis]]
            table = elimination.einsum(*operands, [0])
        else:
            plan = plans.build(compiled, QueryKind.MARGINAL, (var,), (), prior=self.prior)
            table, _ = contraction.single_program(plan, compiled, self.tuning)
        return np.asarray(table / np.add.reduce(table, axis=None))

    def check_dropped(
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
                v for v in plan.dropped if not compiled.source_mask & compiled.lineage_masks[v]
            )
        for v in checkable:
            found = self.prior(v)[values(v)]  # one case's probability, or a batch's array
            if not ((found > 0.0).all() if isinstance(found, np.ndarray) else found > 0.0):
                raise InputError(case())

    def evidence_ids(self, evidence: Evidence) -> dict[int, int]:
        """``{variable id: state index}`` of named evidence (unknown names raise)."""
        compiled = self.compiled
        ids = {}
        for name, s in evidence.items():
            v = compiled.id(name)
            ids[v] = compiled.state(v, s)
        return ids

    def source_evidence(self, ev: Mapping[int, int]) -> Callable[[], dict[str, str]]:
        """The evidence by name, computed when a data node's table first asks for it."""
        compiled = self.compiled
        return lambda: compiled.evidence_names(ev)

    # ------------------------------------------------------------- the questions
    def posterior(self, target: str, evidence: Evidence) -> FloatArray:
        """``P(target | evidence)`` over the target's states (eq. 25)."""
        return posteriors.posterior(self, target, evidence)

    def joint_posterior(self, targets: Sequence[str], evidence: Evidence) -> FloatArray:
        """``P(targets | evidence)``, one axis per target in the given order."""
        return posteriors.joint_posterior(self, targets, evidence, FLOATS)

    def posteriors(self, evidence: Evidence) -> dict[int, FloatArray]:
        """Every unobserved variable's posterior, by variable id."""
        return posteriors.posteriors(self, evidence)

    def probability_of_evidence(self, evidence: Evidence) -> float:
        """``P(evidence)``, the normaliser Σ of eq. 24."""
        return posteriors.probability_of_evidence(self, evidence)

    def ancestral_posterior(self, target: str, evidence: Evidence) -> FloatArray:
        """The paper's recursive query (eq. 27)."""
        return posteriors.ancestral_posterior(self, target, evidence)

    def ancestral_is_exact(self, target: str, evidence: Evidence) -> bool:
        """Whether the recursive query is exact here."""
        return posteriors.ancestral_is_exact(self, target, evidence)

    def posterior_batch(
        self,
        target: str,
        evidence: BatchEvidence,
        *,
        columns: Sequence[str] | None = None,
        soft: Mapping[str, npt.ArrayLike] | None = None,
    ) -> FloatArray:
        """``P(target | case)`` for many cases: ``(n_cases, n_states)``."""
        return batches.posterior_batch(self, target, evidence, FLOATS, columns=columns, soft=soft)

    def posteriors_batch(
        self,
        evidence: BatchEvidence,
        columns: Sequence[str] | None,
        targets: Sequence[str] | None = None,
    ) -> dict[int, FloatArray]:
        """Every variable's (or the targets') posterior per case, by variable id."""
        return batches.posteriors_batch(self, evidence, columns, targets)

    def batch_array(
        self, evidence: BatchEvidence, columns: Sequence[str] | None
    ) -> tuple[IntArray, list[int]]:
        """Checked state indices of batched evidence and each column's variable id."""
        return batches.batch_array(self, evidence, columns)

    def expected_counts(
        self, table: IntArray, cols: Sequence[int], weights: FloatArray
    ) -> tuple[list[FloatArray], float]:
        """EM's E-step: expected family counts of weighted cases, and their log-likelihood."""
        return batches.expected_counts(self, table, cols, weights)

    def mpe(self, evidence: Evidence) -> tuple[dict[str, str], float]:
        """Most probable joint state of the unobserved variables (eq. 13)."""
        return maps.mpe(self, evidence, FLOATS)

    def marginal_map(
        self, variables: Sequence[str], evidence: Evidence
    ) -> tuple[dict[str, str], float]:
        """Marginal MAP over ``variables`` (eq. 14)."""
        return maps.marginal_map(self, variables, evidence, FLOATS)

    def probability(
        self,
        proposition: Proposition | str,
        evidence: Evidence,
        given: Proposition | str | None = None,
    ) -> float:
        """``P(proposition | given, evidence)`` (§2.4, eqs. 15–21)."""
        return probabilities.probability(self, proposition, evidence, given, FLOATS)

    # ------------------------------------- the same questions in fixed point (numbers.py)
    def fixed_posterior(self, target: str, evidence: Evidence, q: QFormat) -> FixedResult:
        """:meth:`posterior` in Q-format integers, with its error bound."""
        return posteriors.joint_posterior(self, [target], evidence, FixedPoint(q))

    def fixed_joint_posterior(
        self, targets: Sequence[str], evidence: Evidence, q: QFormat
    ) -> FixedResult:
        """:meth:`joint_posterior` in Q-format integers."""
        return posteriors.joint_posterior(self, targets, evidence, FixedPoint(q))

    def fixed_posterior_batch(
        self,
        target: str,
        evidence: BatchEvidence,
        q: QFormat,
        *,
        columns: Sequence[str] | None = None,
        soft: Mapping[str, npt.ArrayLike] | None = None,
    ) -> FixedResult:
        """:meth:`posterior_batch` in Q-format integers (soft evidence per case too)."""
        return batches.posterior_batch(
            self, target, evidence, FixedPoint(q), columns=columns, soft=soft
        )

    def fixed_mpe(self, evidence: Evidence, q: QFormat) -> tuple[dict[str, str], FixedResult]:
        """:meth:`mpe` in Q-format integers."""
        return maps.mpe(self, evidence, FixedPoint(q))

    def fixed_marginal_map(
        self, variables: Sequence[str], evidence: Evidence, q: QFormat
    ) -> tuple[dict[str, str], FixedResult]:
        """:meth:`marginal_map` in Q-format integers."""
        return maps.marginal_map(self, variables, evidence, FixedPoint(q))

    def fixed_probability(
        self,
        proposition: Proposition | str,
        evidence: Evidence,
        q: QFormat,
        given: Proposition | str | None = None,
    ) -> FixedResult:
        """:meth:`probability` in Q-format integers."""
        return probabilities.probability(self, proposition, evidence, given, FixedPoint(q))

    def fixed_path(self, plan: Plan) -> elimination.Path:
        """The order of a plan's one-case fixed-point sum (the generated C code replays it)."""
        return contraction.fixed_path(self, plan)
