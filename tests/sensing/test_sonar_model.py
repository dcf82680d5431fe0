"""Tests of the sonar models: eq. 1, the Elfes-style cone model and the two baselines."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from bayesmap.errors import ConfigError
from bayesmap.sensing.sonar import angular_weight, elfes_inverse_model, log_odds, reading_likelihood
from bayesmap.sensing.sonar_baselines import ros_bayes_update, ros_sensor_model, thrun_inverse_model

BEAM = math.radians(25.0)


def test_eq1_is_a_normalised_gaussian() -> None:
    total, _ = integrate.quad(lambda d: float(reading_likelihood(d, 0.03)), -1.0, 1.0)
    assert total == pytest.approx(1.0, abs=1e-9)
    assert float(reading_likelihood(0.0, 0.03)) == pytest.approx(
        1.0 / math.sqrt(2 * math.pi * 0.03**2)
    )
    assert float(reading_likelihood(0.06, 0.03)) == pytest.approx(
        float(reading_likelihood(0.0, 0.03)) * math.exp(-2.0)
    )


def test_eq1_rejects_a_non_positive_sigma() -> None:
    with pytest.raises(ConfigError):
        reading_likelihood(0.0, 0.0)


def test_angular_weight_is_one_on_axis_and_zero_at_and_beyond_the_edge() -> None:
    w = angular_weight(np.array([0.0, BEAM / 4, BEAM / 2, BEAM]), BEAM)
    assert w.tolist() == pytest.approx([1.0, 0.75, 0.0, 0.0])


def test_elfes_cone_free_before_occupied_at_unknown_after_and_outside() -> None:
    rho = np.array([0.5, 1.0, 1.95, 2.0, 2.05, 2.5])
    p = elfes_inverse_model(2.0, rho, 0.0, sigma=0.05, beam_width=BEAM, max_range=5.0)
    assert p[0] == pytest.approx(0.35) and p[1] == pytest.approx(0.35)
    assert p[3] == pytest.approx(0.7)
    assert p[2] > 0.5 and p[4] > 0.5
    assert p[5] == 0.5
    off = elfes_inverse_model(2.0, rho, BEAM, sigma=0.05, beam_width=BEAM, max_range=5.0)
    assert np.all(off == 0.5)


def test_a_one_sided_arc_frees_the_cells_in_front_of_the_echo_and_keeps_the_back() -> None:
    rho = np.array([1.5, 1.85, 1.9, 1.95, 2.0, 2.1, 2.2])
    kw = {"sigma": 0.1, "beam_width": BEAM, "max_range": 5.0}
    both = elfes_inverse_model(2.0, rho, 0.0, **kw)
    front = elfes_inverse_model(2.0, rho, 0.0, sigma_front=0.03, front_flat=0.05, **kw)
    # The symmetric arc marks the cell 0.1 m in front of the echo occupied; the echo is the
    # first return, so the one-sided arc frees it and keeps the peak over half a cell.
    assert both[2] > 0.5 > front[2] and front[1] < both[1]
    assert front[3] == pytest.approx(0.7) and front[4] == pytest.approx(0.7)
    assert np.array_equal(front[4:], both[4:]) and front[0] == pytest.approx(both[0], abs=1e-4)
    # Without sigma_front, front_flat is unused: eq. 1's Gaussian on both sides, bit for bit.
    assert np.array_equal(elfes_inverse_model(2.0, rho, 0.0, front_flat=0.05, **kw), both)
    for bad in ({"sigma_front": 0.0}, {"sigma_front": 0.03, "front_flat": -0.01}):
        with pytest.raises(ConfigError, match="sigma_front"):
            elfes_inverse_model(2.0, rho, 0.0, **bad, **kw)  # type: ignore[arg-type]


def test_elfes_no_echo_clears_up_to_max_range_without_an_arc() -> None:
    rho = np.linspace(0.1, 6.0, 60)
    p = elfes_inverse_model(5.0, rho, 0.0, sigma=0.05, beam_width=BEAM, max_range=5.0)
    assert np.all(p[rho < 5.0] < 0.5)
    assert np.all(p[rho > 5.0] == 0.5)


def test_elfes_probabilities_stay_inside_their_bounds() -> None:
    rng = np.random.default_rng(0)
    r = rng.uniform(0.1, 6.0, 500)
    rho = rng.uniform(0.0, 6.0, 500)
    theta = rng.uniform(-1, 1, 500)
    p = elfes_inverse_model(
        r, rho, theta, sigma=0.05, beam_width=BEAM, max_range=5.0, p_occ=0.8, p_free=0.3
    )
    assert np.all((p >= 0.3 - 1e-12) & (p <= 0.8 + 1e-12))
    assert np.all(np.isfinite(log_odds(p)))


def test_thrun_table_9_2_cases() -> None:
    kw = {"z_max": 5.0, "alpha": 0.2, "beta": BEAM}
    assert float(thrun_inverse_model(2.0, 1.0, 0.0, **kw)) == -0.4
    assert float(thrun_inverse_model(2.0, 2.05, 0.0, **kw)) == 0.4
    assert float(thrun_inverse_model(2.0, 2.2, 0.0, **kw)) == 0.0
    assert float(thrun_inverse_model(2.0, 1.0, BEAM, **kw)) == 0.0
    # A max-range reading clears but never marks.
    assert float(thrun_inverse_model(5.0, 4.95, 0.0, **kw)) == -0.4
    assert float(thrun_inverse_model(5.0, 5.05, 0.0, **kw)) == 0.0


def test_ros_sensor_model_matches_the_layer_formulae() -> None:
    res, max_angle = 0.05, BEAM / 2
    r, phi, theta = 1.0, 0.5, 0.0
    lam = (1 - (1 + math.tanh(2 * (phi - 1.2))) / 2) * 1.0
    assert float(
        ros_sensor_model(r, phi, theta, max_angle=max_angle, resolution=res)
    ) == pytest.approx((1 - lam) * 0.5)
    lam_r = 1 - (1 + math.tanh(2 * (r - 1.2))) / 2
    assert float(
        ros_sensor_model(r, r, theta, max_angle=max_angle, resolution=res)
    ) == pytest.approx(lam_r * 0.5 + 0.5)
    assert float(ros_sensor_model(r, 1.2, theta, max_angle=max_angle, resolution=res)) == 0.5
    assert (
        float(ros_sensor_model(r, 0.5, max_angle * 1.01, max_angle=max_angle, resolution=res))
        == 0.5
    )


def test_ros_bayes_update_quantises_like_the_layer() -> None:
    assert float(ros_bayes_update(127 / 254, 0.5)) == pytest.approx(127 / 254)
    p = float(ros_bayes_update(0.5, 0.9))
    assert p == math.floor(0.9 * 254) / 254
    assert float(ros_bayes_update(0.5, 0.0)) == 0.0
    assert float(ros_bayes_update(0.0, 0.99)) == 0.0
