"""Batch posteriors on a LocalCluster equal the single-machine batch, row for row."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from bayesmap import bn
from bayesmap.errors import InputError
from bayesmap.sweeps.batch import cases_to_indices, posterior_batch


def _net():
    net = bn.BayesNet("sprinkler")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    # CPTs are laid out (child, *parents)
    net.add_variable("Sprinkler", ["off", "on"], parents=["Rain"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    net.add_variable(
        "Wet",
        ["dry", "wet"],
        parents=["Rain", "Sprinkler"],
        cpt=[[[1.0, 0.1], [0.2, 0.01]], [[0.0, 0.9], [0.8, 0.99]]],
    )
    return net


def _cases(n, rng):
    sprinkler = rng.choice(["off", "on", None], size=n)
    wet = rng.choice(["dry", "wet", None], size=n)
    return pd.DataFrame({"Sprinkler": sprinkler, "Wet": wet}, index=[f"case{i}" for i in range(n)])


def test_cases_become_indices_and_bad_ones_are_named():
    net = _net()
    cases = pd.DataFrame({"Wet": ["wet", None], "Sprinkler": [None, "on"]})
    assert cases_to_indices(net, cases).tolist() == [[1, -1], [-1, 1]]
    with pytest.raises(InputError, match="row 1, column 'Wet'.*'soaked'"):
        cases_to_indices(net, pd.DataFrame({"Wet": ["wet", "soaked"]}))
    with pytest.raises(InputError, match="'Mud' is not a variable"):
        cases_to_indices(net, pd.DataFrame({"Mud": ["x"]}))


@pytest.mark.slow
def test_a_local_cluster_gives_the_single_machine_answer():
    net = _net()
    cases = _cases(500, np.random.default_rng(4))
    got = posterior_batch(net, "Rain", cases, workers=2, partitions=7)
    expected = net.posterior_batch("Rain", cases_to_indices(net, cases), columns=list(cases))
    assert list(got.index) == list(cases.index)
    assert list(got.columns) == ["P(Rain=no)", "P(Rain=yes)"]
    np.testing.assert_array_equal(got.to_numpy(), expected)
