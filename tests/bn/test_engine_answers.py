"""The engine's answers on asia, alarm and child, checked against answers stored earlier.

``tests/bn/data/engine_answers.json`` holds posteriors (one, joint, all at once, soft), MAP,
marginal MAP, propositions, batches (one target, every target, soft) and Q16.16 fixed point
(single, batch, MAP, marginal MAP, propositions) of forward-sampled evidence on three
bnlearn networks shipped with pgmpy. A refactoring of the engine must give the same
answers: floats within 1e-12 (a different contraction order moves the last bits), fixed
point within the two answers' guaranteed bounds, MAP assignments equal.

Rewrite the file (only when the answers are meant to change) with
``python tests/bn/test_engine_answers.py --write``; ``python tests/bn/test_engine_answers.py``
says whether today's answers are bit-identical to the stored ones.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import bayesmap.bn as bn

pgmpy = pytest.importorskip("pgmpy")

MODELS = Path(pgmpy.__file__).parent / "utils" / "example_models"
STORED = Path(__file__).parent / "data" / "engine_answers.json"
NETWORKS = ("asia", "alarm", "child")
N_CASES = 4
N_BATCH = 40
Q = "Q16.16"


def _fixed(result: Any) -> dict[str, Any]:
    return {
        "raw": np.asarray(result.raw).tolist(),
        "values": np.asarray(result.values).tolist(),
        "bound": np.asarray(result.bound).tolist(),
    }


def answers(name: str) -> dict[str, Any]:
    """Every kind of question on network ``name``, with evidence drawn from a fixed seed."""
    net = bn.read(MODELS / f"{name}.bif.gz")
    rng = np.random.default_rng(sum(map(ord, name)))
    names = list(net.variables)
    draws = net.copy().sample(N_CASES + N_BATCH, rng=rng)
    out: dict[str, Any] = {"cases": []}
    for k in range(N_CASES):
        chosen = [str(v) for v in rng.choice(names, size=5, replace=False)]
        target, other, *observed = chosen
        evidence = {v: net.states(v)[int(draws[k, names.index(v)])] for v in observed}
        soft_on = other
        weights = rng.random(net.cardinality(soft_on)) + 0.1
        case: dict[str, Any] = {"target": target, "evidence": evidence}
        case["posterior"] = list(net.posterior(target, evidence).values())
        case["joint"] = net.joint_posterior([target, other], evidence).tolist()
        case["posteriors"] = {v: list(p.values()) for v, p in net.posteriors(evidence).items()}
        case["soft"] = list(net.posterior(target, evidence, soft={soft_on: weights}).values())
        case["evidence_probability"] = net.probability_of_evidence(evidence)
        case["map"] = net.map(evidence)
        case["marginal_map"] = net.marginal_map([target, other], evidence)
        likely = int(np.argmax(np.asarray(case["joint"]).sum(axis=0)))
        first, second = net.states(target)[0], net.states(other)[likely]
        proposition = f"{target}={first} or not {other}={second}"
        case["probability"] = net.probability(proposition, evidence)
        case["conditional"] = net.probability(
            f"{target}={first}", evidence, given=f"{other}={second}"
        )
        case["fixed_posterior"] = _fixed(net.posterior_fixed(target, evidence, Q))
        case["fixed_joint"] = _fixed(net.joint_posterior_fixed([target, other], evidence, Q))
        case["fixed_soft"] = _fixed(
            net.posterior_fixed(target, evidence, Q, soft={soft_on: weights})
        )
        assignment, p = net.map_fixed(evidence, Q)
        case["fixed_map"] = [assignment, _fixed(p)]
        assignment, p = net.marginal_map_fixed([target, other], evidence, Q)
        case["fixed_marginal_map"] = [assignment, _fixed(p)]
        case["fixed_probability"] = _fixed(net.probability_fixed(proposition, evidence, Q))
        out["cases"].append(case)
    columns = [str(v) for v in rng.choice(names, size=4, replace=False)]
    target = next(v for v in names if v not in columns)
    table = np.stack([draws[N_CASES:, names.index(v)] for v in columns], axis=1)
    table[rng.random(table.shape) < 0.3] = -1  # blanks: several patterns
    weights = rng.random((N_BATCH, net.cardinality(columns[0]))) + 0.1
    soft_table = table.copy()
    soft_table[:, 0] = -1
    out["batch"] = {"target": target, "columns": columns, "table": table.tolist()}
    out["batch"]["posterior"] = net.posterior_batch(target, table, columns=columns).tolist()
    out["batch"]["soft"] = net.posterior_batch(
        target, soft_table, columns=columns, soft={columns[0]: weights}
    ).tolist()
    few = [v for v in names if v not in columns][:5]
    every = net.posteriors_batch(table, columns=columns, targets=few)
    out["batch"]["posteriors"] = {v: p.tolist() for v, p in every.items()}
    out["batch"]["fixed"] = _fixed(net.posterior_batch_fixed(target, table, Q, columns=columns))
    return out


def _close_fixed(got: dict[str, Any], want: dict[str, Any]) -> None:
    gap = np.abs(np.asarray(got["values"]) - np.asarray(want["values"]))
    assert np.all(gap <= np.asarray(got["bound"]) + np.asarray(want["bound"]))


def _jsonable(value: Any) -> Any:
    return json.loads(json.dumps(value, default=lambda x: np.asarray(x).tolist()))


@pytest.mark.parametrize("name", NETWORKS)
def test_answers_are_those_stored(name: str) -> None:
    stored = json.loads(STORED.read_text())[name]
    got = _jsonable(answers(name))
    for case, want in zip(got["cases"], stored["cases"], strict=True):
        assert case["evidence"] == want["evidence"]
        for key in (
            "posterior",
            "joint",
            "soft",
            "evidence_probability",
            "probability",
            "conditional",
        ):
            np.testing.assert_allclose(case[key], want[key], rtol=1e-12, atol=1e-15, err_msg=key)
        assert case["posteriors"].keys() == want["posteriors"].keys()
        for v, p in case["posteriors"].items():
            np.testing.assert_allclose(p, want["posteriors"][v], rtol=1e-12, atol=1e-15)
        for key in ("map", "marginal_map"):
            assert case[key][0] == want[key][0]
            assert case[key][1] == pytest.approx(want[key][1], rel=1e-12)
        for key in ("fixed_map", "fixed_marginal_map"):
            assert case[key][0] == want[key][0]
    for key in ("posterior", "soft"):
        np.testing.assert_allclose(
            got["batch"][key], stored["batch"][key], rtol=1e-12, atol=1e-15, err_msg=key
        )
    for v, p in got["batch"]["posteriors"].items():
        np.testing.assert_allclose(p, stored["batch"]["posteriors"][v], rtol=1e-12, atol=1e-15)
    for case, want in zip(got["cases"], stored["cases"], strict=True):
        for key in ("fixed_posterior", "fixed_joint", "fixed_soft", "fixed_probability"):
            _close_fixed(case[key], want[key])
        for key in ("fixed_map", "fixed_marginal_map"):
            _close_fixed(case[key][1], want[key][1])
    _close_fixed(got["batch"]["fixed"], stored["batch"]["fixed"])


if __name__ == "__main__":
    if sys.argv[1:] == ["--write"]:
        STORED.write_text(json.dumps({n: _jsonable(answers(n)) for n in NETWORKS}))
    else:  # bit for bit: the same JSON text (floats written shortest round-trip)
        same = json.dumps({n: _jsonable(answers(n)) for n in NETWORKS}) == STORED.read_text()
        print("bit-identical to the stored answers" if same else "answers differ in some bits")
