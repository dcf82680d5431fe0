"""Query plans: the pruned factor list of a question, built once per evidence pattern.

A plan depends on the network version, the queried variables and *which* variables are
observed — never on the observed values — so it is cached and reused every sensor cycle.
Building one:

1. **Barren nodes** (Post et al. 2016 §3.2: only ancestors matter): keep the targets, the
   evidence and their ancestors; every other CPT sums to 1 and drops out.
2. **Evidence slicing**: each CPT is transposed so its observed axes come first, so that
   ``table[e1, e2]`` (one case) or ``table[cols1, cols2]`` (a batch, giving a leading case
   axis) selects the evidence rows without copying the rest.
3. **d-separation**: after slicing, factors link the remaining free variables; connected
   components that hold no target are independent of the targets given the evidence and
   are dropped (their factors only scale the answer). Factors whose every variable is
   observed become scalar checks (a zero means impossible evidence).
4. **Contraction**: opt_einsum picks the order; :func:`opt_einsum.contract_expression`
   pre-contracts every evidence-independent sub-tree once (``constants=``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from operator import itemgetter
from typing import Any

import numpy as np
import opt_einsum

from bayesmap._typing import FloatArray
from bayesmap.bn.compiled import Compiled

BATCH = opt_einsum.get_symbol(0)
"""The einsum index of the case axis of batched queries."""


def symbol(var: int) -> str:
    """Einsum index of variable id ``var`` (index 0 is the case axis)."""
    return str(opt_einsum.get_symbol(var + 1))


@dataclass
class Factor:
    """One CPT of a plan, transposed so that its observed axes come first.

    Attributes
    ----------
    var
        Id of the variable whose CPT this is.
    array
        The transposed CPT (for a data node: ``None``, asked at query time).
    perm
        Axis permutation from ``(child, *parents)`` to ``(observed..., free...)``.
    ev_pos
        Position in the plan's evidence tuple of each observed axis.
    free
        Ids of the free variables, in axis order after the observed ones.
    """

    var: int
    array: FloatArray | None
    perm: tuple[int, ...]
    ev_pos: tuple[int, ...]
    free: tuple[int, ...]
    pick: Any = None

    def __post_init__(self) -> None:
        self.pick = itemgetter(*self.ev_pos) if self.ev_pos else None

    @property
    def term(self) -> str:
        """Einsum indices of the sliced factor (one case)."""
        return "".join(symbol(v) for v in self.free)

    @property
    def observed(self) -> bool:
        """Whether the factor depends on evidence values (observed axes or a data node)."""
        return bool(self.ev_pos) or self.array is None


@dataclass
class Plan:
    """Pruned, sliced factors of one question for one pattern of observed variables.

    Attributes
    ----------
    targets
        Ids of the free queried variables, in output order.
    evidence
        Ids of the observed variables, in the order evidence index lists use.
    factors
        Factors with at least one free variable (in the kept components).
    checks
        Factors whose every variable is observed: scalar probabilities of the evidence.
    """

    targets: tuple[int, ...]
    evidence: tuple[int, ...]
    factors: list[Factor]
    checks: list[Factor]
    cache: dict[Any, Any] = field(default_factory=dict)

    @property
    def output(self) -> str:
        """Einsum indices of the (one-case) result."""
        return "".join(symbol(v) for v in self.targets)


def build(
    compiled: Compiled,
    targets: Sequence[int],
    evidence: Sequence[int],
    *,
    prune_barren: bool = True,
    keep_all_components: bool = False,
    prior: Callable[[int], FloatArray] | None = None,
) -> Plan:
    """Build the plan of a question about ``targets`` given evidence on ``evidence``.

    Parameters
    ----------
    compiled
        The network.
    targets
        Free variables the answer is over (none: probability of the evidence).
    evidence
        Observed variables (ids), disjoint from ``targets``.
    prune_barren
        Drop variables that are neither targets, evidence nor their ancestors (valid for
        sum-product; MAP over all variables keeps them).
    keep_all_components
        Keep components without targets (needed for the probability of the evidence and
        for MAP over all variables).
    prior
        Gives the (cached) prior marginal of a variable; with it, every evidence-free
        ancestral sub-network that meets the rest only through one variable ``Y`` is
        replaced by ``P(Y)`` (see :func:`clean_roots`).
    """
    ev = tuple(evidence)
    ev_set = set(ev)
    if prune_barren:
        relevant = set(targets) | ev_set | compiled.ancestors([*targets, *ev])
    else:
        relevant = set(range(len(compiled.names)))
    replaced = clean_roots(compiled, relevant, ev_set, targets) if prior is not None else {}
    if replaced:
        removed = 0
        for y in replaced:
            removed |= compiled.ancestor_masks[y]
        relevant = {v for v in relevant if not (removed >> v) & 1}
    free_vars = relevant - ev_set
    parent_of = {v: v for v in free_vars}

    def find(v: int) -> int:
        while parent_of[v] != v:
            parent_of[v] = parent_of[parent_of[v]]
            v = parent_of[v]
        return v

    scopes = {
        v: [v] if v in replaced else [u for u in (v, *compiled.parents[v]) if u not in ev_set]
        for v in relevant
    }
    for scope in scopes.values():
        for u in scope[1:]:
            a, b = find(scope[0]), find(u)
            if a != b:
                parent_of[a] = b
    wanted = {find(t) for t in targets}
    factors: list[Factor] = []
    checks: list[Factor] = []
    for v in compiled.topo:
        if v not in relevant:
            continue
        scope = scopes[v]
        if scope and not keep_all_components and find(scope[0]) not in wanted:
            continue
        if v in replaced:
            assert prior is not None
            factors.append(Factor(var=v, array=prior(v), perm=(0,), ev_pos=(), free=(v,)))
            continue
        variables = (v, *compiled.parents[v])
        observed_axes = [k for k, u in enumerate(variables) if u in ev_set]
        free_axes = [k for k, u in enumerate(variables) if u not in ev_set]
        perm = (*observed_axes, *free_axes)
        array = (
            None
            if v in compiled.sources
            else np.ascontiguousarray(compiled.cpts[v].transpose(perm))
        )
        factor = Factor(
            var=v,
            array=array,
            perm=perm,
            ev_pos=tuple(ev.index(variables[k]) for k in observed_axes),
            free=tuple(variables[k] for k in free_axes),
        )
        (factors if scope else checks).append(factor)
    return Plan(targets=tuple(targets), evidence=ev, factors=factors, checks=checks)


def clean_roots(
    compiled: Compiled, relevant: set[int], evidence: set[int], targets: Sequence[int]
) -> set[int]:
    """Variables ``Y`` whose ancestors can be summed out into the prior ``P(Y)``.

    ``Y`` qualifies when no target, evidence or data node is among ``Y`` and its ancestors, and no
    ancestor of ``Y`` has a child in ``relevant`` outside ``Y`` and its ancestors (the
    sub-network meets the rest of the question only through ``Y``); then
    ``Σ_{An(Y)} Π P(· | ·) = P(Y)``. Only maximal ones with at least one ancestor are
    returned (two such sub-networks are nested or disjoint). Bit masks make
    this one pass over ``relevant``.
    """
    r_mask = 0
    for v in relevant:
        r_mask |= 1 << v
    skip = set(targets)
    tainted: set[int] = set()
    reach: dict[int, int] = {}  # children (in relevant) of the ancestors of each variable
    order = [v for v in compiled.topo if (r_mask >> v) & 1]
    for v in order:
        mask = 0
        for parent in compiled.parents[v]:
            child_mask = 0
            for child in compiled.children[parent]:
                child_mask |= 1 << child
            mask |= reach[parent] | (child_mask & r_mask)
        reach[v] = mask
        if (
            v in evidence
            or v in skip
            or v in compiled.sources
            or any(p in tainted for p in compiled.parents[v])
        ):
            tainted.add(v)
    chosen: set[int] = set()
    covered = 0
    for v in reversed(order):
        if v in tainted or (covered >> v) & 1 or not compiled.parents[v]:
            continue
        inside = compiled.ancestor_masks[v] | (1 << v)
        if reach[v] & ~inside == 0:
            chosen.add(v)
            covered |= compiled.ancestor_masks[v]
    return chosen
