"""Forward sampling: draws follow the joint, are reproducible, and feed posterior_batch."""

from __future__ import annotations

import numpy as np
import pytest
from tests.bn.helpers import random_net

from bayesmap.bn import BayesNet
from bayesmap.errors import InputError


@pytest.mark.parametrize("seed", range(4))
def test_sample_frequencies_match_the_joint(seed: int) -> None:
    net = random_net(seed, n_vars=4, max_card=3, zero_fraction=0.2)
    n = 40_000
    draws = net.sample(n, rng=seed)
    assert draws.shape == (n, 4) and draws.dtype == np.int64
    joint = net.joint_posterior(list(net.variables), {})
    counts = np.zeros(joint.shape)
    np.add.at(counts, tuple(draws.T), 1)
    # every cell within 5 standard deviations of its expected count; no impossible draws
    sd = np.sqrt(n * joint * (1 - joint))
    assert np.all(np.abs(counts - n * joint) <= 5 * sd + 1e-9)
    assert not counts[joint == 0].any()


def test_sample_is_reproducible_and_validates_n() -> None:
    net = random_net(1)
    np.testing.assert_array_equal(net.sample(50, rng=3), net.sample(50, rng=3))
    assert not np.array_equal(net.sample(50, rng=3), net.sample(50, rng=4))
    assert net.sample(0, rng=0).shape == (0, len(net.variables))
    for bad in (-1, 2.5, True):
        with pytest.raises(InputError, match="number of samples"):
            net.sample(bad, rng=0)


def test_samples_are_a_posterior_batch_and_data_nodes_use_their_source() -> None:
    net = BayesNet("map lookup")
    net.add_variable("Cell", ["free", "occupied"], cpt=[0.5, 0.5])
    net.add_variable("Reading", ["far", "near"], parents=["Cell"], cpt=[[0.5, 0.5], [0.5, 0.5]])
    net.set_source("Reading", lambda evidence: [[1.0, 0.0], [0.0, 1.0]])
    draws = net.sample(200, rng=0)
    cell, reading = (net.variables.index(name) for name in ("Cell", "Reading"))
    np.testing.assert_array_equal(draws[:, cell], draws[:, reading])
    posterior = net.posterior_batch("Cell", draws[:, [reading]], columns=["Reading"])
    np.testing.assert_allclose(posterior[np.arange(200), draws[:, cell]], 1.0)
