"""The discretised Gaussian form (§3.1 step 3) and naive-Bayes ratio (eq. 6)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap.bn import BayesNet, class_ratio, discretised_gaussian, gaussian_cpt
from bayesmap.errors import ConfigError


@settings(max_examples=100, deadline=None)
@given(
    mean=st.floats(-10, 10),
    sigma=st.floats(0.01, 5),
    edges=st.lists(st.floats(-8, 8), min_size=2, max_size=8, unique=True),
)
def test_bins_sum_to_one_and_match_the_cdf(mean: float, sigma: float, edges: list[float]) -> None:
    e = np.sort(edges)
    if np.any(np.diff(e) <= 1e-9):
        return
    p = discretised_gaussian(mean, sigma, e)
    assert p.sum() == pytest.approx(1.0, abs=1e-12) and np.all(p >= 0)
    cdf = [0.5 * (1 + math.erf((x - mean) / (sigma * math.sqrt(2)))) for x in e[1:-1]]
    np.testing.assert_allclose(np.cumsum(p)[:-1], cdf, atol=1e-12)


def test_gaussian_cpt_builds_a_valid_sensor_model() -> None:
    edges = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    table = gaussian_cpt([0.25, 0.75, 1.25, 1.75], 0.2, edges)
    assert table.shape == (4, 4)
    assert np.argmax(table, axis=0).tolist() == [0, 1, 2, 3]
    net = BayesNet("ranger")
    net.add_variable("Distance", ["d0", "d1", "d2", "d3"])
    net.add_variable("Reading", ["r0", "r1", "r2", "r3"], parents=["Distance"], cpt=table)
    posterior = net.posterior("Distance", {"Reading": "r2"})
    assert max(posterior, key=posterior.__getitem__) == "d2"


@pytest.mark.parametrize(("sigma", "edges"), [(0.0, [0, 1]), (1.0, [1.0]), (1.0, [1, 0])])
def test_bad_forms_raise_config_error(sigma: float, edges: list[float]) -> None:
    with pytest.raises(ConfigError):
        discretised_gaussian(0.0, sigma, edges)


def test_class_ratio_eq_6_equals_inference_on_a_naive_bayes_net() -> None:
    rng = np.random.default_rng(4)
    net = BayesNet("naive")
    prior = rng.dirichlet(np.ones(3))
    net.add_variable("Y", ["y0", "y1", "y2"], cpt=prior)
    rows = []
    evidence = {}
    for m in range(4):
        table = rng.dirichlet(np.ones(2), size=3).T
        net.add_variable(f"X{m}", ["a", "b"], parents=["Y"], cpt=table)
        evidence[f"X{m}"] = "ab"[m % 2]
        rows.append(table[m % 2])
    expected = class_ratio(prior, rows, 0, 2)
    assert net.class_ratio("Y", "y0", "y2", evidence) == pytest.approx(expected)
