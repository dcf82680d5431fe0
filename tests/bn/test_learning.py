"""Parameter learning: pgmpy's and pyAgrum's estimators, EM by brute force, recovery, updates."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from tests.bn.helpers import joint, random_net

import bayesmap.bn as bn
from bayesmap.bn import BayesNet
from bayesmap.errors import ConfigError, InputError

pgmpy = pytest.importorskip("pgmpy")
gum = pytest.importorskip("pyagrum")
MODELS = Path(pgmpy.__file__).parent / "utils" / "example_models"


def blank_copy(net: BayesNet) -> BayesNet:
    """The same structure with uniform CPTs."""
    other = BayesNet(net.name)
    for name in net.topological_order():
        other.add_variable(name, net.states(name), parents=net.parents(name))
    return other.copy()


def as_frame(net: BayesNet, draws: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame(
        {
            name: np.array(net.states(name), dtype=object)[draws[:, j]]
            for j, name in enumerate(net.variables)
        }
    )


def pgmpy_cpts(net: BayesNet, frame: pd.DataFrame, **bayes: object) -> dict[str, np.ndarray]:
    from pgmpy.estimators import BayesianEstimator, MaximumLikelihoodEstimator
    from pgmpy.models import DiscreteBayesianNetwork

    model = DiscreteBayesianNetwork(net.edges())
    model.add_nodes_from(net.variables)
    states = {name: list(net.states(name)) for name in net.variables}
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if bayes:
            estimator = BayesianEstimator(model, frame, state_names=states)
        else:
            estimator = MaximumLikelihoodEstimator(model, frame, state_names=states)
        for name in net.variables:
            cpd = estimator.estimate_cpd(name, **bayes) if bayes else estimator.estimate_cpd(name)
            order = [cpd.variable, *net.parents(name)]
            values = cpd.values  # axes: variable, then cpd.variables[1:]
            out[name] = np.transpose(values, [cpd.variables.index(v) for v in order])
    return out


@pytest.mark.parametrize("name", ["asia", "alarm"])
def test_maximum_likelihood_and_bdeu_match_pgmpy(name: str) -> None:
    truth = bn.read(MODELS / f"{name}.bif.gz")
    frame = as_frame(truth, truth.sample(3000, rng=1))
    ml = blank_copy(truth)
    report = ml.fit(frame)
    assert report.iterations == 0 and report.cases == 3000
    for var, cpt in pgmpy_cpts(truth, frame).items():
        np.testing.assert_allclose(ml.cpt(var), cpt, atol=1e-12, err_msg=var)
    bdeu = blank_copy(truth)
    bdeu.fit(frame, prior="bdeu", equivalent_sample_size=10.0)
    expected = pgmpy_cpts(truth, frame, prior_type="BDeu", equivalent_sample_size=10)
    for var, cpt in expected.items():
        np.testing.assert_allclose(bdeu.cpt(var), cpt, atol=1e-12, err_msg=var)


def pyagrum_cpt(g: object, net: BayesNet, name: str) -> np.ndarray:
    """A pyAgrum CPT in our ``(child, *parents)`` layout, read one parent column at a time."""
    table = np.empty(net.cpt(name).shape)
    for index in np.ndindex(*table.shape[1:]):
        where = {p: int(i) for p, i in zip(net.parents(name), index, strict=True)}
        table[(slice(None), *index)] = g.cpt(name)[where]  # type: ignore[attr-defined]
    return table


@pytest.mark.parametrize("smoothing", [0.0, 0.5])
def test_maximum_likelihood_and_smoothing_match_pyagrum(tmp_path: Path, smoothing: float) -> None:
    truth = bn.read(MODELS / "child.bif.gz")
    frame = as_frame(truth, truth.sample(2000, rng=2))
    # pyAgrum reads labels as written; child's have '/' in them, so number the states
    coded = pd.DataFrame({c: frame[c].map(truth.states(c).index).astype(str) for c in frame})
    path = tmp_path / "child.csv"
    coded.to_csv(path, index=False)
    template = gum.BayesNet("child")
    for name in truth.topological_order():
        labels = [str(k) for k in range(truth.cardinality(name))]
        template.add(gum.LabelizedVariable(name, name, labels))
    for parent, child in truth.edges():
        template.addArc(parent, child)
    learner = gum.BNLearner(str(path), template)
    if smoothing:
        learner.useSmoothingPrior(smoothing)
    else:
        learner.useNoPrior()
    learned = learner.learnParameters(template.dag())
    ours = blank_copy(truth)
    if smoothing:
        # a smoothing prior adds the same count to every cell: ours is BDeu, per variable
        # S = smoothing * r * q; learn one family at a time with its own S
        for name in truth.variables:
            one = blank_copy(truth)
            one.fit(frame, prior="bdeu", equivalent_sample_size=smoothing * truth.cpt(name).size)
            ours.set_cpt(name, one.cpt(name))
    else:
        ours.fit(coded.astype(int))
    for name in truth.variables:
        np.testing.assert_allclose(
            ours.cpt(name), pyagrum_cpt(learned, truth, name), atol=1e-9, err_msg=name
        )


def brute_em(net: BayesNet, cases: np.ndarray, iterations: int) -> BayesNet:
    """EM by enumerating the full joint for every case (−1 = missing)."""
    net = net.copy()
    names = list(net.variables)
    for _ in range(iterations):
        table = joint(net)
        expected = np.zeros(table.shape)
        for case in cases:
            index = tuple(slice(None) if s < 0 else int(s) for s in case)
            part = np.zeros(table.shape)
            part[index] = table[index]
            expected += part / part.sum()
        for name in names:
            family = [names.index(x) for x in (name, *net.parents(name))]
            others = tuple(k for k in range(len(names)) if k not in family)
            members = sorted(family)
            counts = expected.sum(axis=others).transpose([members.index(m) for m in family])
            sums = counts.sum(axis=0, keepdims=True)
            safe = np.where(sums > 0, sums, 1.0)
            net.set_cpt(name, np.where(sums > 0, counts / safe, net.cpt(name)))
    return net


@pytest.mark.parametrize("seed", range(5))
def test_em_iterations_match_brute_force_em(seed: int) -> None:
    truth = random_net(seed, n_vars=5, max_card=3)
    rng = np.random.default_rng(seed)
    cases = truth.sample(60, rng=rng)
    cases[rng.random(cases.shape) < 0.3] = -1
    start = truth.copy()
    for name in start.variables:  # a perturbed start, so that EM has work to do
        noisy = start.cpt(name) + rng.random(start.cpt(name).shape)
        start.set_cpt(name, noisy / noisy.sum(axis=0, keepdims=True))
    for iterations in (1, 3):
        ours = start.copy()
        report = ours.fit(cases, max_iterations=iterations, tol=0.0)
        assert report.iterations == iterations and not report.converged
        expected = brute_em(start, cases, iterations)
        for name in truth.variables:
            np.testing.assert_allclose(ours.cpt(name), expected.cpt(name), atol=1e-10)


@pytest.mark.slow
def test_em_likelihood_never_decreases_and_converges() -> None:
    truth = bn.read(MODELS / "asia.bif.gz")
    rng = np.random.default_rng(3)
    frame = as_frame(truth, truth.sample(3000, rng=rng))
    frame = frame.mask(rng.random(frame.shape) < 0.2)
    history = []
    net = blank_copy(truth)
    for name in net.variables:  # a random start (uniform CPTs are a saddle point of EM)
        table = rng.random(net.cpt(name).shape) + 0.5
        net.set_cpt(name, table / table.sum(axis=0, keepdims=True))
    for _ in range(6):
        history.append(net.fit(frame, max_iterations=1, tol=0.0).log_likelihood)
    assert np.all(np.diff(history) >= -1e-9)
    report = net.fit(frame, max_iterations=500, tol=1e-9)
    assert report.converged and report.log_likelihood >= history[-1]


@pytest.mark.slow
def test_many_samples_recover_the_generating_cpts() -> None:
    truth = bn.read(MODELS / "alarm.bif.gz")
    rng = np.random.default_rng(4)
    draws = truth.sample(200_000, rng=rng)
    net = blank_copy(truth)
    net.fit(draws, columns=truth.variables)
    worst = max(np.abs(net.cpt(n) - truth.cpt(n)).max() for n in _well_sampled(truth, draws))
    assert worst < 0.02
    # with a column partly missing (at random), EM recovers it too
    some = draws[:20_000].copy()
    column = truth.variables.index("HYPOVOLEMIA")
    some[rng.random(len(some)) < 0.5, column] = -1
    em = blank_copy(truth)
    em.fit(some, columns=truth.variables, prior="bdeu", equivalent_sample_size=1.0)
    assert np.abs(em.cpt("HYPOVOLEMIA") - truth.cpt("HYPOVOLEMIA")).max() < 0.02


def _well_sampled(net: BayesNet, draws: np.ndarray) -> list[str]:
    """Variables whose every parent configuration occurs at least 2,000 times."""
    names = list(net.variables)
    kept = []
    for name in names:
        parents = [names.index(p) for p in net.parents(name)]
        cards = [net.cardinality(p) for p in net.parents(name)]
        if not parents:
            kept.append(name)
            continue
        codes = np.ravel_multi_index(tuple(draws[:, p] for p in parents), cards)
        if np.bincount(codes, minlength=int(np.prod(cards))).min() >= 2000:
            kept.append(name)
    return kept


def test_online_updates_equal_one_bayesian_fit() -> None:
    truth = random_net(11, n_vars=6, max_card=3)
    prior = truth.copy()
    rng = np.random.default_rng(11)
    for name in prior.variables:
        table = rng.random(prior.cpt(name).shape) + 0.1
        prior.set_cpt(name, table / table.sum(axis=0, keepdims=True))
    cases = truth.sample(500, rng=rng)
    batch = prior.copy()
    batch.fit(cases, prior="cpt", equivalent_sample_size=8.0)
    online = prior.copy()
    online.update(cases[:1], equivalent_sample_size=8.0)
    for k in range(1, 500, 37):
        online.update(cases[k : k + 37])
    for name in truth.variables:
        np.testing.assert_allclose(online.cpt(name), batch.cpt(name), atol=1e-12)


def test_learning_rejects_bad_input() -> None:
    net = random_net(1, n_vars=3, max_card=2)
    with pytest.raises(ConfigError, match="unknown prior"):
        net.fit(net.sample(5, rng=0), prior="laplace")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="equivalent_sample_size"):
        net.fit(net.sample(5, rng=0), prior="bdeu", equivalent_sample_size=-1.0)
    with pytest.raises(InputError, match="no cases"):
        net.fit(np.empty((0, 3), dtype=int))
    with pytest.raises(InputError, match="not a state"):
        net.fit(pd.DataFrame({"X0": ["s0", "s9"]}))
