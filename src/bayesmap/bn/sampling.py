"""Forward (ancestral) sampling of a network's joint distribution (Post et al. 2016 eq. 8).

The joint factorises as ``P(X_1, …, X_n) = Π_i P(X_i | Pa_i)``, so drawing each variable in
topological order from its CPT column selected by its parents' drawn states gives exact,
independent samples of the joint. Vectorised over samples: one inverse-CDF draw per
variable for all ``n`` samples at once.
"""

from __future__ import annotations

import numpy as np

from bayesmap._typing import IntArray
from bayesmap.bn.compiled import Compiled
from bayesmap.errors import InputError


def forward_sample(compiled: Compiled, n: int, *, rng: np.random.Generator) -> IntArray:
    """``n`` joint samples as an ``(n, n_variables)`` array of state indices.

    Columns follow ``compiled.names`` (the network's variable order). A data node's table
    is asked of its source with no evidence, as for an unconditioned query.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 0:
        raise InputError(f"the number of samples must be a whole number >= 0, got {n!r}")
    n = int(n)
    out = np.zeros((n, len(compiled.names)), dtype=np.int64)
    for v in compiled.topo:
        table = compiled.table(v, {})
        card = compiled.card[v]
        parents = compiled.parents[v]
        # (card, n): each sample's column P(X_v | its parents' drawn states)
        index: tuple[slice | IntArray, ...] = (slice(None), *(out[:, p] for p in parents))
        columns = table[index].reshape(card, -1)
        cumulative = np.cumsum(np.broadcast_to(columns, (card, n)), axis=0)
        # state k where cumulative[k - 1] <= u < cumulative[k]: never a state of probability 0
        u = rng.random(n) * cumulative[-1]
        out[:, v] = np.minimum((cumulative <= u[None, :]).sum(axis=0), card - 1)
    return out
