"""Random small networks and brute-force answers by full joint enumeration."""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np
import opt_einsum

from bayesmap.bn.model import BayesNet


def random_net(
    seed: int,
    *,
    n_vars: int = 5,
    max_card: int = 3,
    max_parents: int = 3,
    zero_fraction: float = 0.0,
) -> BayesNet:
    """A random DAG over ``n_vars`` variables with random CPTs (Dirichlet(1) columns)."""
    rng = np.random.default_rng(seed)
    net = BayesNet(f"random-{seed}")
    for i in range(n_vars):
        card = int(rng.integers(2, max_card + 1))
        k = int(rng.integers(0, min(i, max_parents) + 1))
        parents = [f"X{j}" for j in sorted(rng.choice(i, size=k, replace=False))] if k else []
        shape = (card, *(net.cardinality(p) for p in parents))
        table = rng.dirichlet(np.ones(card), size=shape[1:]).reshape(*shape[1:], card)
        table = np.moveaxis(table, -1, 0)
        if zero_fraction:
            mask = rng.random(shape) < zero_fraction
            mask[rng.integers(card)] = False
            table = np.where(mask, 0.0, table)
            table = table / table.sum(axis=0)
        net.add_variable(f"X{i}", [f"s{k}" for k in range(card)], parents=parents, cpt=table)
    return net


def joint(net: BayesNet) -> np.ndarray:
    """The full joint distribution, one axis per variable in ``net.variables`` order."""
    names = list(net.variables)
    sym = {n: opt_einsum.get_symbol(i) for i, n in enumerate(names)}
    terms = ["".join(sym[x] for x in (n, *net.parents(n))) for n in names]
    return np.asarray(
        opt_einsum.contract(
            ",".join(terms) + "->" + "".join(sym[n] for n in names),
            *[net.cpt(n) for n in names],
        )
    )


def condition(net: BayesNet, table: np.ndarray, evidence: Mapping[str, str]) -> np.ndarray:
    """The joint with every axis kept, zeroed outside the evidence."""
    names = list(net.variables)
    mask = np.ones(table.shape, dtype=bool)
    for name, state in evidence.items():
        axis = names.index(name)
        keep = np.zeros(table.shape[axis], dtype=bool)
        keep[net.states(name).index(state)] = True
        shape = [1] * table.ndim
        shape[axis] = -1
        mask &= keep.reshape(shape)
    return np.where(mask, table, 0.0)


def brute_posterior(net: BayesNet, targets: list[str], evidence: Mapping[str, str]) -> np.ndarray:
    """``P(targets | evidence)`` by enumeration (axes in ``targets`` order)."""
    names = list(net.variables)
    table = condition(net, joint(net), evidence)
    keep = [names.index(t) for t in targets]
    summed = table.sum(axis=tuple(i for i in range(table.ndim) if i not in keep))
    order = sorted(range(len(keep)), key=lambda k: keep[k])
    summed = np.transpose(summed, np.argsort(order))
    return summed / summed.sum()


def brute_map(
    net: BayesNet, variables: list[str], evidence: Mapping[str, str]
) -> tuple[dict[str, str], float, np.ndarray]:
    """Marginal MAP by enumeration: (assignment, P(assignment | e), the posterior table)."""
    post = brute_posterior(net, variables, evidence)
    flat = int(np.argmax(post))
    index = np.unravel_index(flat, post.shape)
    assignment = {v: net.states(v)[int(i)] for v, i in zip(variables, index, strict=True)}
    return assignment, float(post.flat[flat]), post


def all_assignments(net: BayesNet, names: list[str]) -> list[dict[str, str]]:
    """Every joint assignment of ``names``."""
    return [
        dict(zip(names, combo, strict=True))
        for combo in itertools.product(*(net.states(n) for n in names))
    ]


def sample_evidence(net: BayesNet, rng: np.random.Generator, k: int) -> dict[str, str]:
    """Evidence on ``k`` random variables, drawn from one forward sample (so P(e) > 0)."""
    sample: dict[str, str] = {}
    for name in net.topological_order():
        column = net.cpt(name)[
            (slice(None), *(net.states(p).index(sample[p]) for p in net.parents(name)))
        ]
        sample[name] = net.states(name)[int(rng.choice(column.size, p=column))]
    chosen = rng.choice(list(net.variables), size=min(k, len(net)), replace=False)
    return {str(n): sample[str(n)] for n in chosen}
