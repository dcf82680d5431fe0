"""Q-format fixed-point inference: parsing, honesty of the error bound, determinism."""

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
@given(
    seed=SEEDS,
    n_evidence=st.integers(0, 3),
    q=st.sampled_from(["Q16.16", "Q8.24", "Q12.12", "Q2.30"]),
)
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
        assert gap <= 2 * QFormat().resolution + one.bound.max()


def test_bound_scales_with_the_resolution() -> None:
    """8 more fractional bits shrink the bound about 256-fold (it is not vacuous)."""
    for seed in range(10):
        net = random_net(seed, n_vars=6)
        evidence = sample_evidence(net, np.random.default_rng(seed), 2)
        for target in net.variables:
            coarse = net.posterior_fixed(target, evidence, "Q16.16").bound.max()
            fine = net.posterior_fixed(target, evidence, "Q8.24").bound.max()
            assert fine <= coarse / 64
            assert coarse < 1e-2


def test_fixed_point_map_matches_float_on_clear_cases() -> None:
    net = random_net(5, n_vars=6)
    evidence = sample_evidence(net, np.random.default_rng(2), 2)
    assignment, probability = net.map(evidence, fixed_point="Q16.16")
    free = [n for n in net.variables if n not in evidence]
    best, p_best, _ = brute_map(net, free, evidence)
    assert abs(probability - p_best) < 1e-3
    assert assignment == best


def test_overflow_raises_config_error() -> None:
    algebra = FixedAlgebra(QFormat.parse("Q2.8"))
    a = QFormat.parse("Q2.8").quantise(np.full(4, 1.0))
    with pytest.raises(ConfigError, match="overflow"):
        algebra.eliminate(a, 0)


def test_fixed_point_is_deterministic_and_cli_style_option_works() -> None:
    net = BayesNet("rain")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    a = net.posterior("Rain", {"Wet": "yes"}, fixed_point="Q16.16")
    b = net.posterior("Rain", {"Wet": "yes"}, fixed_point=QFormat(16, 16))
    assert a == b
    assert a["yes"] == pytest.approx(0.18 / 0.26, abs=2 * QFormat().resolution)
    assert a["yes"] * 65536 == int(a["yes"] * 65536)
