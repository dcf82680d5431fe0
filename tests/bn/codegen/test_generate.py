"""Generated C against the engine on random questions: bit for bit in fixed point."""

from __future__ import annotations

import numpy as np
import pytest
from tests.bn.codegen.conftest import (
    BNLEARN,
    bnlearn,
    engine_answer,
    extreme_net,
    needs_cc,
    pattern,
    random_question,
)
from tests.bn.helpers import random_net

from bayesmap.bn import BayesNet
from bayesmap.bn.codegen import SoftNetwork, generate
from bayesmap.bn.codegen.native import NativeNetwork
from bayesmap.bn.fixed_point import QFormat
from bayesmap.errors import ConfigError, InputError
from bayesmap.rover.network import CycleInputs, DecisionNetwork
from bayesmap.rover.params import RoverParams

TOLERANCE = {"float": 1e-6, "double": 1e-12}
FAST_BUILD = ("-O0",)
"""Most builds skip optimisation (gcc -O2 takes seconds on a busy machine); the asia test
builds with -O2."""


def _compare(net, code, native, rng, n_questions, arith):
    soft_net = SoftNetwork.build(net, code.soft)
    scale = QFormat.parse(arith).scale if arith not in TOLERANCE else 1 << 16
    compared = 0
    for _ in range(n_questions):
        question = random_question(net, code, rng, scale)
        raw_soft = {v: x * scale if arith not in TOLERANCE else x for v, x in question.soft.items()}
        try:
            expected = engine_answer(soft_net, code, question, arith)
        except InputError:
            with pytest.raises(InputError):
                native.posterior(question.target, question.slots, raw_soft)
            continue
        got = native.posterior(question.target, question.slots, raw_soft)
        if arith in TOLERANCE:
            np.testing.assert_allclose(got, expected, rtol=0, atol=TOLERANCE[arith])
        else:
            np.testing.assert_array_equal(got, expected)
        compared += 1
    assert compared >= n_questions // 2


@needs_cc
@pytest.mark.parametrize("arith", ["q16.16", "q8.24", "float", "double"])
@pytest.mark.parametrize("seed", range(4))
def test_random_networks_match_the_engine(tmp_path, arith, seed):
    rng = np.random.default_rng(seed)
    net = random_net(seed, n_vars=9, max_card=4, max_parents=3)
    targets, evidence, soft = pattern(net, rng, n_evidence=4, n_soft=2)
    code = generate(net, targets, evidence, arith, soft=soft, name="net")
    native = NativeNetwork(code, tmp_path, flags=FAST_BUILD)
    _compare(net, code, native, rng, 60, arith)


@needs_cc
@pytest.mark.parametrize(
    "seed", [0, *(pytest.param(seed, marks=pytest.mark.slow) for seed in range(1, 10))]
)
@pytest.mark.parametrize("arith", ["q16.16", "q8.24"])
def test_near_deterministic_networks_match_bit_for_bit(tmp_path, arith, seed):
    rng = np.random.default_rng(100 + seed)
    net = extreme_net(seed)
    targets, evidence, soft = pattern(net, rng, n_evidence=6, n_soft=1)
    code = generate(net, targets, evidence, arith, soft=soft, name="extreme")
    _compare(net, code, NativeNetwork(code, tmp_path, flags=FAST_BUILD), rng, 40, arith)


@needs_cc
@pytest.mark.parametrize("arith", ["q16.16", "double"])
def test_asia_matches_the_engine(tmp_path, arith):
    rng = np.random.default_rng(5)
    net = bnlearn("asia")
    targets, evidence, soft = pattern(net, rng, n_evidence=4, n_soft=1)
    code = generate(net, targets, evidence, arith, soft=soft, name="asia")
    _compare(net, code, NativeNetwork(code, tmp_path, flags=("-O2",)), rng, 40, arith)


@needs_cc
@pytest.mark.slow
@pytest.mark.parametrize("name", BNLEARN)
@pytest.mark.parametrize("arith", ["q16.16", "q8.24", "float", "double"])
def test_bnlearn_networks_match_the_engine(tmp_path, name, arith):
    rng = np.random.default_rng(abs(hash(name)) % 1000)
    net = bnlearn(name)
    targets, evidence, soft = pattern(net, rng, n_evidence=4, n_soft=1)
    code = generate(net, targets, evidence, arith, soft=soft, name=name)
    native = NativeNetwork(code, tmp_path, flags=FAST_BUILD)
    _compare(net, code, native, rng, 30, arith)


@needs_cc
def test_impossible_evidence_is_an_error_code_where_the_engine_raises(tmp_path):
    rng = np.random.default_rng(7)
    net = random_net(11, n_vars=7, max_card=3, zero_fraction=0.4)
    targets, evidence, _ = pattern(net, rng, n_evidence=4, n_soft=0)
    code = generate(net, targets, evidence, "q16.16", name="zeros")
    native = NativeNetwork(code, tmp_path, flags=FAST_BUILD)
    raised = 0
    for combo in np.ndindex(*(code.states[v] for v in evidence)):
        slots = list(combo)
        try:
            expected = net.posterior_fixed(targets[0], dict(zip(evidence, slots, strict=True))).raw
        except InputError:
            raised += 1
            with pytest.raises(InputError, match="probability zero"):
                native.posterior(targets[0], slots)
            continue
        np.testing.assert_array_equal(native.posterior(targets[0], slots), expected)
    assert raised > 0


@needs_cc
def test_out_of_range_states_are_refused(tmp_path):
    net = random_net(2, n_vars=5)
    code = generate(net, ["X4"], ["X0", "X1"], "double", name="ranges")
    native = NativeNetwork(code, tmp_path, flags=FAST_BUILD)
    with pytest.raises(InputError, match="out of range"):
        native.posterior("X4", [code.states["X0"], -1])


def test_bad_patterns_are_config_errors():
    net = random_net(2, n_vars=5)
    with pytest.raises(ConfigError, match="both a target and evidence"):
        generate(net, ["X4"], ["X4"])
    with pytest.raises(ConfigError, match="no variable 'X9'"):
        generate(net, ["X9"], ["X0"])
    with pytest.raises(ConfigError, match="no variable 'x0'; did you mean 'X0'"):
        generate(net, ["X4"], ["x0"])
    with pytest.raises(ConfigError, match=r"'x1' \(soft evidence\); did you mean 'X1'"):
        generate(net, ["X4"], ["X0"], soft=["x1"])
    with pytest.raises(ConfigError, match="fixed-point format|Q<integer"):
        generate(net, ["X4"], ["X0"], "half")
    with pytest.raises(ConfigError, match="prefix"):
        generate(net, ["X4"], ["X0"], name="1bad-name")


def test_names_that_would_share_a_c_name_are_refused():
    net = BayesNet("clash")
    for name in ("a b", "A_b", "T"):
        net.add_variable(name, ["y", "n"], cpt=[0.5, 0.5])
    with pytest.raises(ConfigError, match="'a b' and 'A_b' both become the C name"):
        generate(net, ["T"], ["a b", "A_b"])
    generate(net, ["T"], ["a b"])  # one of them alone is fine


@needs_cc
def test_names_cannot_end_or_nest_the_comments_they_appear_in(tmp_path):
    net = BayesNet("n */ x /* y")
    net.add_variable("a */ oops /* b", ["y*/", "n"], cpt=[0.3, 0.7])
    net.add_variable("T", ["y", "n"], parents=["a */ oops /* b"], cpt=[[0.9, 0.2], [0.1, 0.8]])
    code = generate(net, ["T"], ["a */ oops /* b"], "double", name="cmt")
    native = NativeNetwork(code, tmp_path, flags=FAST_BUILD)
    got = native.posterior("T", [0])
    expected = net.posterior("T", {"a */ oops /* b": "y*/"})
    np.testing.assert_allclose(got, [expected["y"], expected["n"]], atol=1e-12)


def test_generated_code_has_no_allocation_recursion_or_libm():
    net = bnlearn("alarm")
    code = generate(net, ["HR", "BP"], ["CVP", "PCWP", "HRBP"], "q16.16", soft=["SAO2"])
    text = code.source
    for word in ("malloc", "calloc", "free(", "math.h", "exp(", "log(", "sqrt(", "float", "double"):
        assert word not in text
    assert "static const int32_t cpt_" in text
    assert code.functions == 2 * 2**3


@needs_cc
@pytest.mark.parametrize("arith", ["q16.16", "q8.24", "double"])
def test_the_rovers_decision_network_with_its_data_nodes_matches_the_engine(tmp_path, arith):
    decision = DecisionNetwork(RoverParams())
    net, m = decision.net, decision.params.n_headings
    rangers = [v for v in net.variables if v.startswith("IR_")]
    code = generate(
        net, ["Motors", "SensorFusion"], [*rangers, "ProbabilityMap", "Footprint"], arith
    )
    assert set(code.data) == {v for v in net.variables if net.variable(v).source is not None}
    native = NativeNetwork(code, tmp_path, flags=FAST_BUILD)
    rng = np.random.default_rng(9)
    for _ in range(30):
        p_t = rng.random(m)
        decision.inputs_ = CycleInputs(
            ranges=rng.uniform(0.05, decision.params.r_max, decision.n_sensors),
            p_t=p_t / p_t.sum(),
            p_o=np.minimum(rng.random(m), 0.99),
            safe=rng.random(m) < 0.8,
        )
        evidence: dict[str, str | int] = {
            v: int(rng.integers(2)) for v in rangers if rng.random() < 0.7
        }
        for node in ("ProbabilityMap", "Footprint"):
            if rng.random() < 0.7:
                evidence[node] = "clear"
        target = str(rng.choice(code.targets))
        got = native.ask(net, target, evidence)
        if arith == "double":
            want = np.fromiter(net.posterior(target, evidence).values(), float)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        else:
            np.testing.assert_array_equal(got, net.posterior_fixed(target, evidence, arith).values)
