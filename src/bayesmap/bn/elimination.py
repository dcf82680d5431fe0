"""Pairwise contraction along an opt_einsum path, in any semiring, with max traceback.

opt_einsum chooses the contraction order (:func:`opt_einsum.contract_path`) and runs
ordinary sum-product contractions itself. Max-product (MAP, Post et al. 2016 eqs. 13–14)
and the fixed-point arithmetic of the rover's embedded engine are not sum-product over
float64, so this module replays the same path with a pluggable :class:`Algebra`: each step
multiplies the operands it names (broadcast over the union of their indices) and
eliminates the indices no later operand and not the output needs. For max-eliminations it
keeps the arg-max tables, so :func:`traceback` recovers the maximising joint assignment —
a true joint maximisation, never per-variable arg-maxes of marginals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass
from itertools import chain, compress
from typing import Any, Generic, NamedTuple, Protocol, TypeVar

import numpy as np

from bayesmap._lazy import lazy_module
from bayesmap._typing import FloatArray, IntArray
from bayesmap.bn import _orders
from bayesmap.bn.tuning import TUNING, Tuning
from bayesmap.errors import ModelError

opt_einsum = lazy_module("opt_einsum")  # loads on first use: keeps ``import bayesmap.bn`` lean

T = TypeVar("T")


class Algebra(Protocol[T]):
    """A commutative semiring on operands of type ``T`` (arrays or array pairs)."""

    def shape(self, operand: T) -> tuple[int, ...]:
        """Shape of the operand's value array."""

    def rearrange(self, operand: T, axes: Sequence[int], shape: Sequence[int]) -> T:
        """Transpose the value by ``axes`` and reshape it to ``shape`` (adds unit axes)."""

    def multiply(self, a: T, b: T) -> T:
        """Broadcast product of two aligned operands."""

    def eliminate(self, operand: T, n_keep: int) -> tuple[T, IntArray | None]:
        """Reduce all axes after the first ``n_keep``; return the arg-max table or ``None``."""


@dataclass(frozen=True)
class Record:
    """One max-elimination: ``argmax[kept values]`` is the flat index of the eliminated ones."""

    kept: tuple[str, ...]
    eliminated: tuple[str, ...]
    sizes: tuple[int, ...]
    argmax: IntArray


@dataclass(frozen=True)
class Path:
    """A contraction order for fixed index strings: an SSA path (as :func:`walk` reads it)
    converted from :func:`opt_einsum.contract_path`'s."""

    terms: tuple[str, ...]
    output: str
    steps: tuple[tuple[int, ...], ...]


MAX_STEP_ENTRIES = 1 << 27
"""Largest table (entries) one step of :func:`run` may build: 1 GiB of float64."""


def find_path(
    terms: Sequence[str],
    output: str,
    shapes: Sequence[Sequence[int]],
    *,
    tuning: Tuning = TUNING,
) -> Path:
    """Ask opt_einsum for a contraction order of ``terms -> output``.

    opt_einsum's greedy order comes first (milliseconds even on a thousand factors); only
    where it would cost over ``tuning.search_above`` multiply-adds is a reproducible random-greedy
    search run too, and the cheaper order kept.

    Raises
    ------
    ModelError
        If some step would build a table of more than :data:`MAX_STEP_ENTRIES` entries:
        the network is too densely connected for exact elimination of these variables.
    """
    if not terms:
        return Path((), output, ())
    equation = ",".join(terms) + "->" + output
    steps, info = opt_einsum.contract_path(equation, *shapes, shapes=True, optimize="greedy")
    if float(info.opt_cost) > tuning.search_above:
        search = opt_einsum.RandomGreedy(max_repeats=tuning.search_repeats)
        better, better_info = opt_einsum.contract_path(
            equation, *shapes, shapes=True, optimize=search
        )
        if better_info.opt_cost < info.opt_cost:
            steps = better
    ssa = opt_einsum.paths.linear_to_ssa(steps)
    path = Path(tuple(terms), output, tuple(tuple(s) for s in ssa))
    widest = _widest_step(path, shapes)
    if widest > MAX_STEP_ENTRIES:
        raise _too_wide(widest)
    return path


def _too_wide(entries: int) -> ModelError:
    """The error for a step whose table would exceed :data:`MAX_STEP_ENTRIES`."""
    return ModelError(
        f"exact elimination here needs a table of {entries:.3g} entries "
        f"({entries * 8 / 2**30:.3g} GiB of float64) at one step, above the limit of "
        f"{MAX_STEP_ENTRIES:.3g}: the network is too densely connected for this question; "
        "observe more variables, or ask about fewer (marginal MAP over a subset)"
    )


def _widest_step(path: Path, shapes: Sequence[Sequence[int]]) -> int:
    """Entries of the largest product :func:`run` forms along ``path``."""
    sizes = {
        ch: n
        for term, shape in zip(path.terms, shapes, strict=True)
        for ch, n in zip(term, shape, strict=True)
    }
    steps = walk(path.terms, path.output, path.steps)
    return max((math.prod(sizes[ch] for ch in step.union) for step in steps), default=0)


def run(path: Path, operands: Sequence[T], algebra: Algebra[T]) -> tuple[T, str, list[Record]]:
    """Contract ``operands`` along ``path`` in ``algebra``.

    Returns the result (indices ``path.output``, possibly with a different axis order,
    given as the second return value) and the max-elimination records.
    """
    live: list[tuple[T, str]] = list(zip(operands, path.terms, strict=True))
    records: list[Record] = []
    for step in walk(path.terms, path.output, path.steps):
        chosen = [live[i] for i in step.inputs]
        kept = "".join(step.kept)
        dropped = "".join(ch for ch in step.union if ch not in step.kept)
        order = kept + dropped
        sizes = dict[str, int]()
        for value, term in chosen:
            sizes.update(zip(term, algebra.shape(value), strict=True))
        product: T | None = None
        for value, term in chosen:
            aligned = _align(algebra, value, term, order, sizes)
            product = aligned if product is None else algebra.multiply(product, aligned)
        assert product is not None
        if dropped:
            product, argmax = algebra.eliminate(product, len(kept))
            if argmax is not None:
                records.append(
                    Record(tuple(kept), tuple(dropped), tuple(sizes[ch] for ch in dropped), argmax)
                )
        live.append((product, kept))
    if len(live) != len(operands) + len(path.steps) or (not path.steps and len(live) != 1):
        raise AssertionError("contraction path did not reduce to one operand")
    result, term = live[-1]
    return result, term, records


class LogMax:
    """Max-product in log space (log 0 = -inf), so long products never underflow."""

    def shape(self, operand: FloatArray) -> tuple[int, ...]:
        """Shape of the operand."""
        return tuple(operand.shape)

    def rearrange(
        self, operand: FloatArray, axes: Sequence[int], shape: Sequence[int]
    ) -> FloatArray:
        """Transpose and reshape."""
        return operand.transpose(axes).reshape(shape)

    def multiply(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """Product of probabilities = sum of logs."""
        return np.add(a, b)

    def eliminate(self, operand: FloatArray, n_keep: int) -> tuple[FloatArray, IntArray]:
        """Max over the trailing axes, with the flat arg-max."""
        flat = operand.reshape(*operand.shape[:n_keep], -1)
        argmax = np.argmax(flat, axis=-1)
        return np.take_along_axis(flat, argmax[..., np.newaxis], axis=-1)[..., 0], argmax


def traceback(records: Sequence[Record]) -> dict[str, int]:
    """The maximising value of every max-eliminated index, from the last step back."""
    assignment: dict[str, int] = {}
    for record in reversed(records):
        flat = int(record.argmax[tuple(assignment[ch] for ch in record.kept)])
        for ch, value in zip(record.eliminated, np.unravel_index(flat, record.sizes), strict=True):
            assignment[ch] = int(value)
    return assignment


def _align(algebra: Algebra[T], value: T, term: str, order: str, sizes: dict[str, int]) -> T:
    """Put ``value``'s axes in the order of ``order``, with unit axes for missing indices."""
    axes = sorted(range(len(term)), key=lambda k: order.index(term[k]))
    shape = [sizes[ch] if ch in term else 1 for ch in order]
    return algebra.rearrange(value, axes, shape)


einsum: Callable[..., Any] = _orders.contract
"""Sum-product in sub-list form (``einsum(a, (0, 1), b, (1, 2), (0, 2))``), as numpy's C
``einsum`` without ``optimize`` (and without :func:`numpy.einsum`'s ``__array_function__``
dispatch, 2–3 µs a call). A product of at most 4,096 entries over float64 operands — most
steps of a Bayesian network's contractions — is summed by one loop in ``csrc/contract.c``:
numpy's einsum builds an iterator per call (1.2–1.6 µs on 24–512 entries, against 0.4–1.0
here), and a question asked between other work pays more still for the code and data
those calls bring back into the caches. Larger products, other dtypes, diagonals and
broadcast axes go to numpy's einsum unchanged; the answers agree to rounding."""


_MAX_OPERANDS = 24
"""``np.einsum`` takes at most 32 operands: a step of more than this is contracted in groups."""


class ConstantMemo:
    """Results of evidence-independent contraction steps, shared by :class:`SumProgram` s.

    Keyed by the identity of the input arrays, their labels and the kept labels; each entry
    keeps its input arrays alive, so an id cannot be reused by another array while it is
    stored. Holds at most ``budget`` float entries in all (then stores nothing more).
    """

    def __init__(self, budget: int = 1 << 22) -> None:
        self._results: dict[Any, tuple[tuple[Any, ...], FloatArray]] = {}
        self._left = budget

    @property
    def results(self) -> dict[Any, tuple[tuple[Any, ...], FloatArray]]:
        """The stored steps: ``{key: (input arrays, result)}`` (read by the compiled
        steps of :class:`SumProgram`)."""
        return self._results

    def put(self, key: Any, inputs: tuple[Any, ...], result: FloatArray) -> None:
        """Store ``result`` (of ``inputs``) if the budget allows."""
        if result.size <= self._left:
            self._left -= result.size
            result.flags.writeable = False  # shared by every program that reuses it
            self._results[key] = (inputs, result)


ProgramStep = tuple[tuple[Any, ...], tuple[tuple[int, int], ...], int, bool]
"""A compiled sum-product step: its ``einsum`` arguments (constant arrays and sub-list
labels, ``None`` where a register goes), which argument slot takes which register, the
register of its result, and whether it goes to BLAS. Tuples of arrays, ints and ``None``
only, which Python's cyclic collector stops tracking after a pass or three (one per level
of nesting), so the programs a network caches add nothing to later collections."""


class SumProgram:
    """A sum-product contraction compiled once: a given order, constants pre-contracted.

    opt_einsum's :class:`~opt_einsum.contract.ContractExpression` re-parses and dispatches
    every step at each call; for the many small contractions of a Bayesian network that
    overhead dominates. This replays an opt_einsum SSA path (from
    :func:`bayesmap.bn.plans.order`) as a fixed list of ``np.einsum`` calls in sub-list form
    (BLAS-backed :func:`opt_einsum.contract` for large steps), with every step whose inputs
    are all evidence-independent evaluated once, here.

    Parameters
    ----------
    scopes
        Labels (any hashable, e.g. variable ids) of each operand's axes.
    output
        Labels of the result, in order.
    operands
        For each operand: its constant array, or its shape if it is supplied per call.
    path
        SSA contraction path: step ``k`` contracts the operands it lists (inputs are
        numbered first, each step's result takes the next number); the last step gives
        ``output``. ``None``: the steps come one by one through :meth:`add` as an order
        is built (:func:`~bayesmap.bn.plans.order_steps`' ``emit``), then :meth:`finish`.
    kept
        Labels each step's result keeps (as :func:`walk` gives them), if known.
    memo
        Results of evidence-independent steps, shared between programs over the same
        constant arrays: a new pattern whose plan repeats a step of an earlier one (or of
        a prior marginal's computation) reuses its result instead of contracting it again.
    tuning
        Where a step of many operands is split (``split_above``) and where a pairwise
        step goes to BLAS (``blas_above``).
    """

    __slots__ = (
        "_live",
        "_memo",
        "_operands",
        "_output",
        "_size_table",
        "_steps",
        "_tuning",
        "n_inputs",
        "n_registers",
        "result",
        "steps",
    )

    def __init__(
        self,
        scopes: Sequence[Sequence[int]],
        output: Sequence[int],
        operands: Sequence[FloatArray | tuple[int, ...]],
        path: Sequence[Sequence[int]] | None,
        kept: Sequence[Sequence[int]] | None = None,
        memo: ConstantMemo | None = None,
        *,
        tuning: Tuning = TUNING,
    ) -> None:
        self._memo = memo
        self._tuning = tuning
        self._output = output
        # live operands: (constant value or None, register or -1, labels)
        live: list[tuple[Any, int, Sequence[int]]] = []
        self._live = live
        n_inputs = 0
        for scope, op in zip(scopes, operands, strict=True):
            if isinstance(op, tuple):
                live.append((None, n_inputs, scope))
                n_inputs += 1
            else:
                live.append((op, -1, scope))
        self.n_inputs = n_inputs
        self._operands = (scopes, operands)
        self._size_table: dict[int, int] | None = None
        self._steps: list[ProgramStep] = []  # step k writes register n_inputs + k
        self.steps: tuple[ProgramStep, ...] = ()
        self.n_registers = n_inputs
        self.result: tuple[Any, int] = (None, -1)
        if path is None:
            return
        if kept is None:
            kept = [step.kept for step in walk(scopes, output, path)]
        last = len(path) - 1
        for k, position in enumerate(path):
            self.add(position, output if k == last else kept[k])
        self.finish()

    @property
    def _sizes(self) -> dict[int, int]:
        """Entries of each label, from the operands (built when a step first needs it)."""
        table = self._size_table
        if table is None:
            table = self._size_table = {}
            for scope, op in zip(*self._operands, strict=True):
                table.update(zip(scope, op if isinstance(op, tuple) else op.shape, strict=True))
        return table

    def add(
        self,
        position: Sequence[int],
        kept: Sequence[int],
        entries: int | None = None,
        union: Iterable[int] | None = None,
    ) -> None:
        """Append the step contracting the operands at SSA numbers ``position`` into
        ``kept`` (the last step's labels may come in any order: :meth:`finish` puts them in
        the output's). ``entries``: the size of the operands' product, if known; ``union``:
        their labels in order of first appearance, if known."""
        if union is None:
            scopes = [self._live[i][2] for i in position]
            union = tuple(dict.fromkeys(chain.from_iterable(scopes)))
        else:
            union = tuple(union)
        if entries is None:
            sizes = self._sizes
            entries = math.prod([sizes[label] for label in union])
        self.extend([tuple(position)], [tuple(kept)], [(entries, union)])

    def extend(
        self,
        path: Sequence[Sequence[int]],
        kept: Sequence[Sequence[int]],
        records: Sequence[tuple[int, Iterable[int]]],
    ) -> None:
        """Append the steps of an order walked by :func:`bayesmap.bn.plans.order_steps`: their
        SSA operands, kept labels, and the entries and labels of each step's product.

        Compiled (``csrc/steps.c``): each step's ``einsum`` arguments are numbered there, and a
        step of constant operands looked up in the memo (most constant steps of a new
        pattern's program were met in an earlier one's); only the rare step that must be
        split or checked against :data:`MAX_STEP_ENTRIES` comes back to :meth:`_wide`."""
        memo = self._memo
        tuning = self._tuning
        _orders.emit(
            self._live,
            path,
            kept,
            records,
            None if memo is None else memo.results,
            self._steps,
            self.n_inputs,
            tuning.blas_above,
            tuning.split_above,
            _MAX_OPERANDS,
            MAX_STEP_ENTRIES,
            self._constant,
            self._wide,
        )

    def finish(self) -> None:
        """Close the program after its last step: the result's axes in the output's order."""
        value, source, labels = self._live[-1]
        output = self._output
        if tuple(labels) != tuple(output):
            axes = [list(labels).index(label) for label in output]
            if source < 0:
                value = value.transpose(axes)
            else:  # the last step writes its einsum output subscripts in the output's order
                template, fills, out, large = self._steps[-1]
                written = template[-1]
                self._steps[-1] = (
                    (*template[:-1], tuple([written[k] for k in axes])),
                    fills,
                    out,
                    large,
                )
        self.steps = tuple(self._steps)
        self.n_registers = self.n_inputs + len(self._steps)
        self.result = (value, source)
        # a cached program keeps its steps alone: what only building needed goes
        del self._live, self._steps, self._operands, self._size_table, self._memo

    def _wide(
        self,
        chosen: list[tuple[Any, int, Sequence[int]]],
        kept: Sequence[int],
        entries: int,
        union: Iterable[int],
    ) -> tuple[Any, int, Sequence[int]]:
        """A step the compiled :meth:`extend` hands back: one whose product has over
        :data:`MAX_STEP_ENTRIES` entries (a ModelError if the table it writes has too,
        before any allocation), or of many operands, split here."""
        if entries > MAX_STEP_ENTRIES:  # only then can the table it writes be too large
            sizes = self._sizes
            written = math.prod([sizes[label] for label in kept])
            if written > MAX_STEP_ENTRIES:
                raise _too_wide(written)
        large = entries > self._tuning.split_above
        if len(chosen) > 2 and (large or len(chosen) > _MAX_OPERANDS):
            return self._split(chosen, kept, large)
        return self._emit(chosen, kept, entries, union)

    def _split(
        self,
        chosen: list[tuple[Any, int, Sequence[int]]],
        kept: Sequence[int],
        large: bool,
    ) -> tuple[Any, int, Sequence[int]]:
        """Contract a step of many operands in groups (pairwise if ``large``).

        np.einsum would loop over the whole union of a step's indices (or refuse more than
        32 operands), so the operands are joined smallest first, summing each label once
        no later operand holds it.
        """
        sizes = self._sizes
        chosen.sort(key=lambda op: math.prod([sizes[label] for label in op[2]]))
        group = 1 if large else _MAX_OPERANDS - 1
        acc = chosen[0]
        for j in range(1, len(chosen), group):
            rest = chosen[j + group :]
            later = {label for _, _, scope in rest for label in scope}
            later.update(kept)
            joined = [acc, *chosen[j : j + group]]
            labels = dict.fromkeys(label for _, _, scope in joined for label in scope)
            keep = kept if not rest else [x for x in labels if x in later]
            acc = self._emit(joined, keep, math.prod([sizes[label] for label in labels]), labels)
        return acc

    def _emit(
        self,
        chosen: Sequence[tuple[Any, int, Sequence[int]]],
        kept: Sequence[int],
        entries: int,
        union: Iterable[int],
    ) -> tuple[Any, int, Sequence[int]]:
        """The step contracting ``chosen`` (``entries`` in their product, ``union`` their
        labels in order of first appearance) into ``kept``, by the compiled step of
        :meth:`extend`: a pairwise step over ``blas_above`` entries goes to BLAS."""
        memo = self._memo
        large = len(chosen) == 2 and entries > self._tuning.blas_above
        results = None if memo is None else memo.results
        return _orders.step(
            chosen, kept, tuple(union), large, results, self._steps, self.n_inputs, self._constant
        )

    def _constant(
        self, args: tuple[Any, ...], large: bool, key: Any, inputs: tuple[Any, ...]
    ) -> FloatArray:
        """Contract a step of constant operands now (``key``: its memo key, if memoised)."""
        result = _call(args, large)
        if key is not None and self._memo is not None:
            self._memo.put(key, inputs, result)
        return result

    def __call__(self, *inputs: FloatArray) -> FloatArray:
        """Contract, given the per-call operands in their order among ``operands``."""
        registers: list[Any] = [*inputs, *([None] * (self.n_registers - len(inputs)))]
        for template, fills, out, large in self.steps:
            args = list(template)
            for slot, source in fills:
                args[slot] = registers[source]
            registers[out] = opt_einsum.contract(*args) if large else einsum(*args)
        value, source = self.result
        return np.asarray(value if source < 0 else registers[source])


L = TypeVar("L", bound=Hashable)
"""A label of an operand's axis (a variable id, an einsum character, the case axis)."""


class Step(NamedTuple, Generic[L]):
    """One step of an SSA contraction path, as :func:`walk` reads it.

    Attributes
    ----------
    inputs
        SSA numbers of the operands it multiplies (inputs first, then each step's result).
    union
        Labels of their product, in order of first appearance among the operands.
    kept
        The labels its result keeps — held by a later operand or in the output — in
        ``union`` order; the others are summed (or maximised) out.
    """

    inputs: tuple[int, ...]
    union: tuple[L, ...]
    kept: tuple[L, ...]


class Walker(Generic[L]):
    """An SSA path read one step at a time: each operand's labels (inputs, then each step's
    result), which live operands hold each label, and which operands are still live.

    The Python reader of paths: :func:`walk` reads a whole path with it, and opt_einsum's
    greedy order is merged through it (:func:`~bayesmap.bn.plans.order_steps`). The
    elimination orders of a question are walked the same way by compiled code
    (``csrc/walk.c``: the holders of a label are the operands the step that sums it out
    joins), which ``tests/bn/test_orders.py`` checks step for step against this reader.
    """

    def __init__(self, scopes: Sequence[Iterable[L]], output: Iterable[L]) -> None:
        holders: dict[L, dict[int, None]] = {}
        for k, scope in enumerate(scopes):
            for label in scope:
                held = holders.get(label)
                if held is None:
                    holders[label] = {k: None}
                else:
                    held[k] = None
        for label in output:  # the output holds its labels for good (as SSA number -1)
            held = holders.get(label)
            if held is None:
                holders[label] = {-1: None}
            else:
                held[-1] = None
        self.holders = holders
        """The live operands (SSA numbers, oldest first) holding each label; -1 marks the
        output's labels."""
        self.live: list[Iterable[L]] = list(scopes)
        """Labels of every operand by SSA number."""
        self.open: dict[int, None] = dict.fromkeys(range(len(self.live)))
        """SSA numbers of the live operands (not yet joined), oldest first."""

    def step(self, position: Sequence[int]) -> Step[L]:
        """Multiply the operands at SSA numbers ``position``; the step, its result appended."""
        holders, live, open_ = self.holders, self.live, self.open
        result = len(live)
        union: dict[L, None] = {}
        for i in position:
            del open_[i]
            for label in live[i]:
                union[label] = None
                del holders[label][i]
        kept = tuple(compress(union, map(holders.__getitem__, union)))  # still held
        for label in kept:
            holders[label][result] = None
        live.append(kept)
        open_[result] = None
        return Step(tuple(position), tuple(union), kept)


def walk(
    scopes: Sequence[Iterable[L]],
    output: Iterable[L],
    path: Sequence[Sequence[int]],
) -> list[Step[L]]:
    """Read an SSA ``path`` over operands with labels ``scopes``: each step's operands, the
    labels of their product and the labels its result keeps.

    Every contraction here — compiled sum-product, two-pass, pluggable-arithmetic
    :func:`run`, and the costs of orders — walks its path through this one function.
    """
    walker = Walker(scopes, output)
    return [walker.step(position) for position in path]


def _call(args: Sequence[Any], large: bool) -> FloatArray:
    return np.asarray(opt_einsum.contract(*args) if large else einsum(*args))
