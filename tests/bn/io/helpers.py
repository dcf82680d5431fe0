"""Shared by the file-format tests: example files, network strategies, comparisons."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pgmpy
from hypothesis import strategies as st

from bayesmap.bn.model import BayesNet, NodeKind

EXAMPLES = Path(pgmpy.__file__).parent / "utils" / "example_models"
BIF_EXAMPLES = sorted(EXAMPLES.glob("*.bif.gz"))
# Files compared with pgmpy in the default run (pgmpy needs about a second for each);
# the others are compared in slow-marked tests.
SMALL = {"alarm", "asia", "cancer", "child", "hailfinder", "win95pts"}


def example(name: str) -> Path:
    return EXAMPLES / f"{name}.bif.gz"


def assert_same(a: BayesNet, b: BayesNet, *, atol: float = 0.0, names: bool = True) -> None:
    """Same variables, states, parents, kinds, properties and CPTs (within ``atol``)."""
    if names:
        assert a.name == b.name
        assert a.properties == b.properties
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        va, vb = a.variable(name), b.variable(name)
        assert va.states == vb.states, name
        assert va.parents == vb.parents, name
        assert va.kind == vb.kind, name
        if names:
            assert va.properties == vb.properties, name
        np.testing.assert_allclose(va.cpt, vb.cpt, rtol=0, atol=atol, err_msg=name)


def assert_matches_pgmpy(net: BayesNet, model, *, atol: float = 1e-12) -> None:
    """Our network equals a pgmpy model (CPT columns renormalised as our model does)."""
    cpds = {cpd.variable: cpd for cpd in model.get_cpds()}
    assert set(net.variables) == set(model.nodes()) == set(cpds)
    for name in net.variables:
        cpd = cpds[name]
        evidence = list(cpd.variables[1:])
        assert set(net.parents(name)) == set(evidence), name
        values = cpd.get_values().reshape([cpd.cardinality[0], *cpd.cardinality[1:]])
        order = [0] + [1 + evidence.index(p) for p in net.parents(name)]
        for variable in (name, *evidence):
            assert net.states(variable) == tuple(str(s) for s in cpd.state_names[variable]), name
        _assert_table(net, name, np.transpose(values, order), atol)


def assert_matches_bif_reader(net: BayesNet, reader, *, atol: float = 1e-12) -> None:
    """Our network equals what pgmpy's BIFReader parsed (before it builds its model)."""
    assert set(net.variables) == set(reader.variable_names)
    for name in net.variables:
        parents = list(reader.variable_parents[name])
        assert net.parents(name) == tuple(parents), name
        assert net.states(name) == tuple(reader.variable_states[name]), name
        shape = (
            len(reader.variable_states[name]),
            *(len(reader.variable_states[p]) for p in parents),
        )
        _assert_table(net, name, np.asarray(reader.variable_cpds[name]).reshape(shape), atol)


def _assert_table(net: BayesNet, name: str, values: np.ndarray, atol: float) -> None:
    expected = values / values.sum(axis=0, keepdims=True)
    np.testing.assert_allclose(net.cpt(name), expected, rtol=0, atol=atol, err_msg=name)


def assert_matches_pyagrum(net: BayesNet, bn, *, atol: float = 1e-12) -> None:
    """Our network equals a pyAgrum BayesNet (states, parents, CPTs)."""
    assert set(net.variables) == set(bn.names())
    for name in net.variables:
        assert net.states(name) == tuple(bn.variable(name).labels()), name
        potential = bn.cpt(name)
        # pyAgrum's toarray() has the axes of potential.names in reverse order.
        axis_names = list(reversed(potential.names))
        array = np.asarray(potential.toarray())
        order = [axis_names.index(n) for n in (name, *net.parents(name))]
        assert set(potential.names) == {name, *net.parents(name)}, name
        np.testing.assert_allclose(
            net.cpt(name), np.transpose(array, order), rtol=0, atol=atol, err_msg=name
        )


# ------------------------------------------------------------------ hypothesis strategies
_ODD = st.characters(blacklist_categories=("Cs", "Cc", "Cn", "Co"))
odd_names = st.text(_ODD, min_size=1, max_size=8).filter(lambda s: s == s.strip())
peer_names = st.text("abcXYZ019_<>=+-/.", min_size=1, max_size=6)
plain_names = st.from_regex(r"[a-z][a-z0-9_]{0,5}", fullmatch=True)
property_keys = odd_names.filter(lambda s: "=" not in s and s not in ("kind", "description"))
property_values = st.text(_ODD, max_size=10).filter(lambda s: s == s.strip())


@st.composite
def networks(
    draw: st.DrawFn,
    names: st.SearchStrategy[str] = odd_names,
    *,
    kinds: bool = True,
    properties: bool = True,
    max_variables: int = 5,
    min_states: int = 1,
) -> BayesNet:
    """Random small networks: odd names, up to 3 parents, kinds and properties."""
    n = draw(st.integers(1, max_variables))
    variable_names = draw(st.lists(names, min_size=n, max_size=n, unique=True))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    net = BayesNet(draw(names))
    if properties:
        net.properties = draw(st.dictionaries(property_keys, property_values, max_size=2))
    for i, name in enumerate(variable_names):
        k = draw(st.integers(min_states, 4))
        states = draw(st.lists(names, min_size=k, max_size=k, unique=True))
        parents = (
            draw(st.lists(st.sampled_from(variable_names[:i]), max_size=3, unique=True))
            if i
            else []
        )
        shape = (k, *(net.cardinality(p) for p in parents))
        cpt = rng.dirichlet(np.ones(k), size=int(np.prod(shape[1:]))).T.reshape(shape)
        kind = draw(st.sampled_from([None, *NodeKind])) if kinds else None
        props = (
            draw(st.dictionaries(property_keys, property_values, max_size=2)) if properties else {}
        )
        net.add_variable(name, states, parents=parents, cpt=cpt, kind=kind, properties=props)
    return net
