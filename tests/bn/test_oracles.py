"""Posteriors and MAP against pyAgrum (LazyPropagation) on pgmpy's shipped bnlearn models.

Each network is read with our BIF reader; pyAgrum reads the same file itself, except where
it cannot (child.bif has state names with '/'), where it gets a copy built from ours.
Evidence is drawn by forward sampling, so it has nonzero probability.
"""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest
from tests.bn.helpers import sample_evidence
from tests.bn.peers import to_pyagrum

import bayesmap.bn as bn
from bayesmap.bn import BayesNet

gum = pytest.importorskip("pyagrum")
pgmpy = pytest.importorskip("pgmpy")

MODELS = Path(pgmpy.__file__).parent / "utils" / "example_models"
SMALL = ["asia", "cancer", "earthquake", "survey", "sachs", "alarm", "child", "insurance"]
MEDIUM = ["water", "hailfinder", "hepar2", "win95pts", "pathfinder", "andes"]
LARGE = [
    "mildew",
    "barley",
    "diabetes",
    "pigs",
    "link",
    "munin1",
    "munin2",
    "munin3",
    "munin4",
    "munin",
]


def load_both(name: str, tmp_path: Path) -> tuple[BayesNet, gum.BayesNet]:
    path = MODELS / f"{name}.bif.gz"
    net = bn.read(path)
    plain = tmp_path / f"{name}.bif"
    plain.write_bytes(gzip.decompress(path.read_bytes()))
    try:
        g = gum.loadBN(str(plain))
    except gum.GumException:  # pyAgrum cannot read this file (e.g. '/' in state names)
        g = to_pyagrum(net)
    return net, g


def check_posteriors(name: str, tmp_path: Path, n_cases: int) -> None:
    net, g = load_both(name, tmp_path)
    rng = np.random.default_rng(len(name))
    for _ in range(n_cases):
        evidence = sample_evidence(net, rng, 3)
        free = [v for v in net.variables if v not in evidence]
        targets = [str(t) for t in rng.choice(free, size=min(3, len(free)), replace=False)]
        engine = gum.LazyPropagation(g)
        engine.setEvidence(evidence)
        for t in targets:
            engine.addTarget(t)
        engine.makeInference()
        for t in targets:
            theirs = engine.posterior(t).toarray()
            labels = list(g.variable(t).labels())
            theirs = theirs[[labels.index(s) for s in net.states(t)]]
            ours = np.array(list(net.posterior(t, evidence).values()))
            assert np.max(np.abs(ours - theirs)) <= 1e-6, (name, t, evidence)
        joint = net.joint_posterior(targets[:2], evidence)
        assert joint.sum() == pytest.approx(1.0)
        np.testing.assert_allclose(
            joint.sum(axis=1), list(net.posterior(targets[0], evidence).values())
        )


@pytest.mark.parametrize("name", SMALL + MEDIUM)
def test_posteriors_agree_with_pyagrum(name: str, tmp_path: Path) -> None:
    check_posteriors(name, tmp_path, n_cases=3)


@pytest.mark.slow
@pytest.mark.parametrize("name", LARGE)
def test_posteriors_agree_with_pyagrum_on_large_networks(name: str, tmp_path: Path) -> None:
    check_posteriors(name, tmp_path, n_cases=2)


def log_joint(net: BayesNet, assignment: dict[str, str]) -> float:
    total = 0.0
    for name in net.variables:
        index = tuple(net.states(v).index(assignment[v]) for v in (name, *net.parents(name)))
        total += math.log(net.cpt(name)[index]) if net.cpt(name)[index] > 0 else -math.inf
    return total


@pytest.mark.parametrize("name", ["asia", "cancer", "earthquake", "survey", "sachs"])
def test_map_agrees_with_pyagrum(name: str, tmp_path: Path) -> None:
    net, g = load_both(name, tmp_path)
    rng = np.random.default_rng(3)
    for _ in range(3):
        evidence = sample_evidence(net, rng, 2)
        engine = gum.LazyPropagation(g)
        engine.setEvidence(evidence)
        best = engine.mpe()
        theirs = {
            best.variable(i).name(): best.variable(i).label(best.val(i))
            for i in range(best.nbrDim())
        }
        ours, probability = net.map(evidence)
        full = {**evidence, **ours}
        assert log_joint(net, full) == pytest.approx(
            log_joint(net, {**theirs, **evidence}), abs=1e-9
        )
        expected = math.exp(log_joint(net, full)) / net.probability_of_evidence(evidence)
        assert probability == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("name", ["alarm", "child", "insurance", "hailfinder", "win95pts", "andes"])
def test_map_is_a_joint_optimum_on_larger_networks(name: str) -> None:
    """Oracle-free checks beside tests/bn/test_map_oracles.py (pgmpy max-product): the
    returned probability is the assignment's, and no single change improves it."""
    net = bn.read(MODELS / f"{name}.bif.gz")
    rng = np.random.default_rng(5)
    evidence = sample_evidence(net, rng, 3)
    ours, probability = net.map(evidence)
    full = {**evidence, **ours}
    best = log_joint(net, full)
    expected = math.exp(best) / net.probability_of_evidence(evidence)
    assert probability == pytest.approx(expected, rel=1e-9)
    for name_ in ours:
        for state in net.states(name_):
            assert log_joint(net, {**full, name_: state}) <= best + 1e-9
