"""The paper's ancestral recursive query, Post et al. 2016 eqs. 10, 26–27.

To answer ``P(X)``, walk the network backwards from ``X`` through its parents, and compute
each ancestor's distribution from its parents' — ``P(Y) = Σ_Z P(Y | Z) Π P(Z)`` (eq. 10,
the matrix products of Figs. 4–5) — saving each ``P(Y)`` for the children that need it.
An observed ancestor is a point mass for its children (its predictive distribution is
still computed, to detect evidence of probability zero).

The recursion multiplies the parents' distributions as if they were independent, and it
never looks at evidence below the target. It is therefore exact only when

1. every observed variable is an ancestor of the target, and
2. the target and its ancestors form a polytree: no two directed paths from one ancestor
   reach the target (then the parents of every visited node are d-separated given the
   evidence above them, and evidence never informs a node through its children).

:func:`is_exact` checks both; the engine uses the recursion as a fast path only then.
Distributions that depend on no evidence and no data node are the prior marginals; they
are cached and reused by every later query on the same network version.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, MutableMapping, Sequence

import numpy as np

from bayesmap._typing import FloatArray
from bayesmap.bn.compiled import Compiled, bits
from bayesmap.errors import InputError


def visited(compiled: Compiled, target: int) -> list[int]:
    """Ids the recursion visits for ``target``: it and all its ancestors, parents first."""
    seen = compiled.ancestor_masks[target] | 1 << target
    return [v for v in compiled.topo if (seen >> v) & 1]


def is_exact(
    compiled: Compiled, targets: Sequence[int], evidence: Iterable[int]
) -> list[int] | None:
    """The visiting order if the recursion is exact for this question, else ``None``.

    Exact means: one target, all evidence among its ancestors, and the target with its
    ancestors forming a polytree (edge count = node count − 1; the sub-graph is connected).
    """
    if len(targets) != 1:
        return None
    target = targets[0]
    above = compiled.ancestor_masks[target]
    if any(not (above >> v) & 1 for v in evidence):
        return None
    inside = above | 1 << target
    nodes = inside.bit_count()
    edges = 0
    for v in bits(inside):
        edges += len(compiled.parents[v])
        if edges >= nodes:
            return None
    return visited(compiled, target) if edges == nodes - 1 else None


def marginal(
    compiled: Compiled,
    target: int,
    evidence: Mapping[int, int],
    priors: MutableMapping[int, FloatArray],
    source_evidence: Callable[[], dict[str, str]],
    order: Sequence[int] | None = None,
) -> FloatArray:
    """``P(target | evidence)`` by the ancestral recursion of eq. 27.

    Parameters
    ----------
    compiled
        The network.
    target
        Id of the queried variable.
    evidence
        Observed ``{id: state index}``; evidence on non-ancestors is ignored.
    priors
        Cache of evidence-independent distributions (prior marginals), read and filled.
    source_evidence
        Gives the evidence by name for data nodes' sources.
    order
        The visiting order (from :func:`visited`), if already known.
    """
    if order is None:
        order = visited(compiled, target)
    beliefs: dict[int, FloatArray] = {}
    dependent: set[int] = set()
    for v in order:
        parents = compiled.parents[v]
        independent = v not in compiled.sources and not any(p in dependent for p in parents)
        belief = priors.get(v) if independent else None
        if belief is None:
            table = (
                compiled.table(v, source_evidence()) if v in compiled.sources else compiled.cpts[v]
            )
            belief = table
            for parent in reversed(parents):
                belief = belief @ beliefs[parent]
            if independent:
                priors[v] = belief
        if v in evidence:
            if not belief[evidence[v]] > 0.0:
                raise InputError(
                    f"the evidence {source_evidence()} has probability zero under the network "
                    f"({compiled.names[v]!r} cannot take that state given the rest)"
                )
            belief = np.zeros(compiled.card[v])
            belief[evidence[v]] = 1.0
            dependent.add(v)
        elif not independent:
            dependent.add(v)
        beliefs[v] = belief
    return beliefs[target]
