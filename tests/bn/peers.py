"""Copies of bayesmap networks in the peer libraries used as oracles (tests and benchmarks)."""

from __future__ import annotations

import numpy as np
import pyagrum as gum

from bayesmap.bn import BayesNet


def to_pyagrum(net: BayesNet) -> gum.BayesNet:
    """A pyAgrum copy of ``net`` with the same double-precision tables."""
    g = gum.BayesNet(net.name)
    for name in net.topological_order():
        g.add(gum.LabelizedVariable(name, name, list(net.states(name))))
    for name in net.variables:
        for parent in net.parents(name):
            g.addArc(parent, name)
    for name in net.variables:
        parents = net.parents(name)
        table = net.cpt(name)
        for index in np.ndindex(*table.shape[1:]):
            where = {p: int(i) for p, i in zip(parents, index, strict=True)}
            g.cpt(name)[where] = table[(slice(None), *index)].tolist()
    return g
