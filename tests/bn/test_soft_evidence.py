"""Soft (likelihood) evidence: brute force, pyAgrum's soft evidence, fixed point and batches."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.bn.helpers import brute_posterior, joint, random_net, sample_evidence
from tests.bn.peers import to_pyagrum

import bayesmap.bn as bn
from bayesmap.bn import BayesNet
from bayesmap.errors import InputError

gum = pytest.importorskip("pyagrum")
pgmpy = pytest.importorskip("pgmpy")


def brute_soft(
    net: BayesNet, targets: list[str], evidence: dict[str, str], soft: dict[str, np.ndarray]
) -> np.ndarray:
    """``P(targets | evidence, soft)`` by weighting the full joint."""
    names = list(net.variables)
    table = joint(net)
    for name, weights in soft.items():
        shape = [1] * table.ndim
        shape[names.index(name)] = -1
        table = table * np.asarray(weights).reshape(shape)
    for name, state in evidence.items():
        keep = np.zeros(net.cardinality(name))
        keep[net.states(name).index(state)] = 1.0
        shape = [1] * table.ndim
        shape[names.index(name)] = -1
        table = table * keep.reshape(shape)
    keep_axes = [names.index(t) for t in targets]
    summed = table.sum(axis=tuple(i for i in range(table.ndim) if i not in keep_axes))
    order = np.argsort(np.argsort(keep_axes))
    summed = np.transpose(summed, np.argsort(order)) if len(targets) > 1 else summed
    return summed / summed.sum()


def soft_case(
    net: BayesNet, rng: np.random.Generator
) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    evidence = sample_evidence(net, rng, int(rng.integers(0, 3)))
    free = [v for v in net.variables if v not in evidence]
    chosen = rng.choice(free, size=min(len(free), int(rng.integers(1, 4))), replace=False)
    soft = {str(v): rng.random(net.cardinality(str(v))) + 0.05 for v in chosen}
    return evidence, soft


@pytest.mark.parametrize("seed", range(12))
def test_posterior_joint_and_probability_match_brute_force(seed: int) -> None:
    net = random_net(seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    evidence, soft = soft_case(net, rng)
    for target in net.variables:
        expected = brute_soft(net, [target], evidence, soft)
        got = np.array(list(net.posterior(target, evidence, soft=soft).values()))
        np.testing.assert_allclose(got, expected, atol=1e-12)
    pair = [v for v in net.variables if v not in evidence][:2]
    np.testing.assert_allclose(
        net.joint_posterior(pair, evidence, soft=soft),
        brute_soft(net, pair, evidence, soft),
        atol=1e-12,
    )
    a, b = pair
    sa, sb = net.states(a)[0], net.states(b)[-1]
    table = brute_soft(net, pair, evidence, soft)
    expected_or = table[0, :].sum() + table[:, -1].sum() - table[0, -1]
    assert net.probability(f"{a}={sa} or {b}={sb}", evidence, soft=soft) == pytest.approx(
        expected_or, abs=1e-12
    )
    fixed = net.posterior_fixed(a, evidence, "Q16.16", soft=soft)
    exact = brute_soft(net, [a], evidence, soft)
    assert np.all(np.abs(fixed.values - exact) <= fixed.bound)


@pytest.mark.parametrize("seed", range(6))
def test_map_with_soft_evidence_maximises_the_weighted_joint(seed: int) -> None:
    net = random_net(100 + seed, n_vars=6, max_card=3)
    rng = np.random.default_rng(seed)
    evidence, soft = soft_case(net, rng)
    free = [v for v in net.variables if v not in evidence]
    table = brute_soft(net, free, evidence, soft)
    assignment, p = net.map(evidence, soft=soft)
    assert p == pytest.approx(table.max(), rel=1e-9)
    index = tuple(net.states(v).index(assignment[v]) for v in free)
    assert table[index] == pytest.approx(table.max(), rel=1e-9)
    _, fixed = net.map_fixed(evidence, "Q16.16", soft=soft)
    assert abs(float(fixed.values) - table.max()) <= float(fixed.bound)
    pair = free[:2]
    marginal = brute_soft(net, pair, evidence, soft)
    chosen, q = net.marginal_map(pair, evidence, soft=soft)
    assert q == pytest.approx(marginal.max(), rel=1e-9)


@pytest.mark.parametrize("name", ["asia", "alarm", "child", "insurance"])
def test_posteriors_match_pyagrum_soft_evidence(name: str) -> None:
    net = bn.read(Path(pgmpy.__file__).parent / "utils" / "example_models" / f"{name}.bif.gz")
    g = to_pyagrum(net)
    rng = np.random.default_rng(len(name))
    for _ in range(4):
        evidence, soft = soft_case(net, rng)
        engine = gum.LazyPropagation(g)
        engine.setEvidence({**evidence, **{k: v.tolist() for k, v in soft.items()}})
        engine.makeInference()
        for target in rng.choice(list(net.variables), size=5, replace=False):
            target = str(target)
            theirs = engine.posterior(target).toarray()
            ours = np.array(list(net.posterior(target, evidence, soft=soft).values()))
            np.testing.assert_allclose(ours, theirs, atol=1e-9)


def test_batch_soft_evidence_matches_one_case_at_a_time() -> None:
    net = random_net(7, n_vars=7, max_card=3)
    rng = np.random.default_rng(7)
    cases = net.sample(40, rng=rng)
    cases[rng.random(cases.shape) < 0.6] = -1
    soft_var = net.variables[2]
    cases[:, 2] = -1
    weights = rng.random((40, net.cardinality(soft_var)))
    for target in (net.variables[0], soft_var, net.variables[-1]):
        got = net.posterior_batch(target, cases, soft={soft_var: weights})
        for i in range(40):
            evidence = {net.variables[j]: int(s) for j, s in enumerate(cases[i]) if s >= 0}
            one = net.posterior(target, evidence, soft={soft_var: weights[i]})
            np.testing.assert_allclose(got[i], list(one.values()), atol=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_fixed_point_batch_soft_evidence_is_within_its_bound_of_float(seed: int) -> None:
    """Each case's Q16.16 answer lies within its guaranteed bound of the float64 answer,
    whichever variables are observed (cases with nothing observed included)."""
    net = random_net(seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    cases = net.sample(30, rng=rng)
    cases[rng.random(cases.shape) < 0.6] = -1
    cases[:3] = -1
    soft_vars = [str(v) for v in rng.choice(net.variables, size=2, replace=False)]
    soft = {}
    for v in soft_vars:
        cases[:, net.variables.index(v)] = -1
        soft[v] = rng.random((30, net.cardinality(v))) + 0.05
    for target in (net.variables[0], soft_vars[0], net.variables[-1]):
        exact = net.posterior_batch(target, cases, soft=soft)
        fixed = net.posterior_batch_fixed(target, cases, "Q16.16", soft=soft)
        assert fixed.values.shape == exact.shape
        assert np.all(np.abs(fixed.values - exact) <= fixed.bound)
        assert np.all(fixed.bound < 0.05)  # a bound that says something


@pytest.mark.parametrize("name", ["asia", "alarm", "child"])
def test_fixed_point_batch_soft_evidence_matches_pyagrum(name: str) -> None:
    net = bn.read(Path(pgmpy.__file__).parent / "utils" / "example_models" / f"{name}.bif.gz")
    g = to_pyagrum(net)
    rng = np.random.default_rng(len(name))
    names = list(net.variables)
    columns, (soft_var, target) = np.split(rng.choice(names, size=4, replace=False), [2])
    columns = [str(c) for c in columns]
    soft_var, target = str(soft_var), str(target)
    cases = net.sample(12, rng=rng)[:, [names.index(c) for c in columns]]
    cases[rng.random(cases.shape) < 0.3] = -1
    weights = rng.random((12, net.cardinality(soft_var))) + 0.05
    fixed = net.posterior_batch_fixed(
        target, cases, "Q16.16", columns=columns, soft={soft_var: weights}
    )
    for i in range(12):
        engine = gum.LazyPropagation(g)
        hard = {c: net.states(c)[s] for c, s in zip(columns, cases[i], strict=True) if s >= 0}
        engine.setEvidence({**hard, soft_var: weights[i].tolist()})
        engine.makeInference()
        theirs = engine.posterior(target).toarray()
        assert np.all(np.abs(fixed.values[i] - theirs) <= fixed.bound[i] + 1e-9)


def test_bad_soft_evidence_is_a_one_line_input_error() -> None:
    net = random_net(3, n_vars=3, max_card=2)
    x = net.variables[0]
    for bad in ([0.1], [np.nan, 1.0], [-1.0, 2.0], [0.0, 0.0], {"s0": 1.0}):
        with pytest.raises(InputError, match=f"soft evidence on '{x}'"):
            net.posterior(net.variables[1], soft={x: bad})
    with pytest.raises(InputError, match="both an observed state and soft evidence"):
        net.posterior(net.variables[1], {x: "s0"}, soft={x: [0.5, 0.5]})
    with pytest.raises(InputError, match="case 1"):
        net.posterior_batch(
            net.variables[1], np.full((2, 1), -1), columns=[x], soft={x: [[1, 1], [0, 0]]}
        )
    with pytest.raises(InputError, match="case 1"):
        net.posterior_batch_fixed(
            net.variables[1], np.full((2, 1), -1), columns=[x], soft={x: [[1, 1], [0, 0]]}
        )
    with pytest.raises(InputError, match="both an observed state and soft evidence"):
        net.posterior_batch_fixed(
            net.variables[1], np.array([[-1], [0]]), columns=[x], soft={x: [[1, 1], [1, 2]]}
        )


def test_brute_force_helper_agrees_without_soft_evidence() -> None:
    net = random_net(5, n_vars=5)
    np.testing.assert_allclose(
        brute_soft(net, ["X1", "X3"], {"X0": "s0"}, {}),
        brute_posterior(net, ["X1", "X3"], {"X0": "s0"}),
        atol=1e-14,
    )
