"""Exact posteriors against brute-force enumeration of the joint, on random small networks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.bn.helpers import brute_posterior, random_net, sample_evidence

from bayesmap.bn import BayesNet
from bayesmap.errors import InputError, ModelError

SEEDS = st.integers(0, 2**31 - 1)
FAST = settings(max_examples=60, deadline=None)


@FAST
@given(seed=SEEDS, n_evidence=st.integers(0, 4), zeros=st.sampled_from([0.0, 0.3]))
def test_posteriors_match_brute_force(seed: int, n_evidence: int, zeros: float) -> None:
    net = random_net(seed, n_vars=6, zero_fraction=zeros)
    evidence = sample_evidence(net, np.random.default_rng(seed), n_evidence)
    for target in net.variables:
        got = np.array(list(net.posterior(target, evidence).values()))
        assert got.sum() == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(got, brute_posterior(net, [target], evidence), atol=1e-12)


@FAST
@given(seed=SEEDS, n_evidence=st.integers(0, 3))
def test_joint_posterior_matches_brute_force(seed: int, n_evidence: int) -> None:
    net = random_net(seed, n_vars=6)
    rng = np.random.default_rng(seed)
    evidence = sample_evidence(net, rng, n_evidence)
    targets = [str(t) for t in rng.choice(list(net.variables), size=3, replace=False)]
    got = net.joint_posterior(targets, evidence)
    np.testing.assert_allclose(got, brute_posterior(net, targets, evidence), atol=1e-12)


@FAST
@given(seed=SEEDS)
def test_bayes_rule_between_two_queries(seed: int) -> None:
    """P(A|b) P(b) = P(b|A) P(A) for every state of A (eqs. 7, 12)."""
    net = random_net(seed, n_vars=5)
    rng = np.random.default_rng(seed)
    a, b = (str(n) for n in rng.choice(list(net.variables), size=2, replace=False))
    b_state = sample_evidence(net, rng, len(net))[b]
    p_b = net.posterior(b)[b_state]
    p_a = net.posterior(a)
    p_a_given_b = net.posterior(a, {b: b_state})
    for a_state, prior in p_a.items():
        p_b_given_a = net.posterior(b, {a: a_state})[b_state] if prior > 0 else 0.0
        assert p_a_given_b[a_state] * p_b == pytest.approx(p_b_given_a * prior, abs=1e-12)


@FAST
@given(seed=SEEDS, n_cases=st.integers(1, 12))
def test_batched_equals_looped(seed: int, n_cases: int) -> None:
    net = random_net(seed, n_vars=6, zero_fraction=0.2)
    rng = np.random.default_rng(seed)
    names = list(net.variables)
    cases = [sample_evidence(net, rng, int(rng.integers(0, 4))) for _ in range(n_cases)]
    table = np.full((n_cases, len(names)), -1)
    for i, case in enumerate(cases):
        for name, state in case.items():
            table[i, names.index(name)] = net.states(name).index(state)
    for target in names:
        looped = np.array([list(net.posterior(target, case).values()) for case in cases])
        np.testing.assert_allclose(net.posterior_batch(target, table), looped, atol=1e-12)
        np.testing.assert_allclose(net.posterior_batch(target, cases), looped, atol=1e-12)


def test_batch_with_named_columns_and_one_pattern() -> None:
    net = random_net(7, n_vars=6)
    rng = np.random.default_rng(1)
    cases = [sample_evidence(net, rng, len(net)) for _ in range(50)]
    columns = ["X1", "X4"]
    table = np.array([[net.states(c).index(case[c]) for c in columns] for case in cases])
    got = net.posterior_batch("X5", table, columns=columns)
    for row, case in zip(got, cases, strict=True):
        expected = brute_posterior(net, ["X5"], {c: case[c] for c in columns})
        np.testing.assert_allclose(row, expected, atol=1e-12)


def sprinkler() -> BayesNet:
    net = BayesNet("sprinkler")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Sprinkler", ["off", "on"], parents=["Rain"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    wet = np.array([[[1.0, 0.1], [0.2, 0.01]], [[0.0, 0.9], [0.8, 0.99]]])
    net.add_variable("Wet", ["no", "yes"], parents=["Rain", "Sprinkler"], cpt=wet)
    return net


def test_impossible_evidence_raises_input_error() -> None:
    net = sprinkler()
    impossible = {"Rain": "no", "Sprinkler": "off", "Wet": "yes"}
    for query in (
        lambda: net.posterior("Rain", impossible),
        lambda: net.posterior("Wet", impossible),
        lambda: net.joint_posterior(["Rain", "Wet"], impossible),
        lambda: net.posterior_batch("Rain", [{"Rain": "yes"}, impossible]),
        lambda: net.map(impossible),
        lambda: net.probability_of_evidence(impossible),
    ):
        with pytest.raises(InputError, match="probability zero"):
            query()


def test_unknown_names_raise_clear_errors() -> None:
    net = sprinkler()
    with pytest.raises(ModelError, match="no variable 'Snow'"):
        net.posterior("Snow")
    with pytest.raises(InputError, match="no state 'maybe'.*'no', 'yes'"):
        net.posterior("Rain", {"Wet": "maybe"})
    with pytest.raises(InputError, match="shape"):
        net.posterior_batch("Rain", np.zeros((2, 2), dtype=int))


def test_state_indices_are_accepted_as_evidence() -> None:
    net = sprinkler()
    assert net.posterior("Rain", {"Wet": 1}) == net.posterior("Rain", {"Wet": "yes"})


def test_probability_of_evidence_matches_brute_force() -> None:
    net = random_net(3, n_vars=6)
    evidence = sample_evidence(net, np.random.default_rng(3), 3)
    from tests.bn.helpers import condition, joint

    expected = condition(net, joint(net), evidence).sum()
    assert net.probability_of_evidence(evidence) == pytest.approx(expected, rel=1e-12)


def test_data_node_is_asked_at_query_time_with_the_evidence() -> None:
    """A 'D' node (§3.4): its table comes from a callable, e.g. a map lookup."""
    occupancy = {"c0": 0.1, "c1": 0.9}
    calls: list[dict[str, str]] = []

    def lookup(evidence: dict[str, str]) -> list[float]:
        calls.append(dict(evidence))
        p = occupancy[evidence["Cell"]]
        return [1 - p, p]

    net = BayesNet("map")
    net.add_variable("Cell", ["c0", "c1"], cpt=[0.5, 0.5], kind="B")
    net.add_variable("Obstacle", ["free", "occupied"], kind="D", source=lookup)
    net.add_variable(
        "Echo", ["none", "echo"], parents=["Obstacle"], cpt=[[0.9, 0.2], [0.1, 0.8]], kind="A"
    )
    for cell, p in occupancy.items():
        got = net.posterior("Obstacle", {"Cell": cell, "Echo": "echo"})
        expected = p * 0.8 / (p * 0.8 + (1 - p) * 0.1)
        assert got["occupied"] == pytest.approx(expected)
    assert calls and all("Cell" in c for c in calls)
    batch = net.posterior_batch("Obstacle", [{"Cell": "c0", "Echo": "echo"}, {"Cell": "c1"}])
    assert batch[1, 1] == pytest.approx(0.9)
    assert net.posterior("Echo", {"Cell": "c1"})["echo"] == pytest.approx(0.9 * 0.8 + 0.1 * 0.1)


@FAST
@given(seed=SEEDS, n_evidence=st.integers(0, 3))
def test_ancestral_recursion_is_exact_where_it_claims(seed: int, n_evidence: int) -> None:
    """Eq. 27: exact on polytrees with evidence on ancestors; used then as the fast path."""
    net = random_net(seed, n_vars=6, max_parents=1 + seed % 2)
    rng = np.random.default_rng(seed)
    evidence = sample_evidence(net, rng, n_evidence)
    for target in net.variables:
        if net.ancestral_is_exact(target, evidence):
            got = np.array(list(net.ancestral_posterior(target, evidence).values()))
            np.testing.assert_allclose(got, brute_posterior(net, [target], evidence), atol=1e-12)


def test_ancestral_recursion_is_only_approximate_on_a_loop() -> None:
    """A -> B -> D, A -> C -> D: the recursion treats B and C as independent."""
    net = BayesNet("diamond")
    net.add_variable("A", ["0", "1"], cpt=[0.5, 0.5])
    net.add_variable("B", ["0", "1"], parents=["A"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    net.add_variable("C", ["0", "1"], parents=["A"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    xor = np.array([[[1.0, 0.0], [0.0, 1.0]], [[0.0, 1.0], [1.0, 0.0]]])
    net.add_variable("D", ["0", "1"], parents=["B", "C"], cpt=xor)
    assert not net.ancestral_is_exact("D")
    assert net.ancestral_posterior("D")["1"] == pytest.approx(0.5)
    assert net.posterior("D")["1"] == pytest.approx(2 * 0.9 * 0.1)
    assert not net.ancestral_is_exact("B", {"C": "1"})
    assert net.ancestral_is_exact("D", {"B": "0", "C": "1"}) is False
    chain = BayesNet("chain")
    chain.add_variable("A", ["0", "1"], cpt=[0.3, 0.7])
    chain.add_variable("B", ["0", "1"], parents=["A"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    assert chain.ancestral_is_exact("B", {"A": "0"})
    assert not chain.ancestral_is_exact("A", {"B": "0"})


def test_large_batches_use_the_answer_memo_and_still_catch_impossible_cases() -> None:
    net = sprinkler()
    cases = [{"Sprinkler": s, "Wet": w} for s in ("off", "on") for w in ("no", "yes")] * 5
    got = net.posterior_batch("Rain", cases)
    for row, case in zip(got, cases, strict=True):
        np.testing.assert_allclose(row, list(net.posterior("Rain", case).values()), atol=1e-12)
    net.add_variable("Slip", ["no", "yes"], parents=["Wet"], cpt=[[0.9, 0.3], [0.1, 0.7]])
    states = [("no", "on", "yes"), ("yes", "off", "no")] * 5
    full = [dict(zip(("Rain", "Sprinkler", "Wet"), s, strict=True)) for s in states]
    assert net.posterior_batch("Slip", full).shape == (10, 2)
    full[7] = {"Rain": "no", "Sprinkler": "off", "Wet": "yes"}
    with pytest.raises(InputError, match="case 7: .*probability zero"):
        net.posterior_batch("Slip", full)


def test_a_variable_with_many_observed_children():
    """120 observed children give one contraction step of 121 operands: more than np.einsum
    takes at once, so the compiled program must split it; the answer is a closed form."""
    net = BayesNet("many sensors")
    prior = np.array([0.7, 0.3])
    net.add_variable("Obstacle", ["no", "yes"], cpt=prior)
    rng = np.random.default_rng(4)
    evidence, log_joint = {}, np.log(prior)
    for i in range(120):
        hit = float(rng.uniform(0.2, 0.3))
        cpt = np.array([[1 - hit, 0.8], [hit, 0.2]])
        net.add_variable(f"S{i}", ["quiet", "echo"], parents=["Obstacle"], cpt=cpt)
        evidence[f"S{i}"] = "echo" if i % 3 else "quiet"
        log_joint += np.log(cpt[int(i % 3 != 0)])
    log_evidence = np.logaddexp.reduce(log_joint)
    exact = np.exp(log_joint - log_evidence)
    np.testing.assert_allclose(list(net.posterior("Obstacle", evidence).values()), exact)
    assert net.probability_of_evidence(evidence) == pytest.approx(np.exp(log_evidence))
    assert net.map(evidence) == ({"Obstacle": "no"}, pytest.approx(exact[0]))
    cases = np.array([[net.states(v).index(s) for v, s in evidence.items()]] * 3)
    batch = net.posterior_batch("Obstacle", cases, columns=list(evidence))
    np.testing.assert_allclose(batch, np.tile(exact, (3, 1)))


def test_a_question_too_wide_for_memory_is_refused_before_allocating():
    """40 binary roots, 40 observed children of 8 random roots each: once the children are
    observed every root interacts with most others, and exact elimination needs a table of
    2^30 entries (8 GiB). The engine says so before allocating it."""
    rng = np.random.default_rng(7)
    net = BayesNet("wide")
    roots = [f"R{i}" for i in range(40)]
    for name in roots:
        net.add_variable(name, ["a", "b"], cpt=[0.5, 0.5])
    for i in range(40):
        parents = [str(p) for p in rng.choice(roots, size=8, replace=False)]
        cpt = rng.dirichlet([1.0, 1.0], size=2**8).T.reshape((2,) + (2,) * 8)
        net.add_variable(f"C{i}", ["a", "b"], parents=parents, cpt=cpt)
    with pytest.raises(ModelError, match="too densely connected"):
        net.posterior("R0", {f"C{i}": "a" for i in range(40)})
