"""MAP/MPE (eq. 13) and marginal MAP (eq. 14) against brute-force maximisation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.bn.helpers import brute_map, random_net, sample_evidence

from bayesmap.bn import BayesNet, elimination
from bayesmap.errors import ModelError

SEEDS = st.integers(0, 2**31 - 1)


@settings(max_examples=50, deadline=None)
@given(seed=SEEDS, n_evidence=st.integers(0, 3), zeros=st.sampled_from([0.0, 0.3]))
def test_mpe_is_the_brute_force_joint_argmax(seed: int, n_evidence: int, zeros: float) -> None:
    net = random_net(seed, n_vars=6, zero_fraction=zeros)
    evidence = sample_evidence(net, np.random.default_rng(seed), n_evidence)
    free = [n for n in net.variables if n not in evidence]
    assignment, probability = net.map(evidence)
    _, best, table = brute_map(net, free, evidence)
    assert probability == pytest.approx(best, rel=1e-9)
    index = tuple(net.states(v).index(assignment[v]) for v in free)
    assert table[index] == pytest.approx(best, rel=1e-9)  # ties may pick another argmax


@settings(max_examples=50, deadline=None)
@given(seed=SEEDS, n_evidence=st.integers(0, 3), n_query=st.integers(1, 3))
def test_marginal_map_is_the_brute_force_argmax(seed: int, n_evidence: int, n_query: int) -> None:
    net = random_net(seed, n_vars=6)
    rng = np.random.default_rng(seed)
    evidence = sample_evidence(net, rng, n_evidence)
    free = [n for n in net.variables if n not in evidence]
    query = [str(v) for v in rng.choice(free, size=min(n_query, len(free)), replace=False)]
    assignment, probability = net.marginal_map(query, evidence)
    _, best, table = brute_map(net, query, evidence)
    assert probability == pytest.approx(best, rel=1e-9)
    assert table[tuple(net.states(v).index(assignment[v]) for v in query)] == pytest.approx(best)


def test_joint_map_is_not_the_per_variable_argmax() -> None:
    """The classic trap: each marginal's argmax need not be part of the joint argmax."""
    net = BayesNet("trap")
    net.add_variable("A", ["0", "1"], cpt=[0.4, 0.6])
    net.add_variable("B", ["0", "1"], parents=["A"], cpt=[[0.9, 0.5], [0.1, 0.5]])
    per_variable = {v: max(net.posterior(v).items(), key=lambda kv: kv[1])[0] for v in "AB"}
    assert per_variable == {"A": "1", "B": "0"}  # P = 0.6 * 0.5 = 0.30
    assignment, probability = net.map()
    assert assignment == {"A": "0", "B": "0"}  # P = 0.4 * 0.9 = 0.36
    assert probability == pytest.approx(0.36)
    assert net.marginal_map(["B"]) == ({"B": "0"}, pytest.approx(0.66))


def test_map_keeps_observed_variables_out_and_handles_full_evidence() -> None:
    net = random_net(11, n_vars=4)
    evidence = sample_evidence(net, np.random.default_rng(0), 4)
    assignment, probability = net.map(evidence)
    assert assignment == {} and probability == pytest.approx(1.0)
    some = dict(list(evidence.items())[:2])
    assignment, _ = net.map(some)
    assert set(assignment) == set(net.variables) - set(some)
    chosen, _ = net.marginal_map([*some, next(v for v in net.variables if v not in some)], some)
    assert all(chosen[k] == v for k, v in some.items())


def test_map_on_a_long_chain_does_not_underflow() -> None:
    """Max-product runs in log space: 600 factors of ~0.3 are ~1e-314 in float64."""
    net = BayesNet("chain")
    net.add_variable("X0", ["a", "b", "c"], cpt=[0.3, 0.3, 0.4])
    step = np.full((3, 3), 0.35)
    np.fill_diagonal(step, 0.3)
    for i in range(1, 600):
        net.add_variable(f"X{i}", ["a", "b", "c"], parents=[f"X{i - 1}"], cpt=step)
    assignment, probability = net.map({"X599": "a"})
    assert len(assignment) == 599 and 0 < probability <= 1
    assert assignment["X0"] == "c"


def test_map_too_wide_for_memory_raises_model_error():
    """Three factors of 28 binary variables each, overlapping: any order multiplies two of
    them into a table of at least 2^29 entries, beyond the 2^27 limit."""
    terms = ["".join(chr(65 + (i + k) % 40) for k in range(28)) for i in range(3)]
    with pytest.raises(ModelError, match="too densely connected"):
        elimination.find_path(terms, "", [(2,) * 28] * 3)
