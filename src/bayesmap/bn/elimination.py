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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np
import opt_einsum

from bayesmap._typing import FloatArray, IntArray

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
    """A contraction order for fixed index strings, from :func:`opt_einsum.contract_path`."""

    terms: tuple[str, ...]
    output: str
    steps: tuple[tuple[int, ...], ...]


def find_path(terms: Sequence[str], output: str, shapes: Sequence[Sequence[int]]) -> Path:
    """Ask opt_einsum for a contraction order of ``terms -> output``."""
    if not terms:
        return Path((), output, ())
    equation = ",".join(terms) + "->" + output
    steps, _ = opt_einsum.contract_path(equation, *shapes, shapes=True, optimize="auto-hq")
    return Path(tuple(terms), output, tuple(tuple(s) for s in steps))


def run(path: Path, operands: Sequence[T], algebra: Algebra[T]) -> tuple[T, str, list[Record]]:
    """Contract ``operands`` along ``path`` in ``algebra``.

    Returns the result (indices ``path.output``, possibly with a different axis order,
    given as the second return value) and the max-elimination records.
    """
    live: list[tuple[T, str]] = list(zip(operands, path.terms, strict=True))
    records: list[Record] = []
    for step in path.steps:
        chosen = [live[i] for i in step]
        for i in sorted(step, reverse=True):
            del live[i]
        needed = set(path.output).union(*(term for _, term in live))
        union = "".join(dict.fromkeys("".join(term for _, term in chosen)))
        kept = "".join(ch for ch in union if ch in needed)
        dropped = "".join(ch for ch in union if ch not in needed)
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
    if len(live) != 1:
        raise AssertionError("contraction path did not reduce to one operand")
    result, term = live[0]
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


_LETTERS = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
_SMALL = 1 << 14
"""Pairwise products up to this many entries go to ``np.einsum`` directly (no BLAS set-up)."""


@dataclass(frozen=True)
class _Step:
    inputs: tuple[tuple[bool, Any], ...]  # (is constant, array or register)
    subscripts: str
    output: int
    large: bool


class SumProgram:
    """A sum-product contraction compiled once: opt_einsum's order, constants pre-contracted.

    opt_einsum's :class:`~opt_einsum.contract.ContractExpression` re-parses and dispatches
    every step at each call; for the many small contractions of a Bayesian network that
    overhead dominates. This replays :func:`opt_einsum.contract_path`'s order as a fixed list
    of ``np.einsum`` calls (BLAS-backed :func:`opt_einsum.contract` for large steps), with
    every step whose inputs are all evidence-independent evaluated once, here.

    Parameters
    ----------
    terms
        Einsum indices of each operand.
    output
        Indices of the result, in order.
    operands
        For each operand: its constant array, or its shape if it is supplied per call.
    """

    def __init__(
        self, terms: Sequence[str], output: str, operands: Sequence[FloatArray | tuple[int, ...]]
    ) -> None:
        shapes = [op if isinstance(op, tuple) else op.shape for op in operands]
        sizes: dict[str, int] = {}
        for term, shape in zip(terms, shapes, strict=True):
            sizes.update(zip(term, shape, strict=True))
        live: list[tuple[bool, Any, str]] = []
        n_inputs = 0
        for term, op in zip(terms, operands, strict=True):
            if isinstance(op, tuple):
                live.append((False, n_inputs, term))
                n_inputs += 1
            else:
                live.append((True, op, term))
        self.n_inputs = n_inputs
        steps: list[_Step] = []
        register = n_inputs
        if len(live) > 1:
            index_sets = [frozenset(term) for term in terms]
            order = opt_einsum.paths.optimal if len(live) <= 4 else opt_einsum.paths.greedy
            path = order(index_sets, frozenset(output), sizes)
        else:
            path = [(0,)]
        count: dict[str, int] = {}
        for term in terms:
            for ch in term:
                count[ch] = count.get(ch, 0) + 1
        for ch in output:
            count[ch] = count.get(ch, 0) + 1
        for position in path:
            chosen = [live[i] for i in position]
            for i in sorted(position, reverse=True):
                del live[i]
            union = "".join(dict.fromkeys("".join(term for _, _, term in chosen)))
            for _, _, term in chosen:
                for ch in term:
                    count[ch] -= 1
            if live:
                kept = "".join(ch for ch in union if count[ch] > 0)
                for ch in kept:
                    count[ch] += 1
            else:
                kept = output
            letters = {ch: _LETTERS[k] for k, ch in enumerate(dict.fromkeys(union + kept))}
            subscripts = (
                ",".join("".join(letters[ch] for ch in term) for _, _, term in chosen)
                + "->"
                + "".join(letters[ch] for ch in kept)
            )
            large = math.prod(sizes[ch] for ch in union) > _SMALL
            if all(constant for constant, _, _ in chosen):
                value = _einsum(subscripts, [v for _, v, _ in chosen], large)
                live.append((True, value, kept))
                continue
            inputs = tuple((constant, value) for constant, value, _ in chosen)
            steps.append(_Step(inputs, subscripts, register, large))
            live.append((False, register, kept))
            register += 1
        self.steps = tuple(steps)
        self.n_registers = register
        constant, value, _ = live[0]
        self.result: tuple[bool, Any] = (constant, value)

    def __call__(self, *inputs: FloatArray) -> FloatArray:
        """Contract, given the per-call operands in their order among ``operands``."""
        registers: list[Any] = [*inputs, *([None] * (self.n_registers - len(inputs)))]
        for step in self.steps:
            args = [value if constant else registers[value] for constant, value in step.inputs]
            registers[step.output] = (
                opt_einsum.contract(step.subscripts, *args)
                if step.large
                else np.einsum(step.subscripts, *args)
            )
        constant, value = self.result
        return np.asarray(value if constant else registers[value])


def _einsum(subscripts: str, arrays: Sequence[FloatArray], large: bool) -> FloatArray:
    if large:
        return np.asarray(opt_einsum.contract(subscripts, *arrays))
    return np.asarray(np.einsum(subscripts, *arrays))
