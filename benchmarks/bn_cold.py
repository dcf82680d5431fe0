"""Where a pattern's first ("cold") question spends its time, and how much of it the
per-call cost of its sum-products could explain.

For each bnlearn network of ``benchmarks/bn_inference.py`` (up to munin's size): 40 random
patterns (a target and 3 observed variables, values drawn by forward sampling, as there),
each asked once in a process that has answered one untimed question of another pattern. Per
question, CPU time (``time.process_time``) of the whole call and of its parts, taken by
wrapping the engine's functions for this run only:

- *priors*: the prior marginals of variables (``Engine._marginal``) the question needs
  and no earlier one computed — of the sub-networks a plan replaces by ``P(Y)``, and of
  observed variables d-separated from the target, whose states' priors are checked for
  impossible evidence; cached for the network's later questions;
- *plan*: pruning and slicing (``plans.build``, priors excluded);
- *order*: the contraction order (``plans.order_steps``) — for a one-case question this
  also builds the compiled program's steps, handed to it once the order is chosen
  (``SumProgram.extend``), including the evidence-free steps contracted now (those another
  pattern already contracted are looked up);
- *compile*: ``SumProgram``'s constructor — for a one-case question only its set-up (the
  steps come through *order*), all of the program where the order came from a cache or
  from opt_einsum's search;
- *run*: the first run of the compiled program;
- *rest*: everything else (evidence lookup, the ancestral-query check, normalising).

Each part excludes the priors computed inside it.

And the sum-product calls a cold question makes (``elimination.einsum``: small products
summed in the compiled core, larger ones by numpy; compile and run), and the fixed cost of one
such call (a 2×3 by 3×4 product, best of 5 × 2,000), whose product is the share of the
question that this per-call cost alone accounts for. And the *interpreter steps* of a cold
question: the Python bytecode instructions it executes (counted with ``sys.settrace``
opcode events, the same questions asked again of a fresh copy of the network, untimed) —
a count no other job on the machine can move, and the Python bookkeeping that is most of a
cold question. The wrappers add a few µs per
question, so the parts sum to a little more than a cold question of
``benchmarks/bn_inference.py``. Run ``python benchmarks/bn_cold.py`` (writes the
``bn_cold`` section of docs/benchmarks.md; network names as arguments only print).
"""

from __future__ import annotations

import os
import statistics
import sys
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._bnlearn import MODELS, NETWORKS  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402

import bayesmap.bn as bn  # noqa: E402
from bayesmap.bn import elimination, plans  # noqa: E402
from bayesmap.bn.inference import Engine  # noqa: E402

N_PATTERNS = 40
N_EVIDENCE = 3
PARTS = ("priors", "plan", "order", "compile", "run")


class Meter:
    """CPU seconds spent in wrapped functions and einsum calls: outermost calls only, except
    that a prior computed inside another part is moved from that part to *priors*."""

    def __init__(self) -> None:
        self.spent = dict.fromkeys(PARTS, 0.0)
        self.calls = 0
        self._open: list[str] = []

    def reset(self) -> None:
        self.spent = dict.fromkeys(PARTS, 0.0)
        self.calls = 0

    def timed(self, part: str, function: Callable[..., Any]) -> Callable[..., Any]:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            open_ = self._open
            if open_ and (part != "priors" or "priors" in open_):
                return function(*args, **kwargs)  # nested: counted by the outer call
            open_.append(part)
            start = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                spent = time.process_time() - start
                open_.pop()
                self.spent[part] += spent
                if open_:  # a prior computed inside another part: not that part's time
                    self.spent[open_[-1]] -= spent

        return wrapper

    def counted(self, function: Callable[..., Any]) -> Callable[..., Any]:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            self.calls += 1
            return function(*args, **kwargs)

        return wrapper


def instrument(meter: Meter) -> None:
    """Wrap the engine's parts for this process (the benchmark's own run only)."""
    Engine._marginal = meter.timed("priors", Engine._marginal)  # type: ignore[method-assign]
    plans.build = meter.timed("plan", plans.build)
    plans.order_steps = meter.timed("order", plans.order_steps)
    program = elimination.SumProgram
    init, call = program.__init__, program.__call__
    program.__init__ = meter.timed("compile", init)  # type: ignore[method-assign]
    program.__call__ = meter.timed("run", call)  # type: ignore[method-assign]
    elimination.einsum = meter.counted(elimination.einsum)


def call_cost() -> float:
    """CPU seconds of one small ``elimination.einsum`` call (its fixed cost), best of 5."""
    a, b = np.ones((2, 3)), np.ones((3, 4))
    einsum = elimination.einsum
    runs = timeit.repeat(lambda: einsum(a, [0, 1], b, [1, 2], [0, 2]), number=2000, repeat=5)
    return min(runs) / 2000


def interpreter_steps(name: str, questions: list[tuple[str, dict[str, str]]]) -> float:
    """Mean bytecode instructions per question of ``questions[1:]`` on a fresh copy of the
    network, after ``questions[0]`` (the network's first question) untimed and uncounted."""
    net = bn.read(MODELS / f"{name}.bif.gz")
    net.posterior(*questions[0])
    steps = 0

    def tracer(frame: Any, event: str, arg: Any) -> Any:
        nonlocal steps
        if frame.f_code.co_filename == __file__:
            return None  # this benchmark's own timing wrappers are not the engine's steps
        frame.f_trace_opcodes = True
        if event == "opcode":
            steps += 1
        return tracer

    sys.settrace(tracer)
    try:
        for target, evidence in questions[1:]:
            net.posterior(target, evidence)
    finally:
        sys.settrace(None)
    return steps / (len(questions) - 1)


def measure(name: str, rng: np.random.Generator, meter: Meter) -> dict[str, Any]:
    net = bn.read(MODELS / f"{name}.bif.gz")
    names = list(net.variables)
    draws = net.copy().sample(N_PATTERNS + 1, rng=rng)
    questions = []
    for k in range(N_PATTERNS + 1):
        chosen = [str(v) for v in rng.choice(names, size=N_EVIDENCE + 1, replace=False)]
        evidence = {v: net.states(v)[int(draws[k, names.index(v)])] for v in chosen[1:]}
        questions.append((chosen[0], evidence))
    net.posterior(*questions[0])  # the network's first question: not a pattern's
    totals: list[float] = []
    parts: dict[str, list[float]] = {part: [] for part in PARTS}
    calls: list[int] = []
    for target, evidence in questions[1:]:
        meter.reset()
        start = time.process_time()
        net.posterior(target, evidence)
        totals.append(time.process_time() - start)
        for part in PARTS:
            parts[part].append(meter.spent[part])
        calls.append(meter.calls)
    rest = [t - sum(p[k] for p in parts.values()) for k, t in enumerate(totals)]
    return {
        "steps": interpreter_steps(name, questions),
        "network": name,
        "cold_ms": statistics.median(totals) * 1e3,
        "parts_ms": {part: statistics.fsum(v) / len(v) * 1e3 for part, v in parts.items()},
        "rest_ms": statistics.fsum(rest) / len(rest) * 1e3,
        "mean_ms": statistics.fsum(totals) / len(totals) * 1e3,
        "calls": statistics.median(calls),
        "calls_mean": statistics.fsum(calls) / len(calls),
    }


def markdown(rows: list[dict[str, Any]], cost: float, load: tuple[float, float]) -> str:
    lines = [
        "## A pattern's first question, part by part (`benchmarks/bn_cold.py`)",
        "",
        f"Machine: {machine()}, shared with other jobs (1-minute load average {load[0]:.1f} "
        f"at the start, {load[1]:.1f} at the end). {N_PATTERNS} patterns per network, a "
        f"target and {N_EVIDENCE} observed variables, each asked once after one untimed "
        "question of another pattern; CPU ms. *cold*: median; the parts are means (they add "
        "up to the mean question, which a few large patterns pull above the median). "
        "*einsum calls*: sum-product calls per question (`elimination.einsum`, median, "
        "mean); *call share*: mean calls "
        f"× the fixed cost of one call ({cost * 1e6:.2f} µs here) / mean question. "
        "*interpreter steps*: Python bytecode instructions per question (mean; the same "
        "questions on a fresh copy of the network, counted, not timed: the load cannot move "
        "it).",
        "",
        "| network | cold (median) | mean | priors | plan | order | compile | first run | rest "
        "| einsum calls | call share | interpreter steps |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for r in rows:
        p = r["parts_ms"]
        share = r["calls_mean"] * cost * 1e3 / r["mean_ms"]
        lines.append(
            f"| {r['network']} | {r['cold_ms']:.3f} | {r['mean_ms']:.3f} | {p['priors']:.3f} "
            f"| {p['plan']:.3f} "
            f"| {p['order']:.3f} | {p['compile']:.3f} | {p['run']:.3f} | {r['rest_ms']:.3f} "
            f"| {r['calls']:.0f}, {r['calls_mean']:.1f} | {share:.0%} | {r['steps']:,.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    rng = np.random.default_rng(20261201)
    cost = call_cost()
    meter = Meter()
    instrument(meter)
    load_start = os.getloadavg()[0]
    rows = []
    for name in sys.argv[1:] or NETWORKS:
        row = measure(name, rng, meter)
        rows.append(row)
        print(
            f"{name:11s} cold {row['cold_ms']:.3f} ms (mean {row['mean_ms']:.3f}), "
            + ", ".join(f"{k} {v:.3f}" for k, v in row["parts_ms"].items())
            + f", rest {row['rest_ms']:.3f}, einsum calls {row['calls_mean']:.1f}, "
            f"interpreter steps {row['steps']:,.0f} "
            f"(load {os.getloadavg()[0]:.1f})",
            flush=True,
        )
    text = markdown(rows, cost, (load_start, os.getloadavg()[0]))
    print(text)
    if not sys.argv[1:]:
        update_section("bn_cold", text)


if __name__ == "__main__":
    main()
