"""Every marginal from one contraction and its reverse: the two-pass scheme.

The probability of the evidence is one contraction of the network's sliced CPTs (Post et
al. 2016 eq. 24, the normaliser Σ), ``Z = Σ Π_i φ_i``. Its partial derivative by a factor,
``∂Z/∂φ_k``, is the contraction of every *other* factor to ``φ_k``'s variables, so
``φ_k · ∂Z/∂φ_k`` summed to a variable ``X`` of ``φ_k`` is the joint ``P(X, e)`` (Darwiche
2003, "A differential approach to inference in Bayesian networks"). Reverse-mode
differentiation of the contraction gives all the derivatives at once: walk the forward
steps backwards, and the adjoint of each step's input is its step's adjoint contracted
with the step's other input. That is the collect/distribute pair of junction-tree
propagation laid over the elimination tree of the contraction order: each intermediate
table of the forward pass is reused by the backward pass, and the whole costs about three
contractions instead of one per variable.

:class:`TwoPass` compiles this once per question pattern: the order is made pairwise, every
step whose inputs do not depend on the evidence is evaluated at build time, and each call
replays a fixed list of ``np.einsum`` calls (BLAS-backed :func:`opt_einsum.contract` for
large ones); adjoints are computed only where a wanted factor lies below.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

from bayesmap._lazy import lazy_module
from bayesmap._typing import FloatArray
from bayesmap.bn.elimination import einsum, walk
from bayesmap.bn.tuning import TUNING, Tuning

opt_einsum = lazy_module("opt_einsum")  # loads on first use: keeps ``import bayesmap.bn`` lean


class _Node:
    """One table of the forward pass: an input or the product of one or two earlier ones."""

    __slots__ = ("args", "constant", "inputs", "labels", "large", "reshape", "value")

    def __init__(self, labels: tuple[Hashable, ...], value: Any, inputs: tuple[int, ...]) -> None:
        self.labels = labels
        self.value = value  # the array if evidence-independent, else None
        self.constant = value is not None
        self.inputs = inputs
        self.args: list[Any] = []
        self.large = False
        self.reshape: Any = None


def _sublist(
    operands: Sequence[tuple[int, tuple[Hashable, ...]]],
    output: Sequence[Hashable],
    sizes: dict[Hashable, int],
    large_above: int,
) -> tuple[list[Any], bool]:
    """An ``np.einsum`` sub-list template (array slots hold node numbers) and whether it is
    over more than ``large_above`` joint entries (then opt_einsum, BLAS, runs it)."""
    index: dict[Hashable, int] = {}
    args: list[Any] = []
    for node, labels in operands:
        args.append(node)
        args.append([index.setdefault(label, len(index)) for label in labels])
    args.append([index[label] for label in output])
    return args, math.prod([sizes[label] for label in index]) > large_above


def _run(args: list[Any], store: Sequence[Any], large: bool) -> Any:
    """Fill a :func:`_sublist` template from ``store`` and contract."""
    contract = opt_einsum.contract if large else einsum
    if len(args) == 5:
        return contract(store[args[0]], args[1], store[args[2]], args[3], args[4])
    if len(args) == 3:
        return contract(store[args[0]], args[1], args[2])
    filled = [store[a] if k % 2 == 0 and k < len(args) - 1 else a for k, a in enumerate(args)]
    return contract(*filled)


class TwoPass:
    """``Z`` and the joints ``P(X, e)`` of chosen variables, compiled for one pattern.

    Parameters
    ----------
    scopes
        Labels of each factor's axes.
    operands
        Each factor's constant array, or ``None`` if it is given per call.
    path
        SSA contraction path over the factors (steps may join any number of them).
    output
        Labels never summed (the case axis of a batch, or none).
    sizes
        Size of every label.
    wanted
        ``(factor k, label X)`` pairs: the call returns ``Σ φ_k · ∂Z/∂φ_k`` over
        ``output + (X,)`` for each.
    tuning
        Steps over more joint entries than ``tuning.two_pass_blas_above`` run on opt_einsum
        (BLAS) rather than ``np.einsum``.
    """

    def __init__(
        self,
        scopes: Sequence[tuple[Hashable, ...]],
        operands: Sequence[FloatArray | None],
        path: Sequence[Sequence[int]],
        output: tuple[Hashable, ...],
        sizes: dict[Hashable, int],
        wanted: Sequence[tuple[int, Hashable]],
        *,
        tuning: Tuning = TUNING,
    ) -> None:
        large = tuning.two_pass_blas_above
        self.n_inputs = len(scopes)
        self.output = output
        nodes = [_Node(tuple(s), op, ()) for s, op in zip(scopes, operands, strict=True)]
        kept = [step.kept for step in walk(scopes, output, path)]
        ssa = list(range(len(nodes)))  # SSA number -> node number
        last = len(path) - 1
        for k, step in enumerate(path):
            keep = tuple(output) if k == last else tuple(kept[k])
            members = sorted((ssa[i] for i in step), key=lambda n: len(nodes[n].labels))
            acc = members[0]
            if len(members) == 1:
                acc = self._add(nodes, (acc,), keep, sizes, large)
            for j, other in enumerate(members[1:], start=2):
                later = {lab for n in members[j:] for lab in nodes[n].labels} | set(keep)
                union = dict.fromkeys((*nodes[acc].labels, *nodes[other].labels))
                labels = keep if j == len(members) else tuple(x for x in union if x in later)
                acc = self._add(nodes, (acc, other), labels, sizes, large)
            ssa.append(acc)
        self.root = ssa[-1]
        self.nodes = nodes
        # adjoints are needed on the way from the root down to each wanted factor
        parent = {i: n for n, node in enumerate(nodes) for i in node.inputs}
        needed: set[int] = set()
        for k, _ in wanted:
            n = k
            while n in parent and n not in needed:
                needed.add(n)
                n = parent[n]

        # an adjoint is a derivative of every output entry: it carries the output labels
        def adjoint_labels(n: int) -> tuple[Hashable, ...]:
            own = nodes[n].labels
            return (*(lab for lab in output if lab not in own), *own)

        self.backward: list[tuple[int, int, list[Any], bool, Any]] = []
        for n in range(len(nodes) - 1, self.n_inputs - 1, -1):
            node = nodes[n]
            for i in node.inputs:
                if i not in needed:
                    continue
                others = [(j, nodes[j].labels) for j in node.inputs if j != i]
                others.append((-1 - n, adjoint_labels(n)))
                present = {lab for _, labels in others for lab in labels}
                full = adjoint_labels(i)
                target = tuple(lab for lab in full if lab in present)
                args, big = _sublist(others, target, sizes, large)
                spread = None
                if len(target) < len(full):  # labels only φ_i holds: constant along them
                    spread = [(a, sizes[lab]) for a, lab in enumerate(full) if lab not in present]
                self.backward.append((i, n, args, big, spread))
        self.marginals = [
            _sublist(
                [(k, nodes[k].labels), (-1 - k, adjoint_labels(k))], (*output, label), sizes, large
            )
            for k, label in wanted
        ]
        self.forward = [n for n in range(self.n_inputs, len(nodes)) if not nodes[n].constant]
        # one store for both passes: node n's value at n, its adjoint at len(nodes) + n
        size = len(nodes)
        for template in [args for *_, args, _, _ in self.backward] + [
            args for args, _ in self.marginals
        ]:
            for k in range(0, len(template) - 1, 2):
                if template[k] < 0:
                    template[k] = size - 1 - template[k]  # -1 - n -> size + n
        self.size = size

    @staticmethod
    def _add(
        nodes: list[_Node],
        inputs: tuple[int, ...],
        labels: tuple[Hashable, ...],
        sizes: dict[Hashable, int],
        large_above: int,
    ) -> int:
        node = _Node(labels, None, inputs)
        node.args, node.large = _sublist(
            [(i, nodes[i].labels) for i in inputs], labels, sizes, large_above
        )
        if all(nodes[i].constant for i in inputs):
            node.value = _run(node.args, [nodes[i].value for i in range(len(nodes))], node.large)
            node.constant = True
        nodes.append(node)
        return len(nodes) - 1

    def __call__(self, operands: Sequence[FloatArray]) -> tuple[FloatArray, list[FloatArray]]:
        """``Z`` over ``output`` and the wanted joints, given the per-call factors (the
        factors whose operand was ``None``, in their order)."""
        nodes, size = self.nodes, self.size
        store: list[Any] = [node.value for node in nodes] + [None] * size
        given = iter(operands)
        for k in range(self.n_inputs):
            if store[k] is None:
                store[k] = next(given)
        for n in self.forward:
            node = nodes[n]
            store[n] = _run(node.args, store, node.large)
        store[size + self.root] = np.ones(np.shape(store[self.root]))
        for i, _, args, large, spread in self.backward:
            grad = _run(args, store, large)
            if spread is not None:
                grad = np.expand_dims(grad, [a for a, _ in spread])
                shape = list(grad.shape)
                for a, length in spread:
                    shape[a] = length
                grad = np.broadcast_to(grad, shape)
            store[size + i] = grad
        joints = [np.asarray(_run(args, store, large)) for args, large in self.marginals]
        return np.asarray(store[self.root]), joints
