"""Every posterior at once (the two-pass scheme) against one variable at a time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.bn.helpers import random_net, sample_evidence

import bayesmap.bn as bn
from bayesmap.errors import InputError

pgmpy = pytest.importorskip("pgmpy")
MODELS = Path(pgmpy.__file__).parent / "utils" / "example_models"


@pytest.mark.parametrize("seed", range(20))
def test_random_networks_match_the_per_variable_answers(seed: int) -> None:
    rng = np.random.default_rng(seed)
    net = random_net(seed, n_vars=int(rng.integers(2, 12)), max_card=4, zero_fraction=0.1)
    evidence = sample_evidence(net, rng, int(rng.integers(0, 4)))
    answers = net.posteriors(evidence)
    assert set(answers) == set(net.variables) - set(evidence)
    for name, posterior in answers.items():
        expected = net.posterior(name, evidence)
        np.testing.assert_allclose(list(posterior.values()), list(expected.values()), atol=1e-12)


@pytest.mark.parametrize("name", ["alarm", "child", "insurance", "hailfinder", "win95pts"])
def test_bnlearn_networks_match_within_1e_9(name: str) -> None:
    net = bn.read(MODELS / f"{name}.bif.gz")
    rng = np.random.default_rng(len(name))
    for k in (0, 3, 8):
        evidence = sample_evidence(net, rng, k)
        answers = net.posteriors(evidence)
        for target in rng.choice(sorted(answers), size=8, replace=False):
            expected = net.posterior(str(target), evidence)
            got = answers[str(target)]
            np.testing.assert_allclose(list(got.values()), list(expected.values()), atol=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_batches_match_one_case_at_a_time(seed: int) -> None:
    net = random_net(30 + seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    cases = net.sample(50, rng=rng)
    cases[rng.random(cases.shape) < 0.6] = -1
    answers = net.posteriors_batch(cases)
    for i in range(len(cases)):
        evidence = {net.variables[j]: int(s) for j, s in enumerate(cases[i]) if s >= 0}
        one = net.posteriors(evidence)
        for j, name in enumerate(net.variables):
            if cases[i, j] >= 0:
                assert answers[name][i, cases[i, j]] == 1.0
            else:
                np.testing.assert_allclose(answers[name][i], list(one[name].values()), atol=1e-12)


def test_soft_and_fixed_point_forms() -> None:
    net = random_net(5, n_vars=6, max_card=3)
    soft = {"X1": [0.2, 0.9, 0.4][: net.cardinality("X1")]}
    answers = net.posteriors({"X0": "s0"}, soft=soft)
    assert set(answers) == set(net.variables) - {"X0"}
    for name, posterior in answers.items():
        expected = net.posterior(name, {"X0": "s0"}, soft=soft)
        np.testing.assert_allclose(list(posterior.values()), list(expected.values()), atol=1e-12)
    fixed = net.posteriors({"X0": "s0"}, fixed_point="Q16.16")
    for name, posterior in fixed.items():
        exact = net.posterior(name, {"X0": "s0"})
        assert max(abs(posterior[s] - exact[s]) for s in exact) < 1e-3


def test_impossible_evidence_is_an_input_error() -> None:
    net = bn.BayesNet("zero")
    net.add_variable("A", ["a", "b"], cpt=[1.0, 0.0])
    net.add_variable("B", ["x", "y"], parents=["A"], cpt=[[1.0, 0.5], [0.0, 0.5]])
    with pytest.raises(InputError, match="probability zero"):
        net.posteriors({"B": "y"})
    with pytest.raises(InputError, match="case 1"):
        net.posteriors_batch(np.array([[-1, 0], [-1, 1]]))


@pytest.mark.parametrize("seed", range(4))
def test_many_blank_patterns_share_one_indicator_contraction(seed: int) -> None:
    net = random_net(60 + seed, n_vars=10, max_card=3, max_parents=2)
    rng = np.random.default_rng(seed)
    cases = net.sample(400, rng=rng)
    cases[rng.random(cases.shape) < 0.5] = -1
    patterns = {tuple(row >= 0) for row in cases}
    assert len(patterns) > 64  # the indicator path is the one under test
    targets = [net.variables[0], net.variables[4], net.variables[-1]]
    many = net.posteriors_batch(cases, targets=targets)
    single = net.posterior_batch(targets[1], cases)
    np.testing.assert_allclose(single, many[targets[1]], atol=1e-12)
    for i in range(0, 400, 7):
        evidence = {net.variables[j]: int(s) for j, s in enumerate(cases[i]) if s >= 0}
        for t in targets:
            expected = list(net.posterior(t, evidence).values())
            np.testing.assert_allclose(many[t][i], expected, atol=1e-12)


def test_indicator_contraction_names_an_impossible_case() -> None:
    net = bn.BayesNet("zero")
    net.add_variable("A", ["a", "b"], cpt=[1.0, 0.0])
    net.add_variable("B", ["x", "y"], parents=["A"], cpt=[[1.0, 0.5], [0.0, 0.5]])
    for k in range(8):
        net.add_variable(f"C{k}", ["u", "v"], parents=["A"], cpt=[[0.3, 0.6], [0.7, 0.4]])
    rng = np.random.default_rng(0)
    cases = rng.integers(-1, 2, size=(300, len(net)))
    cases[:, 0] = -1
    cases[:, 1] = np.where(np.arange(300) == 250, 1, -1)
    with pytest.raises(InputError, match="case 250"):
        net.posterior_batch("A", cases)
