"""The engine's tuning changes how a question is answered, never the answer."""

from __future__ import annotations

import numpy as np
import pytest
from tests.bn.helpers import random_net, sample_evidence

from bayesmap.bn import BayesNet
from bayesmap.bn.tuning import TUNING, Tuning

FORCED = Tuning(
    batch_class=1,
    many_patterns=0,
    max_lookup=0,
    joint_above=-1,
    call_cost=0,
    calls_per_question=0,
    one_step=0,
    one_step_operands=0,
    greedy_above=-1,
    greedy_per_factor=-1,
    search_above=-1.0,
    search_repeats=2,
    split_above=-1,
    blas_above=-1,
    two_pass_blas_above=-1,
)
"""Thresholds that send questions down rarely taken branches: indicator batches, no answer
memo, the two-pass contraction always, no one-step shortcut, greedy re-ordering, random-greedy
search, pairwise and BLAS steps (the joint fill of a batch memo: test_cold_path.py)."""


def test_a_network_keeps_its_tuning_and_a_new_one_drops_the_caches() -> None:
    net = BayesNet("rain", tuning=FORCED)
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    assert net.tuning is FORCED
    assert net.copy().tuning is FORCED
    engine = net._engine
    net.tuning = TUNING
    assert net.tuning is TUNING and net._engine is not engine
    assert net.posterior("Rain", {"Wet": "yes"})["yes"] == pytest.approx(0.18 / 0.26)


@pytest.mark.parametrize("seed", range(8))
def test_forced_branches_give_the_default_answers(seed: int) -> None:
    net = random_net(seed, n_vars=8, max_card=3)
    forced = net.copy()
    forced.tuning = FORCED
    rng = np.random.default_rng(seed)
    names = list(net.variables)
    for _ in range(3):
        evidence = sample_evidence(net, rng, 2)
        for target in names:
            np.testing.assert_allclose(
                list(forced.posterior(target, evidence).values()),
                list(net.posterior(target, evidence).values()),
                rtol=1e-12,
                atol=1e-15,
            )
        every = forced.posteriors(evidence)
        for v, p in net.posteriors(evidence).items():
            np.testing.assert_allclose(list(every[v].values()), list(p.values()), atol=1e-12)
        assert forced.map(evidence)[0] == net.map(evidence)[0]
        fixed = forced.posterior_fixed(names[-1], evidence)
        default = net.posterior_fixed(names[-1], evidence)
        assert np.all(np.abs(fixed.values - default.values) <= fixed.bound + default.bound)
    cases = net.sample(60, rng=rng)
    cases[rng.random(cases.shape) < 0.5] = -1
    for target in names[:3]:
        np.testing.assert_allclose(
            forced.posterior_batch(target, cases), net.posterior_batch(target, cases), atol=1e-12
        )
    every_batch = forced.posteriors_batch(cases)
    for v, p in net.posteriors_batch(cases).items():
        np.testing.assert_allclose(every_batch[v], p, atol=1e-12)
