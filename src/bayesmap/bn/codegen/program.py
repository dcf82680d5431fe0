"""The straight-line programs behind generated C: one per target and observation pattern.

A question pattern (a target, the variables that *may* be observed, the variables that take
soft evidence) is answered in C by one function per subset of observed variables. Each
function is the engine's own plan for that subset (:func:`bayesmap.bn.plans.build`: barren
nodes pruned, d-separated components dropped, evidence-free ancestral sub-networks replaced
by their priors, CPTs sliced by the evidence) contracted along the engine's own fixed-point
path (:meth:`bayesmap.bn.inference.Engine.fixed_path`).

The steps are recorded by replaying :func:`bayesmap.bn.elimination.run` with
:class:`Tracer`, an algebra whose operands are views (a buffer, an offset, a size and stride
per axis) and whose ``multiply`` and ``eliminate`` append instructions. The C code therefore
multiplies, sums and renormalises in exactly the order the fixed-point engine does
(:mod:`bayesmap.bn.fixed_point`), which is what makes it agree bit for bit.

Soft evidence (a likelihood vector ``λ`` over the states of ``X``, Pearl's virtual
evidence) is a virtual binary data node ``X~soft`` with parent ``X``, observed in its first
state, whose table is ``[λ, 1 − λ]``: the engine answers the same question on the network
:func:`with_soft_evidence` builds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from bayesmap._typing import FloatArray
from bayesmap.bn import elimination
from bayesmap.bn.compiled import Compiled
from bayesmap.bn.model import BayesNet, DataSource
from bayesmap.bn.plans import Factor, Plan
from bayesmap.bn.suggest import unknown
from bayesmap.errors import ConfigError

SOFT_SUFFIX = "~soft"
"""Suffix of the virtual node that carries a variable's soft evidence."""
MAX_PATTERN_VARIABLES = 10
"""Most variables that may be observed: one C function per subset, ``2**k`` of them."""


@dataclass(frozen=True)
class Axis:
    """One axis of a view: the variable it runs over (``None`` for a unit axis)."""

    var: int | None
    size: int
    stride: int


@dataclass(frozen=True)
class Table:
    """Where a leaf operand's numbers live.

    ``kind`` is ``"cpt"`` (a constant CPT, ``(child, *parents)`` C order), ``"prior"`` (a
    constant prior marginal), ``"data"`` (a data node's table, given at query time) or
    ``"soft"`` (a soft-evidence vector, given at query time); ``var`` is the variable whose
    table it is (for ``"soft"``: the variable the evidence is about).
    """

    kind: str
    var: int


@dataclass(frozen=True)
class View:
    """Numbers addressed as ``base[offset + Σ evidence[slot]·stride + Σ i_k·axis_k.stride]``.

    ``table`` is a leaf's table, or ``None`` for a work buffer at ``work``.
    """

    table: Table | None
    work: int
    offset: tuple[tuple[int, int], ...]
    axes: tuple[Axis, ...]

    @property
    def size(self) -> int:
        """Number of entries it spans."""
        return math.prod(a.size for a in self.axes)


@dataclass(frozen=True)
class Multiply:
    """``out[i] = a[i]·b[i]`` over the broadcast axes, then renormalise ``out``."""

    out: View
    a: View
    b: View


@dataclass(frozen=True)
class MultiplySum:
    """``out[kept] = Σ_dropped renormalised(a·b)[kept, dropped]``, then renormalise ``out``.

    A product summed at once, never stored: the block's shift comes from a first pass over
    the products, the shifted products are summed in a second. The numbers are those of a
    :class:`Multiply` followed by an :class:`Eliminate`; the work array holds only ``out``.
    ``a`` and ``b`` are aligned on the product's axes, of which the first ``n_keep`` stay.
    """

    out: View
    a: View
    b: View
    n_keep: int


@dataclass(frozen=True)
class Eliminate:
    """``out[kept] = Σ_dropped source[kept, dropped]``, then renormalise ``out``."""

    out: View
    source: View
    n_keep: int


Step = Multiply | MultiplySum | Eliminate
"""One instruction of a :class:`Program`."""


@dataclass(frozen=True)
class Check:
    """The question is impossible unless the entry ``view`` picks (at the evidence) is > 0."""

    view: View


@dataclass
class Program:
    """The straight-line answer of one target for one subset of observed variables."""

    target: int
    observed: tuple[int, ...]
    checks: list[Check]
    steps: list[Step]
    result: View
    work_size: int


@dataclass
class Allocator:
    """First-fit placement of work buffers in one array, reusing the space of dead ones.

    A buffer read by an instruction is freed once that instruction has its output, so an
    output never overlaps its own inputs.
    """

    free: list[tuple[int, int]] = field(default_factory=list)
    pending: list[tuple[int, int]] = field(default_factory=list)
    top: int = 0

    def take(self, size: int) -> int:
        """Offset of a new buffer of ``size`` entries."""
        self._settle()
        for k, (start, length) in enumerate(self.free):
            if length >= size:
                if length == size:
                    del self.free[k]
                else:
                    self.free[k] = (start + size, length - size)
                return start
        start = self.top
        self.top += size
        return start

    def _settle(self) -> None:
        self.free.extend(self.pending)
        self.pending.clear()
        self.free.sort()
        merged: list[tuple[int, int]] = []
        for start, length in self.free:
            if merged and merged[-1][0] + merged[-1][1] == start:
                merged[-1] = (merged[-1][0], merged[-1][1] + length)
            else:
                merged.append((start, length))
        self.free = merged


@dataclass
class Tracer:
    """An :class:`~bayesmap.bn.elimination.Algebra` on views that records the instructions.

    A product is not placed in the work array until it is needed: if the next instruction
    sums it out, the two become one :class:`MultiplySum` and the product is never stored
    (the largest tables of a plan are such products).
    """

    steps: list[Step] = field(default_factory=list)
    allocator: Allocator = field(default_factory=Allocator)
    pending: tuple[View, View, View] | None = None
    placed: dict[int, tuple[View, View]] = field(default_factory=dict)

    def shape(self, operand: View) -> tuple[int, ...]:
        """Sizes of the axes."""
        return tuple(a.size for a in operand.axes)

    def rearrange(self, operand: View, axes: Sequence[int], shape: Sequence[int]) -> View:
        """Permute the axes, then insert unit axes: only the strides change."""
        operand = self.resolve(operand)
        moved = [operand.axes[k] for k in axes]
        out, j = [], 0
        for size in shape:
            if j < len(moved) and moved[j].size == size:
                out.append(moved[j])
                j += 1
            else:
                out.append(Axis(None, 1, 0))
        return View(operand.table, operand.work, operand.offset, tuple(out))

    def multiply(self, a: View, b: View) -> View:
        """Record a broadcast product (placed in the work array only if it is kept)."""
        a, b = self.resolve(a), self.resolve(b)
        if self.pending is not None:  # an earlier product, still needed later: place it
            self.resolve(self.pending[0])
        axes = tuple(x if x.size >= y.size else y for x, y in zip(a.axes, b.axes, strict=True))
        product = View(None, -1, (), _laid_out(axes))
        self.pending = (product, a, b)
        return product

    def eliminate(self, operand: View, n_keep: int) -> tuple[View, None]:
        """Record the sum over the trailing axes into a fresh buffer."""
        pending = self.pending
        if pending is not None and operand is pending[0]:
            _, a, b = pending
            self.pending = None
            out = self._fresh(operand.axes[:n_keep])
            self._release(a, b)
            self.steps.append(MultiplySum(out, a, b, n_keep))
            return out, None
        operand = self.resolve(operand)
        if pending is not None and self.pending is not None:
            self.resolve(pending[0])
        out = self._fresh(operand.axes[:n_keep])
        self._release(operand)
        self.steps.append(Eliminate(out, operand, n_keep))
        return out, None

    def resolve(self, view: View) -> View:
        """The placed view of a product (placing the pending one now), or ``view`` itself."""
        pending = self.pending
        if pending is not None and view is pending[0]:
            product, a, b = pending
            self.pending = None
            out = self._fresh(product.axes)
            self._release(a, b)
            self.steps.append(Multiply(out, a, b))
            self.placed[id(product)] = (product, out)
            return out
        entry = self.placed.get(id(view))
        return entry[1] if entry is not None and entry[0] is view else view

    def _fresh(self, axes: tuple[Axis, ...]) -> View:
        size = math.prod(a.size for a in axes)
        return View(None, self.allocator.take(size), (), _laid_out(axes))

    def _release(self, *views: View) -> None:
        for view in views:
            if view.table is None:
                self.allocator.pending.append((view.work, view.size))


def _laid_out(axes: tuple[Axis, ...]) -> tuple[Axis, ...]:
    """The axes of a contiguous C-order buffer (unit axes get stride 0)."""
    strides, step = [], 1
    for axis in reversed(axes):
        strides.append(step if axis.size > 1 else 0)
        step *= axis.size
    strides.reverse()
    return tuple(Axis(a.var, a.size, s) for a, s in zip(axes, strides, strict=True))


@dataclass
class SoftNetwork:
    """A copy of a network with a virtual evidence node ``X~soft`` below each soft variable.

    The node has states ``("seen", "not_seen")`` and, as a data node, the table
    ``[λ, 1 − λ]`` where ``λ`` is the likelihood vector last given to :meth:`set` (all ones
    at first). Observing it ``seen`` multiplies the joint by ``λ(X)``: Pearl's virtual
    evidence. This is the network the generated code answers questions about.
    """

    net: BayesNet
    likelihoods: dict[str, FloatArray]

    @classmethod
    def build(cls, net: BayesNet, soft: Sequence[str]) -> SoftNetwork:
        """Add the virtual nodes of ``soft`` to a copy of ``net``."""
        augmented = net.copy()
        likelihoods: dict[str, FloatArray] = {}
        for name in soft:
            card = augmented.cardinality(name)
            likelihoods[name] = np.ones(card)
            augmented.add_variable(
                name + SOFT_SUFFIX,
                ["seen", "not_seen"],
                parents=[name],
                cpt=np.stack([np.ones(card), np.zeros(card)]),
                source=_soft_source(likelihoods, name),
            )
        return cls(augmented, likelihoods)

    def set(self, name: str, likelihood: FloatArray | None) -> None:
        """Use ``λ(name)`` (entries in [0, 1]; ``None``: all ones) in the next questions."""
        card = self.net.cardinality(name)
        self.likelihoods[name] = (
            np.ones(card) if likelihood is None else np.asarray(likelihood, dtype=np.float64)
        )


def _soft_source(likelihoods: dict[str, FloatArray], name: str) -> DataSource:
    def source(evidence: Mapping[str, str]) -> FloatArray:
        del evidence
        likelihood = likelihoods[name]
        return np.stack([likelihood, 1.0 - likelihood])

    return source


def check_pattern(net: BayesNet, targets: Sequence[str], observable: Sequence[str]) -> None:
    """Raise :class:`ConfigError` unless the targets and observable variables make a pattern."""
    if not targets:
        raise ConfigError("code generation needs at least one target variable")
    for name in (*targets, *observable):
        if name not in net:
            raise ConfigError(
                f"network {net.name!r} has no variable {name!r}; "
                + unknown("variable", name, net.variables)
            )
    overlap = sorted(set(targets) & set(observable))
    if overlap:
        raise ConfigError(
            f"{overlap} cannot be both a target and evidence: the generated code answers "
            "the distribution of a target that is not observed"
        )
    for group, label in ((targets, "target"), (observable, "evidence variable")):
        if len(set(group)) != len(group):
            raise ConfigError(f"a {label} is listed twice in {list(group)}")
    if len(observable) > MAX_PATTERN_VARIABLES:
        raise ConfigError(
            f"{len(observable)} evidence variables would need 2**{len(observable)} "
            f"generated functions; declare at most {MAX_PATTERN_VARIABLES}"
        )


def trace(
    compiled: Compiled, plan: Plan, path: elimination.Path, soft: Mapping[int, int]
) -> Program:
    """Record the instructions of ``plan`` contracted along ``path`` (the engine's order).

    ``soft`` maps the id of each virtual soft-evidence node to the variable it is about.
    """
    tracer = Tracer()
    operands = [_leaf(compiled, f, soft) for f in plan.factors]
    result, term, _ = elimination.run(path, operands, tracer)
    result = tracer.resolve(result)
    if term != plan.output:  # one target: the only other order is none at all
        raise AssertionError("a one-target plan ended with a different output")
    checks = [Check(_leaf(compiled, f, soft)) for f in plan.checks]
    checks.extend(  # as Engine.check_dropped: not at or below a data node
        Check(View(Table("prior", v), 0, ((v, 1),), ()))
        for v in plan.dropped
        if not compiled.source_mask & (compiled.ancestor_masks[v] | 1 << v)
    )
    return Program(
        target=plan.targets[0],
        observed=tuple(v for v in plan.evidence if v not in soft),
        checks=checks,
        steps=tracer.steps,
        result=result,
        work_size=tracer.allocator.top,
    )


def _leaf(compiled: Compiled, factor: Factor, soft: Mapping[int, int]) -> View:
    """The view of a plan factor's table for one case: the evidence picks the offset.

    Tables keep their ``(child, *parents)`` C layout, so one constant array serves every
    pattern; a prior marginal (an evidence-free ancestral sub-network summed out by the
    plan) is its own constant vector, a soft-evidence factor the likelihood vector ``λ``.
    """
    v = factor.var
    if factor.array is not None and factor.array.ndim == 1 and compiled.parents[v]:
        return View(Table("prior", v), 0, (), (Axis(v, compiled.card[v], 1),))
    if v in soft:
        about = soft[v]
        if factor.free:
            return View(Table("soft", about), 0, (), (Axis(about, compiled.card[about], 1),))
        return View(Table("soft", about), 0, ((about, 1),), ())
    variables = (v, *compiled.parents[v])
    strides, step = {}, 1
    for u in reversed(variables):
        strides[u] = step
        step *= compiled.card[u]
    free = set(factor.free)
    offset = tuple((u, strides[u]) for u in variables if u not in free)
    axes = tuple(Axis(u, compiled.card[u], strides[u]) for u in factor.free)
    kind = "data" if v in compiled.sources else "cpt"
    return View(Table(kind, v), 0, offset, axes)
