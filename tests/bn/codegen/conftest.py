"""Shared pieces of the code-generation tests: networks, random questions, the engine's answers."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pgmpy
import pytest

from bayesmap import bn
from bayesmap.bn.codegen import SOFT_SUFFIX, CSources
from bayesmap.bn.codegen.program import SoftNetwork

MODELS = Path(pgmpy.__file__).parent / "utils" / "example_models"
BNLEARN = ["asia", "alarm", "child", "insurance", "hailfinder"]

needs_cc = pytest.mark.skipif(
    shutil.which("cc") is None and shutil.which("gcc") is None,
    reason="no C compiler (cc or gcc) on PATH",
)


def bnlearn(name: str) -> bn.BayesNet:
    """A bnlearn network shipped with pgmpy."""
    return bn.read(MODELS / f"{name}.bif.gz")


def pattern(
    net: bn.BayesNet, rng: np.random.Generator, n_evidence: int = 4, n_soft: int = 1
) -> tuple[list[str], list[str], list[str]]:
    """Random targets (two), evidence variables and soft-evidence variables."""
    names = [v for v in net.variables if net.variable(v).source is None]
    chosen = [str(v) for v in rng.permutation(names)]
    targets, evidence = chosen[:2], chosen[2 : 2 + n_evidence]
    soft = [str(v) for v in rng.choice(chosen[2:], size=n_soft, replace=False)]
    return targets, evidence, soft


@dataclass
class Question:
    """One question: evidence slots (−1 not observed) and soft likelihoods by variable."""

    target: str
    slots: list[int]
    soft: dict[str, np.ndarray]


def random_question(
    net: bn.BayesNet, code: CSources, rng: np.random.Generator, scale: int
) -> Question:
    """Evidence from one forward sample (each slot observed with probability 0.6), and soft
    likelihoods on dyadic grids (multiples of ``1/scale``, so exact in every arithmetic)."""
    sample = net.sample(1, rng=rng)[0]
    names = list(net.variables)
    slots = [int(sample[names.index(v)]) if rng.random() < 0.6 else -1 for v in code.evidence]
    soft = {
        v: rng.integers(1, scale + 1, size=code.states[v]) / scale
        for v in code.soft
        if rng.random() < 0.8
    }
    return Question(str(rng.choice(code.targets)), slots, soft)


def engine_answer(
    soft_net: SoftNetwork, code: CSources, question: Question, arith: str
) -> np.ndarray:
    """The engine's answer to the question the generated code answers (raw integers in Q)."""
    for v in code.soft:
        soft_net.set(v, question.soft.get(v))
    evidence: dict[str, str | int] = {
        v: s for v, s in zip(code.evidence, question.slots, strict=True) if s >= 0
    }
    evidence.update({v + SOFT_SUFFIX: "seen" for v in code.soft})
    if arith in ("float", "double"):
        return np.fromiter(soft_net.net.posterior(question.target, evidence).values(), float)
    return soft_net.net.posterior_fixed(question.target, evidence, arith).raw


def extreme_net(seed: int, n_vars: int = 10) -> bn.BayesNet:
    """A random network with near-deterministic CPTs (Dirichlet(0.15) columns, entries down
    to 1e-12): long products of tiny numbers, the hardest case for block fixed point."""
    rng = np.random.default_rng(seed)
    net = bn.BayesNet(f"extreme-{seed}")
    for i in range(n_vars):
        card = int(rng.integers(2, 4))
        k = int(rng.integers(0, min(i, 3) + 1))
        parents = [f"X{j}" for j in sorted(rng.choice(i, size=k, replace=False))] if k else []
        shape = (card, *(net.cardinality(p) for p in parents))
        table = rng.dirichlet(np.full(card, 0.15), size=shape[1:]).reshape(*shape[1:], card)
        table = np.maximum(np.moveaxis(table, -1, 0), 1e-12)
        net.add_variable(
            f"X{i}", [f"s{j}" for j in range(card)], parents=parents, cpt=table / table.sum(0)
        )
    return net
