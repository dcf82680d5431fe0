"""Tests of the IR ranger models (Post et al. 2016 eqs. 31–34, §5.1 transfer function)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bayesmap.sensing.ir import (
    angular_weight,
    beta_r,
    contact,
    range_from_raw,
    raw_from_range,
    sensor_posterior,
)


def test_beta_r_endpoints_and_shape() -> None:
    r = np.linspace(0.0, 2.0, 21)
    b = beta_r(r, r_max=2.0, beta_b=0.2)
    assert b[0] == 1.0 and b[-1] == pytest.approx(0.2)
    assert np.all(np.diff(b) <= 0)
    assert beta_r(3.0, beta_b=0.2) == 0.2
    # (1 - beta_b)(r_max^2 - R^2)^2 / r_max^4 at R = 1: 0.8 * 9 / 16
    assert float(beta_r(1.0, r_max=2.0, beta_b=0.2)) == pytest.approx(0.2 + 0.8 * 9 / 16)


@given(st.floats(0.0, 1.0), st.floats(0.01, 0.99), st.integers(0, 1))
def test_sensor_posterior_is_bayes_rule(beta: float, prior: float, o: int) -> None:
    # P(r | R) = beta if the reading agrees with R, 1 - beta otherwise
    like_obj = beta if o == 1 else 1.0 - beta
    like_free = 1.0 - beta if o == 1 else beta
    expected = like_obj * prior / (like_obj * prior + like_free * (1.0 - prior))
    assert float(sensor_posterior(beta, prior, o)) == pytest.approx(expected, abs=1e-12)


def test_sensor_posterior_with_beta_half_is_prior() -> None:
    assert np.allclose(sensor_posterior(0.5, [0.1, 0.2, 0.7], [0, 1, 1]), [0.1, 0.2, 0.7])


def test_contact_needs_two_samples_above_two_sigma() -> None:
    sigma = 2.777
    assert contact([5.6, 5.6], [5.6, 5.5], sigma_r=sigma).tolist() == [True, False]
    assert contact([5.5], [100.0], sigma_r=sigma).tolist() == [False]


@given(st.floats(0.15, 4.0))
def test_transfer_function_round_trip(r: float) -> None:
    assert float(range_from_raw(raw_from_range(r))) == pytest.approx(r, rel=1e-9)


def test_transfer_function_values_from_the_paper() -> None:
    # r_raw = (-7.933 r + 56.61) / (r + 0.07544)
    assert float(raw_from_range(2.0)) == pytest.approx((-15.866 + 56.61) / 2.07544)
    assert float(raw_from_range(np.inf)) == pytest.approx(-7.933)
    assert float(range_from_raw(0.0)) == pytest.approx(0.08 * 707625 / 7933)


def test_angular_weight_is_gaussian_of_width_w_r() -> None:
    w = 0.3
    a = angular_weight(np.array([0.0, w, -w]), w)
    assert a[0] == pytest.approx(1.0 / (w**2 * np.sqrt(2 * np.pi)))
    assert a[1] == pytest.approx(a[0] * np.exp(-1.0)) and a[1] == a[2]
