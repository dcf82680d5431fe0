"""Q-format fixed-point inference: parsing, block floating point, honesty and tightness of the
error bound, determinism."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.bn.helpers import brute_map, brute_posterior, random_net, sample_evidence

from bayesmap.bn import BayesNet, QFormat
from bayesmap.bn.fixed_point import FixedAlgebra
from bayesmap.errors import ConfigError

SEEDS = st.integers(0, 2**31 - 1)
FORMATS = st.sampled_from(["Q16.16", "Q8.24", "Q12.12", "Q2.30", "Q1.15"])


@pytest.mark.parametrize(
    ("text", "bits"), [("Q16.16", (16, 16)), ("q8.24", (8, 24)), ("Q1.31", (1, 31))]
)
def test_parse_q_formats(text: str, bits: tuple[int, int]) -> None:
    q = QFormat.parse(text)
    assert (q.int_bits, q.frac_bits) == bits
    assert str(q) == text.upper()


@pytest.mark.parametrize("text", ["Q16", "16.16", "Q20.20", "Q0.16", "Qx.y"])
def test_bad_q_formats_raise_config_error(text: str) -> None:
    with pytest.raises(ConfigError):
        QFormat.parse(text)


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS, n_evidence=st.integers(0, 3), q=FORMATS)
def test_fixed_point_posterior_is_within_its_bound(seed: int, n_evidence: int, q: str) -> None:
    net = random_net(seed, n_vars=6, zero_fraction=0.1)
    evidence = sample_evidence(net, np.random.default_rng(seed), n_evidence)
    for target in net.variables:
        exact = brute_posterior(net, [target], evidence)
        result = net.posterior_fixed(target, evidence, q)
        assert np.all(np.abs(result.values - exact) <= result.bound)
        assert result.raw.dtype == np.int64
        assert np.array_equal(result.values, result.raw / QFormat.parse(q).scale)


@settings(max_examples=30, deadline=None)
@given(seed=SEEDS, n_cases=st.integers(1, 6))
def test_fixed_point_batch_equals_looped(seed: int, n_cases: int) -> None:
    net = random_net(seed, n_vars=5)
    rng = np.random.default_rng(seed)
    cases = [sample_evidence(net, rng, 2) for _ in range(n_cases)]
    batch = net.posterior_batch_fixed("X4", cases, "Q16.16")
    for i, case in enumerate(cases):
        one = net.posterior_fixed("X4", case, "Q16.16")
        exact = brute_posterior(net, ["X4"], case)
        assert np.all(np.abs(batch.values[i] - exact) <= batch.bound[i])
        gap = np.max(np.abs(batch.values[i] - one.values))
        assert gap <= batch.bound[i].max() + one.bound.max()


def test_bound_is_tight_on_random_networks() -> None:
    """The bound, scaled by P(e), stays within a few resolutions (it was up to 15 before
    block floating point) and the error stays near the CPT quantisation."""
    q = QFormat.parse("Q16.16")
    scaled, errors = [], []
    for seed in range(40):
        net = random_net(seed, n_vars=6)
        evidence = sample_evidence(net, np.random.default_rng(seed), 2)
        p_e = net.probability_of_evidence(evidence)
        for target in net.variables:
            result = net.posterior_fixed(target, evidence, q)
            exact = brute_posterior(net, [target], evidence)
            scaled.append(result.bound.max() * p_e / q.resolution)
            errors.append(np.max(np.abs(result.values - exact)) * p_e / q.resolution)
    assert max(scaled) < 4.0
    assert max(errors) < 1.5
    finer = [
        net.posterior_fixed(t, {}, "Q8.24").bound.max()
        for net in (random_net(s, n_vars=6) for s in range(5))
        for t in net.variables
    ]
    assert max(finer) < 4.0 * QFormat.parse("Q8.24").resolution


def test_long_products_keep_their_precision() -> None:
    """120 weak, independent observations: P(e) ≈ 1e-53, far below Q16.16's resolution.

    Fixed-scale Q16.16 arithmetic rounds such products to zero; block floating point keeps
    every intermediate factor at full mantissa precision, so the posterior stays accurate.
    """
    net = BayesNet("many sensors")
    prior = np.array([0.7, 0.3])
    net.add_variable("Obstacle", ["no", "yes"], cpt=prior)
    rng = np.random.default_rng(4)
    evidence = {}
    log_joint = np.log(prior)
    for i in range(120):
        hit = float(rng.uniform(0.2, 0.3))
        cpt = np.array([[1 - hit, 0.8], [hit, 0.2]])
        net.add_variable(f"S{i}", ["quiet", "echo"], parents=["Obstacle"], cpt=cpt)
        evidence[f"S{i}"] = "echo" if i % 3 else "quiet"
        log_joint += np.log(cpt[int(i % 3 != 0)])
    assert np.logaddexp.reduce(log_joint) < np.log(1e-50)
    exact = np.exp(log_joint - np.logaddexp.reduce(log_joint))
    result = net.posterior_fixed("Obstacle", evidence, "Q16.16")
    error = np.abs(result.values - exact)
    assert np.all(error <= result.bound)
    assert error.max() < 1e-3 and result.bound.max() < 1e-2


def test_block_sums_never_overflow_the_word() -> None:
    """Sums beyond the format's range stay exact: the block exponent absorbs them."""
    q = QFormat.parse("Q2.8")
    total, _ = FixedAlgebra(q).eliminate(q.quantise(np.full(400, 1.0)), 0)
    assert int(total.raw) * 2.0 ** int(total.exp) == 400.0
    assert int(total.raw) <= q.max_raw and float(total.error) == 0.0


def test_values_beyond_the_format_raise_config_error() -> None:
    with pytest.raises(ConfigError, match="does not fit"):
        QFormat.parse("Q2.8").quantise([3.0])


def test_fixed_point_map_matches_float_on_clear_cases() -> None:
    net = random_net(5, n_vars=6)
    evidence = sample_evidence(net, np.random.default_rng(2), 2)
    assignment, probability = net.map(evidence, fixed_point="Q16.16")
    free = [n for n in net.variables if n not in evidence]
    best, p_best, _ = brute_map(net, free, evidence)
    assert abs(probability - p_best) < 1e-4
    assert assignment == best


def test_fixed_point_is_deterministic_and_cli_style_option_works() -> None:
    net = BayesNet("rain")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    a = net.posterior("Rain", {"Wet": "yes"}, fixed_point="Q16.16")
    b = net.posterior("Rain", {"Wet": "yes"}, fixed_point=QFormat(16, 16))
    assert a == b
    assert a["yes"] == pytest.approx(0.18 / 0.26, abs=2 * QFormat().resolution)
    assert a["yes"] * 65536 == int(a["yes"] * 65536)
