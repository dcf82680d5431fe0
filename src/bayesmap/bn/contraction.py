"""Slicing a plan's factors by the evidence and contracting them: one case or a batch.

Every question of :mod:`bayesmap.bn.inference` ends here: the plan's CPTs are sliced by the
observed values (Post et al. 2016 §3.2: ``P(X_i | Pa_i)`` with the evidence put in) and
summed over the non-targets (eqs. 22–25), as one compiled
:class:`~bayesmap.bn.elimination.SumProgram` per plan (one case) or per size class of
batches (a leading case axis, label :data:`CASE`). The fixed-point sum of the same plan
runs along :func:`fixed_path`, the order the generated C code replays.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from itertools import chain, compress
from operator import attrgetter, not_
from typing import TYPE_CHECKING, Any

import numpy as np

from bayesmap._typing import FloatArray, IntArray
from bayesmap.bn import elimination, plans
from bayesmap.bn.compiled import Compiled
from bayesmap.bn.plans import BatchOrder, Factor, Plan
from bayesmap.bn.tuning import Tuning
from bayesmap.errors import InputError

if TYPE_CHECKING:
    from bayesmap.bn.inference import Engine

CASE = -1
"""Label of the case axis in batched contractions (variable ids are >= 0)."""

_OBSERVED, _FREE, _SPEC = attrgetter("observed"), attrgetter("free"), attrgetter("spec")
_SUM = np.add.reduce
"""Getters of a plan's factors, mapped over them in C (:func:`single_program`)."""


def contract(
    engine: Engine, plan: Plan, ev: Mapping[int, int], *, check: bool = True
) -> FloatArray:
    """Unnormalised contraction of one case (checks multiplied in unless ``check``)."""
    compiled = engine.compiled
    ev_idx = [ev[v] for v in plan.evidence]
    names = engine.source_evidence(ev)
    scale = 1.0
    for factor in plan.checks:
        scale *= float(slice_case(compiled, factor, ev_idx, names))
    if check and scale == 0.0:
        raise InputError(impossible(compiled.evidence_names(ev)))
    entry = plan.cache.single
    if entry is None:
        entry = plan.cache.single = single_program(plan, compiled, engine.tuning)
    expression, observed = entry
    if not observed:
        result: FloatArray = expression
    else:
        result = expression(*[slice_case(compiled, f, ev_idx, names) for f in observed])
    return result if check else result * scale


def batch_contract(
    engine: Engine, plan: Plan, ev_vars: Sequence[int], values: IntArray, rows: IntArray
) -> FloatArray:
    """Unnormalised answers of many cases sharing ``plan``: shape ``(n, *targets)``."""
    compiled = engine.compiled
    n = values.shape[0]
    order = [list(ev_vars).index(v) for v in plan.evidence]
    cols = [values[:, j] for j in order]
    case_names = case_namer(compiled, plan.evidence, cols)
    if plan.dropped:
        where = dict(zip(plan.evidence, cols, strict=True))

        def first_bad() -> str:
            ok = np.logical_and.reduce(
                [engine.prior(v)[where[v]] > 0.0 for v in plan.cache.checkable or ()]
            )
            i = int(np.flatnonzero(~ok)[0])
            return f"batched evidence case {int(rows[i])}: " + impossible(case_names(i))

        engine.check_dropped(plan, where.__getitem__, first_bad)
    scale = np.ones(n)
    for factor in plan.checks:
        scale *= slice_batch(compiled, factor, cols, case_names)
    observed = [f for f in plan.factors if f.observed]
    if observed:
        expression = batch_program(plan, compiled, n, engine.tuning)
        result = expression(*[slice_batch(compiled, f, cols, case_names) for f in observed])
    else:
        single, _ = plan.cache.single or single_program(plan, compiled, engine.tuning)
        result = np.broadcast_to(single, (n, *np.shape(single)))
    totals = scale * result.reshape(n, -1).sum(axis=1)
    bad = np.flatnonzero(totals <= 0.0)
    if bad.size:
        case = {
            compiled.names[v]: compiled.states[v][c[bad[0]]]
            for v, c in zip(plan.evidence, cols, strict=True)
        }
        raise InputError(f"batched evidence case {int(rows[bad[0]])}: " + impossible(case))
    return np.asarray(result)


def fixed_path(engine: Engine, plan: Plan) -> elimination.Path:
    """The order of a plan's one-case fixed-point sum-product (cached on the plan).

    The generated C code (:mod:`bayesmap.bn.codegen`) replays this same order.
    """
    path = plan.cache.fixed_path
    if path is None:
        path = plan.cache.fixed_path = elimination.find_path(
            [f.term for f in plan.factors],
            plan.output,
            [f.shape for f in plan.factors],
            tuning=engine.tuning,
        )
    return path


def slice_case(
    compiled: Compiled, factor: Factor, ev_idx: Sequence[int], names: Callable[[], dict[str, str]]
) -> FloatArray:
    """The factor's values for one evidence case."""
    array = factor.array
    if array is None:
        array = compiled.table(factor.var, names()).transpose(factor.perm)
    return array[factor.pick(ev_idx)] if factor.pick is not None else array


def slice_batch(
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


def case_namer(
    compiled: Compiled, evidence: Sequence[int], cols: Sequence[IntArray]
) -> Callable[[int], dict[str, str]]:
    """Case ``i``'s evidence by name (what a data node's table is asked with)."""
    return lambda i: {
        compiled.names[v]: compiled.states[v][int(c[i])]
        for v, c in zip(evidence, cols, strict=True)
    }


def single_program(plan: Plan, compiled: Compiled, tuning: Tuning) -> tuple[Any, list[Factor]]:
    """The compiled contraction of one case, or the constant result if nothing is observed."""
    factors = plan.factors
    if not factors:
        return np.ones(()), []
    if len(factors) == 1 and not factors[0].observed and factors[0].free == plan.targets:
        return factors[0].array, []  # one evidence-free factor over the targets: the answer
    flags = list(map(_OBSERVED, factors))
    observed = list(compress(factors, flags))
    scopes = list(map(_FREE, factors))
    specs = list(map(_SPEC, factors))
    size = compiled.card.__getitem__
    memo = compiled.constants
    labels = dict.fromkeys(chain.from_iterable(scopes))
    entries = math.prod(map(size, labels))
    if len(scopes) <= tuning.one_step_operands and entries <= tuning.one_step:
        # small enough for one np.einsum call over all variables: no order to compute
        program = elimination.SumProgram(
            scopes, plan.targets, specs, None, memo=memo, tuning=tuning
        )
        program.add(tuple(range(len(scopes))), plan.targets, entries, labels)
        program.finish()
    elif plan.cache.single_order is not None:
        path, kept, _ = plan.cache.single_order
        program = elimination.SumProgram(
            scopes, plan.targets, specs, path, kept, memo=memo, tuning=tuning
        )
    else:  # order and program in one pass over the factors
        program = elimination.SumProgram(
            scopes, plan.targets, specs, None, memo=memo, tuning=tuning
        )
        plan.cache.single_order = plans.order_steps(
            compiled,
            scopes,
            plan.targets,
            emit=program.extend,
            network=list(map(not_, flags)),
            tuning=tuning,
        )
        program.finish()
    if not observed:
        return program(), []
    return program, observed


def single_order(
    plan: Plan, compiled: Compiled, tuning: Tuning
) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]] | None, int]:
    """The one-case contraction order of a plan's factors: path, kept labels and cost
    (:func:`~bayesmap.bn.plans.order_steps`, cached on the plan)."""
    entry = plan.cache.single_order
    if entry is None:
        scopes = [f.free for f in plan.factors]
        entry = plan.cache.single_order = plans.order_steps(
            compiled,
            scopes,
            plan.targets,
            network=[not f.observed for f in plan.factors],
            tuning=tuning,
        )
    return entry


def batch_program(plan: Plan, compiled: Compiled, n: int, tuning: Tuning) -> Any:
    """The compiled contraction of a batch (case axis first), cached per size class."""
    cache = plan.cache.batch
    size_class = max(n, tuning.batch_class).bit_length()
    program = cache.get(size_class)
    if program is None:
        scopes, output, specs, path, kept, _ = batch_order(plan, compiled, n, tuning)
        program = cache[size_class] = elimination.SumProgram(
            scopes, output, specs, path, kept, memo=compiled.constants, tuning=tuning
        )
    return program


def batch_order(plan: Plan, compiled: Compiled, n: int, tuning: Tuning) -> BatchOrder:
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
                scopes.append((CASE, *f.free))
                specs.append((n, *(compiled.card[v] for v in f.free)))
            else:
                scopes.append(f.free)
                specs.append(f.array)
        output = (CASE, *plan.targets)
        path, kept, cost = plans.order_steps(compiled, scopes, output, {CASE: n}, tuning=tuning)
        entry = cache[size_class] = (scopes, output, specs, path, kept, cost)
    return entry


def patterns(table: IntArray) -> list[tuple[IntArray, IntArray]]:
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


def normalised(table: FloatArray, evidence: Mapping[str, object]) -> FloatArray:
    """``table / Σ table``; raises on impossible evidence (a zero sum)."""
    total = _SUM(table, axis=None)  # the ufunc itself: ``table.sum()`` adds a Python wrapper
    if not total > 0.0:
        raise InputError(impossible(evidence))
    return np.asarray(table / total)


def one_hot(size: int, index: int) -> FloatArray:
    """The posterior of an observed variable: 1 at its state."""
    out = np.zeros(size)
    out[index] = 1.0
    return out


def embed(
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


def impossible(evidence: Mapping[str, object]) -> str:
    """The message of evidence of probability zero."""
    shown = ", ".join(f"{k}={v}" for k, v in evidence.items())
    return (
        f"the evidence {{{shown}}} has probability zero under the network; "
        "check the observed states or the CPTs"
    )
