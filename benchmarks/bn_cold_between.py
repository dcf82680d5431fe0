"""What runs between a network's cold questions changes what they cost.

``benchmarks/bn_inference.py`` times a pattern's first ("cold") question right after a fresh
pyAgrum and a pgmpy question, as a robot would ask it between other work, and the cold
median there reads 30 % or more above the same questions asked back to back. This script
separates the causes. For each network, 120 new patterns (a target and 3 observed
variables, values by forward sampling) are asked once each of a fresh copy of the network
(after its untimed first question), each question preceded by one of the following (six
rounds of all six, their order rotating, after one untimed round of the first):

- *nothing*;
- *4 MiB sweep*: one byte written in every 64-byte cache line of a 4 MiB buffer (twice
  the per-core L2 cache of the machine measured; the engine's data must come back from
  the shared L3);
- *arithmetic loop*: a Python loop of 20,000 integer additions (the interpreter runs
  other bytecode, allocating nothing);
- *allocating loop*: a Python function that fills a dict with 20,000 entries of tuples
  and strings and drops it;
- *allocating loop, then small objects*: the same, then 1,500 tuples, 300 dicts and 300
  lists made and dropped (whether the rise is the engine's own allocations landing in memory
  the burst pushed out of the caches);
- *peers*: a fresh pyAgrum ``LazyPropagation`` and a pgmpy ``VariableElimination.query`` of
  the same pattern, as in ``bn_inference.py``.

Median CPU ms (``time.process_time``) of the bayesmap question, and pgmpy's median asked
back to back and among the peers, so that cold × pgmpy can be read both ways. And the same
questions *warm* (every pattern asked once before, so each question runs its compiled
program) with nothing or the allocating loop before: whether the rise is paid by the
planning code a cold question runs or by what every question runs. Run
``python benchmarks/bn_cold_between.py`` (writes the ``bn_cold_between`` section of
docs/benchmarks.md; network names as arguments only print).
"""

from __future__ import annotations

import logging
import os
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import pyagrum as gum  # noqa: E402
from benchmarks._bnlearn import MODELS  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks.bn_inference import forward_sample, load_pyagrum, to_pgmpy  # noqa: E402
from pgmpy.inference import VariableElimination  # noqa: E402

import bayesmap.bn as bn  # noqa: E402

NETWORKS = ("alarm", "insurance", "hailfinder", "win95pts", "pathfinder", "pigs")
N_PATTERNS = 120
N_EVIDENCE = 3
ROUNDS = 6
LOOP = 20_000
SWEEP = np.zeros(4 << 20, dtype=np.uint8)

Question = tuple[str, dict[str, str]]
CONDITIONS = ("nothing", "sweep", "arithmetic", "allocating", "refilled", "peers")


def sweep() -> None:
    SWEEP[::64] += 1


def arithmetic() -> None:
    total = 0
    for i in range(LOOP):
        total += i
    if total < 0:
        raise AssertionError


def allocating() -> None:
    entries = {}
    for i in range(LOOP):
        entries[i] = (i, str(i))
    entries.clear()


def refilled() -> None:
    allocating()
    small = [(i, i) for i in range(1_500)], [{} for _ in range(300)], [[i] for i in range(300)]
    del small


def questions(name: str, net: bn.BayesNet, rng: np.random.Generator) -> list[Question]:
    """The network's first question, then ``N_PATTERNS`` patterns, one set of values each."""
    names = list(net.variables)
    draws = forward_sample(net, N_PATTERNS + 1, rng)
    asked = []
    for k in range(N_PATTERNS + 1):
        chosen = [str(v) for v in rng.choice(names, size=N_EVIDENCE + 1, replace=False)]
        values = {v: net.states(v)[int(draws[v][k])] for v in chosen[1:]}
        asked.append((chosen[0], values))
    return asked


def cold_times(name: str, asked: list[Question], before: Callable[[Question], Any]) -> list[float]:
    """CPU seconds of the bayesmap questions ``asked[1:]`` of a fresh copy of the network,
    ``before(question)`` run before each."""
    net = bn.read(MODELS / f"{name}.bif.gz")
    net.posterior(*asked[0])
    spent = []
    for question in asked[1:]:
        before(question)
        start = time.process_time()
        net.posterior(*question)
        spent.append(time.process_time() - start)
    return spent


def warm_ms(name: str, asked: list[Question]) -> dict[str, float]:
    """Median CPU ms of the same questions once every pattern has been asked (each one
    *warm*), with nothing and with the allocating loop right before, rotating rounds."""
    net = bn.read(MODELS / f"{name}.bif.gz")
    for question in asked:
        net.posterior(*question)
    spent: dict[str, list[float]] = {"nothing": [], "allocating": []}
    for r in range(ROUNDS):
        for condition in sorted(spent, reverse=r % 2 == 1):
            for question in asked[1:]:
                if condition == "allocating":
                    allocating()
                start = time.process_time()
                net.posterior(*question)
                spent[condition].append(time.process_time() - start)
    return {c: statistics.median(v) * 1e3 for c, v in spent.items()}


def measure(name: str, rng: np.random.Generator) -> dict[str, Any]:
    net = bn.read(MODELS / f"{name}.bif.gz")
    asked = questions(name, net, rng)
    g, _ = load_pyagrum(name, net)
    ve = VariableElimination(to_pgmpy(net))
    pgmpy_spent: list[float] = []

    def pgmpy(question: Question, record: bool) -> None:
        start = time.process_time()
        ve.query([question[0]], evidence=question[1], show_progress=False)
        if record:
            pgmpy_spent.append(time.process_time() - start)

    def peers(question: Question) -> None:
        engine = gum.LazyPropagation(g)
        engine.setEvidence(question[1])
        engine.addTarget(question[0])
        engine.makeInference()
        engine.posterior(question[0])
        pgmpy(question, True)

    befores: dict[str, Callable[[Question], Any]] = {
        "nothing": lambda q: None,
        "sweep": lambda q: sweep(),
        "arithmetic": lambda q: arithmetic(),
        "allocating": lambda q: allocating(),
        "refilled": lambda q: refilled(),
        "peers": peers,
    }
    cold_times(name, asked, befores["nothing"])  # warm-up: the process's heap grows here
    spent: dict[str, list[float]] = {c: [] for c in CONDITIONS}
    for r in range(ROUNDS):  # each condition once a round, their order rotating
        for k in range(len(CONDITIONS)):
            condition = CONDITIONS[(k + r) % len(CONDITIONS)]
            spent[condition] += cold_times(name, asked, befores[condition])
    alone_pgmpy = []
    for question in asked[1:]:
        start = time.process_time()
        ve.query([question[0]], evidence=question[1], show_progress=False)
        alone_pgmpy.append(time.process_time() - start)
    row: dict[str, Any] = {c: statistics.median(v) * 1e3 for c, v in spent.items()}
    row["network"] = name
    row["warm"] = warm_ms(name, asked)
    row["pgmpy_alone"] = statistics.median(alone_pgmpy) * 1e3
    row["pgmpy_peers"] = statistics.median(pgmpy_spent) * 1e3
    return row


def markdown(rows: list[dict[str, Any]], load: tuple[float, float]) -> str:
    lines = [
        "## What runs between cold questions (`benchmarks/bn_cold_between.py`)",
        "",
        f"Machine: {machine()}, shared with other jobs (1-minute load average {load[0]:.1f} "
        f"at the start, {load[1]:.1f} at the end). {N_PATTERNS} new patterns per network "
        f"(a target and {N_EVIDENCE} observed variables), each asked once of a fresh copy "
        f"of the network, {ROUNDS} rounds of the six conditions in rotating order after an "
        "untimed round; median CPU ms of the bayesmap question, and in brackets its rise "
        "over *nothing*, when right before it ran: nothing; a write to every cache line of a "
        f"4 MiB buffer; a Python loop of {LOOP:,} integer additions; a Python function "
        f"filling and dropping a dict of {LOOP:,} tuples and strings; the same, then 1,500 "
        "tuples, 300 dicts and 300 lists made and dropped; a fresh pyAgrum and a "
        "pgmpy question of the same pattern (as in `bn_inference.py`). *warm*: the same "
        "questions once every pattern has been asked, with nothing or the allocating loop "
        "before (rotating rounds). pgmpy: its median "
        "asked back to back, and among the peers; × pgmpy: the two ways of reading it.",
        "",
        "| network | nothing | 4 MiB sweep | arithmetic loop | allocating loop "
        "| allocating loop, then small objects | peers | warm: nothing | warm: allocating loop "
        "| pgmpy alone | pgmpy among peers | × pgmpy, back to back | × pgmpy, among peers |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for r in rows:
        base, warm = r["nothing"], r["warm"]
        cells = [f"{base:.3f}"] + [f"{r[c]:.3f} ({r[c] / base - 1:+.0%})" for c in CONDITIONS[1:]]
        lines.append(
            f"| {r['network']} | " + " | ".join(cells) + f" | {warm['nothing']:.3f} "
            f"| {warm['allocating']:.3f} ({warm['allocating'] / warm['nothing'] - 1:+.0%}) "
            f"| {r['pgmpy_alone']:.3f} "
            f"| {r['pgmpy_peers']:.3f} | {r['pgmpy_alone'] / base:.1f} "
            f"| {r['pgmpy_peers'] / r['peers']:.1f} |"
        )
    return "\n".join(lines)


def main() -> None:
    warnings.filterwarnings("ignore")
    logging.getLogger("pgmpy").setLevel(logging.ERROR)
    rng = np.random.default_rng(20261205)
    load_start = os.getloadavg()[0]
    rows = []
    for name in sys.argv[1:] or NETWORKS:
        row = measure(name, rng)
        rows.append(row)
        print(
            f"{name:11s} "
            + ", ".join(f"{c} {row[c]:.3f}" for c in CONDITIONS)
            + f" | pgmpy {row['pgmpy_alone']:.3f} / {row['pgmpy_peers']:.3f} ms",
            flush=True,
        )
    text = markdown(rows, (load_start, os.getloadavg()[0]))
    print(text)
    if not sys.argv[1:]:
        update_section("bn_cold_between", text)


if __name__ == "__main__":
    main()
