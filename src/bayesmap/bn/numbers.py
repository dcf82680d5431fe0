"""The two number systems every question runs in: float64 and Q-format fixed point.

A question — which plan, which evidence checks, which variables are summed or maximised — is
written once (:mod:`~bayesmap.bn.posteriors`, :mod:`~bayesmap.bn.maps`,
:mod:`~bayesmap.bn.probabilities`, and for many cases :func:`~bayesmap.bn.batches.posterior_batch`)
against :class:`Numbers`; the arithmetic is the number system's:

- :class:`Floats`: compiled float64 sum-product (:class:`~bayesmap.bn.elimination.SumProgram`),
  max-product in log space (:class:`~bayesmap.bn.elimination.LogMax`), answers as arrays and
  floats; a batch's distinct cases memoised, or all its patterns in one contraction with
  evidence indicators;
- :class:`FixedPoint`: the rover's embedded arithmetic (Post et al. 2016 §3.2): CPT entries
  quantised to a :class:`~bayesmap.bn.fixed_point.QFormat`, sums and maxima in block floating
  point (:class:`~bayesmap.bn.fixed_point.FixedAlgebra`) along the orders the generated C
  code replays, answers as :class:`~bayesmap.bn.fixed_point.FixedResult` with a guaranteed
  error bound; a batch pattern in one contraction with a case axis, one block exponent per
  case.

Each operation is the one the engine always ran for its number system, so answers are the
same to the bit whichever way the question is asked.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np

from bayesmap._lazy import lazy_module
from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.bn import batches, contraction, elimination, posteriors
from bayesmap.bn.contraction import impossible, slice_case
from bayesmap.bn.fixed_point import (
    Fixed,
    FixedAlgebra,
    FixedResult,
    QFormat,
    constant,
    normalise,
    ratio,
    renormalise,
)
from bayesmap.bn.plans import BATCH, Plan, QueryKind, symbol
from bayesmap.errors import InputError

opt_einsum = lazy_module("opt_einsum")  # loads on first use: keeps ``import bayesmap.bn`` lean

if TYPE_CHECKING:
    from bayesmap.bn.batches import Pattern
    from bayesmap.bn.inference import Engine, Evidence

T = TypeVar("T")
"""An operand or unnormalised table of the number system."""
A = TypeVar("A")
"""A table answer of the number system (a posterior)."""
S = TypeVar("S")
S_co = TypeVar("S_co", covariant=True)
"""A scalar answer of the number system (a probability)."""

Place = Callable[[Any], Any]
"""Puts an answer over the free targets into the grid of every target (observed: one-hot)."""


class Numbers(Protocol[T, A, S_co]):
    """A number system for one-case questions: contraction, normalisation, answers.

    ``T`` is its unnormalised table, ``A`` its table answer, ``S_co`` its scalar answer.
    """

    def sum_product(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> T:
        """The plan's unnormalised sum over its non-targets, axes in ``plan.output`` order;
        raises :class:`InputError` on impossible evidence."""

    def posterior(self, table: T, ev_names: Evidence, what: str) -> A:
        """The table normalised over all its axes (a posterior)."""

    def certain(self) -> A:
        """Probability 1 as a 0-d table (no free target: everything asked is observed)."""

    def sure(self) -> S_co:
        """Probability 1 as a scalar answer."""

    def place(self, answer: A, place: Place) -> A:
        """``place`` applied to an answer's values (and bound)."""

    def share(
        self,
        joint: T | None,
        grid: tuple[BoolArray, BoolArray | None],
        free: tuple[BoolArray, BoolArray | None],
        place: Place,
        ev_names: Evidence,
        what: tuple[str, str | None],
    ) -> S_co:
        """``P(proposition | condition, e)`` from the joint of the free mentioned variables
        (``None``: all are observed); ``grid`` gives where the proposition and condition hold
        on the grid of all mentioned variables, ``free`` the same at the observed values."""

    def max_product(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> tuple[Any, list[elimination.Record]]:
        """``max_x Π φ`` of every factor (and check) of the plan, with the traceback records."""

    def map_probability(
        self, engine: Engine, best: Any, ev: Mapping[int, int], ev_names: Evidence
    ) -> S_co:
        """``P(x | e)`` of a maximum ``best`` of the joint with the evidence (eq. 13)."""

    def marginal_map(
        self,
        engine: Engine,
        plan: Plan,
        groups: Sequence[tuple[list[int], str | None]],
        ev: Mapping[int, int],
        ev_names: Evidence,
    ) -> tuple[S_co, list[elimination.Record]]:
        """``max_x Σ_Z Π φ`` by sum groups (eq. 14), as ``P(x | e)``, with the records."""

    def all_at_once(
        self, engine: Engine, t: int, table: IntArray, cols: Sequence[int], n_patterns: int
    ) -> A | None:
        """``P(t | case)`` of a whole batch in one go, where the number system has such a
        way for cases spread over ``n_patterns`` patterns; ``None``: pattern by pattern."""

    def one_hot_batch(self, n_states: int, states: IntArray) -> A:
        """``(n, n_states)`` posteriors of an observed target, one-hot at ``states``."""

    def batch_marginal(
        self, engine: Engine, t: int, cases: Pattern, weights: Mapping[int, FloatArray]
    ) -> A:
        """``P(t | case)`` of the cases of one pattern, ``t`` unobserved, with soft evidence
        ``weights`` ``{variable: (n_cases, n_states)}``."""

    def stack(self, parts: Sequence[tuple[IntArray, A]], n: int, n_states: int) -> A:
        """The ``(n, n_states)`` answers of a batch from each pattern's ``(rows, answers)``."""


@dataclass(frozen=True)
class Floats:
    """float64 arithmetic: the engine's compiled contractions."""

    def sum_product(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> FloatArray:
        """Sliced and contracted by the plan's compiled program (dropped evidence checked)."""
        if plan.dropped:
            engine.check_dropped(plan, ev.__getitem__, lambda: impossible(ev_names))
        return contraction.contract(engine, plan, ev)

    def posterior(self, table: FloatArray, ev_names: Evidence, what: str) -> FloatArray:
        """``table / Σ table``."""
        return contraction.normalised(table, ev_names)

    def certain(self) -> FloatArray:
        """``1.0`` as a 0-d array."""
        return np.ones(())

    def sure(self) -> float:
        """``1.0``."""
        return 1.0

    def place(self, answer: FloatArray, place: Place) -> FloatArray:
        """The placed array."""
        return np.asarray(place(answer))

    def share(
        self,
        joint: FloatArray | None,
        grid: tuple[BoolArray, BoolArray | None],
        free: tuple[BoolArray, BoolArray | None],
        place: Place,
        ev_names: Evidence,
        what: tuple[str, str | None],
    ) -> float:
        """Sums of the normalised joint posterior of every mentioned variable."""
        holds, condition = grid
        table = np.ones(()) if joint is None else self.posterior(joint, ev_names, what[0])
        full = place(table)
        if condition is None:
            return float(full[holds].sum())
        total = float(full[condition].sum())
        if not total > 0.0:
            raise InputError(f"the condition {what[1]} has probability zero given the evidence")
        return float(full[holds & condition].sum()) / total

    def max_product(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> tuple[float, list[elimination.Record]]:
        """Max-product in log space; ``log max_x P(x, e)``."""
        checks, factors = _sliced(engine, plan, ev)
        log_scale = sum(_log(c) for c in checks)
        operands = [_log(f) for f in factors]
        path = _scalar_path(engine, plan, [np.shape(op) for op in operands])
        best: FloatArray = np.zeros(())
        records: list[elimination.Record] = []
        if operands:
            best, _, records = elimination.run(path, operands, elimination.LogMax())
        log_best = float(best) + log_scale
        if not math.isfinite(log_best):
            raise InputError(impossible(ev_names))
        return log_best, records

    def map_probability(
        self, engine: Engine, best: float, ev: Mapping[int, int], ev_names: Evidence
    ) -> float:
        """``exp(log best − log P(e))``, at most 1."""
        total = posteriors.probability_of_evidence(engine, ev_names)
        probability = math.exp(best - math.log(total))
        return min(probability, 1.0)

    def marginal_map(
        self,
        engine: Engine,
        plan: Plan,
        groups: Sequence[tuple[list[int], str | None]],
        ev: Mapping[int, int],
        ev_names: Evidence,
    ) -> tuple[float, list[elimination.Record]]:
        """Each group summed by opt_einsum, then max-product in log space."""
        checks, sliced = _sliced(engine, plan, ev)
        log_scale = sum(_log(c) for c in checks)
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
            terms, "", [np.shape(op) for op in operands], tuning=engine.tuning
        )
        best, _, records = elimination.run(path, operands, elimination.LogMax())
        if not (math.isfinite(log_scale) and math.isfinite(float(best))):
            raise InputError(impossible(ev_names))
        equation = ",".join(f.term for f in plan.factors) + "->"
        total = float(opt_einsum.contract(equation, *sliced))
        probability = math.exp(float(best) - math.log(total))
        return min(probability, 1.0), records

    def all_at_once(
        self, engine: Engine, t: int, table: IntArray, cols: Sequence[int], n_patterns: int
    ) -> FloatArray | None:
        """One contraction with evidence indicators (:func:`~bayesmap.bn.batches.indicator_batch`)
        when the cases spread over more than ``tuning.many_patterns`` patterns."""
        if n_patterns > engine.tuning.many_patterns and not engine.compiled.sources:
            return batches.indicator_batch(engine, (t,), table, cols)[t]
        return None

    def one_hot_batch(self, n_states: int, states: IntArray) -> FloatArray:
        """Rows of the identity."""
        return np.eye(n_states)[states]

    def batch_marginal(
        self, engine: Engine, t: int, cases: Pattern, weights: Mapping[int, FloatArray]
    ) -> FloatArray:
        """Distinct cases contracted once and memoised (:func:`~bayesmap.bn.batches.batch_answers`),
        or, with soft evidence, the weighted joint (:func:`~bayesmap.bn.batches.soft_marginal`)."""
        if weights:
            return batches.soft_marginal(engine, t, cases, weights)
        return batches.batch_answers(engine, t, cases.ev_vars, cases.values, cases.rows)

    def stack(
        self, parts: Sequence[tuple[IntArray, FloatArray]], n: int, n_states: int
    ) -> FloatArray:
        """One array, each pattern's rows in place."""
        out = np.empty((n, n_states))
        for rows, part in parts:
            out[rows] = part
        return out


@dataclass(frozen=True)
class FixedPoint:
    """Q-format integer arithmetic in block floating point, with guaranteed error bounds.

    Parameters
    ----------
    q
        The format of the CPT entries and of every answer.
    """

    q: QFormat

    def operands(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> list[Fixed]:
        """The plan's factors sliced by one case and quantised; raises on impossible evidence."""
        if plan.dropped:
            engine.check_dropped(plan, ev.__getitem__, lambda: impossible(ev_names))
        checks, factors = _sliced(engine, plan, ev)
        if any(not float(c) > 0.0 for c in checks):
            raise InputError(impossible(ev_names))
        return [self.q.quantise(f) for f in factors]

    def sum_product(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> Fixed:
        """Sum-product along :func:`~bayesmap.bn.contraction.fixed_path` (the C code's order)."""
        operands = self.operands(engine, plan, ev, ev_names)
        path = contraction.fixed_path(engine, plan)
        result, term, _ = elimination.run(path, operands, FixedAlgebra(self.q))
        if term != plan.output:
            result = result.transpose([term.index(ch) for ch in plan.output])
        return result

    def posterior(self, table: Fixed, ev_names: Evidence, what: str) -> FixedResult:
        """Integer division by the sum of the block, with the bound."""
        return normalise(self.q, table, tuple(range(table.raw.ndim)), what)

    def certain(self) -> FixedResult:
        """``1.0`` in the format (its rounding as bound)."""
        return constant(self.q, np.ones(()))

    def sure(self) -> FixedResult:
        """``1.0`` in the format (its rounding as bound)."""
        return self.certain()

    def place(self, answer: FixedResult, place: Place) -> FixedResult:
        """The placed raw integers and bounds."""
        raw = place(answer.raw.astype(np.float64)).astype(np.int64)
        return FixedResult(self.q, raw, self.q.to_float(raw), place(answer.bound))

    def share(
        self,
        joint: Fixed | None,
        grid: tuple[BoolArray, BoolArray | None],
        free: tuple[BoolArray, BoolArray | None],
        place: Place,
        ev_names: Evidence,
        what: tuple[str, str | None],
    ) -> FixedResult:
        """The unnormalised joint summed where the proposition holds and where it does not
        (within the condition), then divided. The two sums are a block of their own, brought
        back to the format's mantissa before the division: a sum of many full-width entries
        shifted by the fractional bits would overflow 64 bits (Q2.30 and wider)."""
        q = self.q
        mask, inside = free
        if joint is None:
            if inside is not None and not inside:
                raise InputError(f"the condition {what[1]} is false for the evidence")
            return constant(q, np.asarray(float(mask)))
        if inside is None:
            yes, no = mask, ~mask
        else:
            if not np.any(joint.raw[inside] > 0):
                raise InputError(f"the condition {what[1]} has probability zero given the evidence")
            yes, no = mask & inside, ~mask & inside
        split = Fixed(
            np.array([joint.raw[yes].sum(), joint.raw[no].sum()]),
            joint.exp.reshape(1),
            np.array([joint.error[yes].sum(), joint.error[no].sum()]),
        )
        answer = normalise(q, renormalise(q, split), (0,), what[0])
        return FixedResult(q, answer.raw[0], answer.values[0], answer.bound[0])

    def scalar(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], algebra: FixedAlgebra
    ) -> tuple[Fixed, list[elimination.Record]]:
        """Every factor of the plan (checks included) contracted to a scalar in ``algebra``."""
        q = self.q
        checks, factors = _sliced(engine, plan, ev)
        operands = [q.quantise(f) for f in factors]
        path = _scalar_path(engine, plan, [op.raw.shape for op in operands])
        value = Fixed(np.ones((), dtype=np.int64), np.zeros((), dtype=np.int64), np.zeros(()))
        records: list[elimination.Record] = []
        if operands:
            value, _, records = elimination.run(path, operands, algebra)
        for c in checks:
            value = algebra.multiply(value, q.quantise(c))
        return value, records

    def max_product(
        self, engine: Engine, plan: Plan, ev: Mapping[int, int], ev_names: Evidence
    ) -> tuple[Fixed, list[elimination.Record]]:
        """Max-product in block floating point."""
        return self.scalar(engine, plan, ev, FixedAlgebra(self.q, "max"))

    def map_probability(
        self, engine: Engine, best: Fixed, ev: Mapping[int, int], ev_names: Evidence
    ) -> FixedResult:
        """``best / P(e)``, ``P(e)`` summed in the same arithmetic."""
        plan = engine.plan(QueryKind.EVIDENCE, (), frozenset(ev))
        total, _ = self.scalar(engine, plan, ev, FixedAlgebra(self.q))
        return ratio(self.q, best, total, "MAP")

    def marginal_map(
        self,
        engine: Engine,
        plan: Plan,
        groups: Sequence[tuple[list[int], str | None]],
        ev: Mapping[int, int],
        ev_names: Evidence,
    ) -> tuple[FixedResult, list[elimination.Record]]:
        """Each group summed, then maximised, in block floating point."""
        q = self.q
        operands = self.operands(engine, plan, ev, ev_names)
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
        path = elimination.find_path(terms, "", shapes, tuning=engine.tuning)
        best, _, records = elimination.run(path, parts, FixedAlgebra(q, "max"))
        total, _, _ = elimination.run(path, parts, sums)
        return ratio(q, best, total, "marginal MAP"), records

    def all_at_once(
        self, engine: Engine, t: int, table: IntArray, cols: Sequence[int], n_patterns: int
    ) -> FixedResult | None:
        """Never: fixed point answers pattern by pattern."""
        return None

    def one_hot_batch(self, n_states: int, states: IntArray) -> FixedResult:
        """Rows of the identity; the bound is the rounding of 1."""
        one = self.certain()
        eye = np.eye(n_states)[states]
        raw = (eye * one.raw).astype(np.int64)
        return FixedResult(self.q, raw, self.q.to_float(raw), eye * one.bound)

    def batch_marginal(
        self, engine: Engine, t: int, cases: Pattern, weights: Mapping[int, FloatArray]
    ) -> FixedResult:
        """One quantised contraction with a case axis, one block exponent per case.

        Soft evidence enters as one more factor per softly observed variable ``X``, over
        the case axis and ``X``: each case's likelihood scaled to a largest weight of 1 and
        quantised like a CPT (the virtual child's table of a single question,
        :mod:`bayesmap.bn.soft`), then summed out with the other non-targets, so its
        rounding is inside the guaranteed bound. Where no factor depends on the case, every
        case has the one-case answer.
        """
        q, compiled = self.q, engine.compiled
        rows, ev_vars, values = cases
        plan = engine.plan(
            QueryKind.MARGINAL, (t, *(v for v in weights if v != t)), frozenset(ev_vars)
        )
        contraction.batch_contract(engine, plan, ev_vars, values, rows)  # evidence check
        what = f"posterior of {compiled.names[t]!r}"
        if not (weights or any(f.observed for f in plan.factors)):
            ev = {v: int(s) for v, s in zip(ev_vars, values[0], strict=True)}
            names = compiled.evidence_names(ev)
            return self.posterior(self.sum_product(engine, plan, ev, names), names, what)
        order = [list(ev_vars).index(v) for v in plan.evidence]
        cols_k = [values[:, j] for j in order]
        case_names = contraction.case_namer(compiled, plan.evidence, cols_k)
        operands, terms = [], []
        for f in plan.factors:
            sliced = contraction.slice_batch(compiled, f, cols_k, case_names)
            operands.append(q.quantise(sliced, case_axis=f.observed))
            terms.append(BATCH + f.term if f.observed else f.term)
        for v, w in weights.items():
            mine = w[rows]
            operands.append(q.quantise(mine / mine.max(axis=1, keepdims=True), case_axis=True))
            terms.append(BATCH + symbol(v))
        output = BATCH + symbol(t)
        path = plan.cache.fixed_batch_path if not weights else None
        if path is None:
            path = elimination.find_path(
                terms, output, [o.raw.shape for o in operands], tuning=engine.tuning
            )
            if not weights:  # a soft question's terms depend on which variables are soft
                plan.cache.fixed_batch_path = path
        result, term, _ = elimination.run(path, operands, FixedAlgebra(q))
        if term != output:
            result = result.transpose([term.index(ch) for ch in output])
        return normalise(q, result, (1,), what)

    def stack(
        self, parts: Sequence[tuple[IntArray, FixedResult]], n: int, n_states: int
    ) -> FixedResult:
        """One result, each pattern's rows in place."""
        raw = np.empty((n, n_states), dtype=np.int64)
        bound = np.empty((n, n_states))
        for rows, part in parts:
            raw[rows], bound[rows] = part.raw, part.bound
        return FixedResult(self.q, raw, self.q.to_float(raw), bound)


FLOATS = Floats()
"""The float64 number system."""


def _sliced(
    engine: Engine, plan: Plan, ev: Mapping[int, int]
) -> tuple[list[FloatArray], list[FloatArray]]:
    """The plan's evidence checks and its factors, sliced by one case."""
    compiled = engine.compiled
    ev_idx = [ev[v] for v in plan.evidence]
    names = engine.source_evidence(ev)
    return (
        [slice_case(compiled, f, ev_idx, names) for f in plan.checks],
        [slice_case(compiled, f, ev_idx, names) for f in plan.factors],
    )


def _scalar_path(engine: Engine, plan: Plan, shapes: Sequence[tuple[int, ...]]) -> elimination.Path:
    """The order contracting every factor of the plan to a scalar (cached on the plan)."""
    path = plan.cache.scalar_path
    if path is None:
        path = plan.cache.scalar_path = elimination.find_path(
            [f.term for f in plan.factors], "", list(shapes), tuning=engine.tuning
        )
    return path


def _log(values: FloatArray | float) -> Any:
    """Natural log with log 0 = −inf, silently."""
    with np.errstate(divide="ignore"):
        return np.log(values)
