"""Contraction orders of a pattern's first question: the network-wide order restricted to the
plan against a min-weight order of the plan's own.

For each network, ``--patterns`` random one-case questions (a target and ``--observed``
observed variables) are planned as the engine plans them, and each plan's factors are
ordered twice with :func:`bayesmap.bn.plans.order_steps`:

- *own*: the greedy min-weight order of the plan's factors (what every pattern paid for
  before the network-wide order);
- *network*: the engine's one-case order now — the network-wide min-weight order restricted
  to the plan, evidence-free sub-trees first, kept when its arithmetic is negligible
  (``Tuning.network_order_per_factor``), else the plan's own.

Reported per network: the time of the network-wide order (once per network), the CPU time
of ordering all the patterns each way (µs per pattern; the ways alternate for three rounds
and each keeps its fastest), how often the network order was
kept, and the quality of the orders: multiply-adds summed over the patterns (every step, as
a pattern's first question contracts them, constant steps included) and, for the steps a
warm question repeats (those that join evidence), their number and multiply-adds. Besides
the bnlearn networks, two generated families nobody tuned on: random DAGs whose parents are
any earlier variables (``random``) and long networks whose parents lie among the ten
variables before (``banded``), each a fresh seed per network.

    python benchmarks/bn_orders.py            # all networks; writes the bn_orders section
    python benchmarks/bn_orders.py alarm andes --no-write
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._bnlearn import MODELS  # noqa: E402
from benchmarks._bnlearn import NETWORKS as BNLEARN  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402
from tests.bn.helpers import random_net  # noqa: E402

import bayesmap.bn as bn  # noqa: E402
from bayesmap.bn import plans  # noqa: E402
from bayesmap.bn.elimination import walk  # noqa: E402
from bayesmap.bn.inference import Engine  # noqa: E402
from bayesmap.bn.plans import QueryKind  # noqa: E402

ROUNDS = 3
NETWORKS = [
    *BNLEARN,
    "random-1",
    "random-2",
    "banded-1",
    "banded-2",
]


def banded_net(seed: int, n_vars: int = 300, band: int = 10) -> bn.BayesNet:
    """A long network: each variable has up to 3 parents among the ``band`` before it, 2–4
    states, Dirichlet(1) CPT columns."""
    rng = np.random.default_rng(seed)
    net = bn.BayesNet(f"banded-{seed}")
    for i in range(n_vars):
        card = int(rng.integers(2, 5))
        window = range(max(0, i - band), i)
        k = int(rng.integers(0, min(len(window), 3) + 1))
        parents = [f"X{j}" for j in sorted(rng.choice(list(window), size=k, replace=False))]
        shape = (card, *(net.cardinality(p) for p in parents))
        table = np.moveaxis(rng.dirichlet(np.ones(card), size=shape[1:]), -1, 0)
        net.add_variable(f"X{i}", [f"s{s}" for s in range(card)], parents=parents, cpt=table)
    return net


def load(name: str) -> bn.BayesNet:
    family, _, seed = name.partition("-")
    if family == "random":
        return random_net(int(seed), n_vars=60, max_card=3, max_parents=3)
    if family == "banded":
        return banded_net(int(seed))
    return bn.read(MODELS / f"{name}.bif.gz")


def repeated(
    factors: list[Any], targets: tuple[int, ...], path: list[tuple[int, ...]], card: Any
) -> tuple[int, int]:
    """Steps of ``path`` that join evidence (a warm question runs them) and their
    multiply-adds."""
    constant = [not f.observed for f in factors]
    steps = entries = 0
    for step in walk([f.free for f in factors], targets, path):
        fixed = all(constant[i] for i in step.inputs)
        constant.append(fixed)
        if not fixed:
            steps += 1
            entries += math.prod(card[u] for u in step.union)
    return steps, entries


def measure(name: str, n_patterns: int, n_observed: int, seed: int) -> dict[str, Any]:
    net = load(name)
    engine = Engine(net, net.tuning)
    compiled = engine.compiled
    start = time.process_time()
    plans.network_order(compiled)
    network_ms = (time.process_time() - start) * 1e3
    rng = np.random.default_rng(seed)
    n = len(compiled.names)
    jobs = []
    for _ in range(n_patterns):
        chosen = [int(v) for v in rng.choice(n, size=n_observed + 1, replace=False)]
        plan = engine.plan(QueryKind.MARGINAL, (chosen[0],), frozenset(chosen[1:]))
        if len(plan.factors) >= 2:
            jobs.append(plan)
    tuning = engine.tuning
    results: dict[str, list[tuple[list[tuple[int, ...]], int]]] = {}
    seconds: dict[str, float] = {"own": math.inf, "network": math.inf}
    for _ in range(ROUNDS):  # the ways alternate; each keeps its fastest round
        for way in ("own", "network"):
            out = []
            start = time.process_time()
            for plan in jobs:
                scopes = [f.free for f in plan.factors]
                flags = [not f.observed for f in plan.factors] if way == "network" else None
                path, _, cost = plans.order_steps(
                    compiled, scopes, plan.targets, network=flags, tuning=tuning
                )
                out.append((path, cost))
            seconds[way] = min(seconds[way], time.process_time() - start)
            results[way] = out
    row: dict[str, Any] = {
        "network": name,
        "variables": n,
        "patterns": len(jobs),
        "network_ms": network_ms,
        "factors": statistics.median(len(p.factors) for p in jobs),
    }
    for way in ("own", "network"):
        row[f"{way}_us"] = seconds[way] / len(jobs) * 1e6
        row[f"{way}_cost"] = sum(cost for _, cost in results[way])
        warm = [
            repeated(p.factors, p.targets, path, compiled.card)
            for p, (path, _) in zip(jobs, results[way], strict=True)
        ]
        row[f"{way}_warm_steps"] = sum(s for s, _ in warm)
        row[f"{way}_warm_cost"] = sum(e for _, e in warm)
    row["changed"] = sum(
        own != new for (own, _), (new, _) in zip(results["own"], results["network"], strict=True)
    )
    ratios = [
        new / own for (_, own), (_, new) in zip(results["own"], results["network"], strict=True)
    ]
    row["cost_ratio_max"] = max(ratios)
    return row


def markdown(
    rows: list[dict[str, Any]], args: argparse.Namespace, load: tuple[float, float]
) -> str:
    lines = [
        "## Contraction orders of a pattern's first question (`benchmarks/bn_orders.py`)",
        "",
        f"Machine: {machine()}, shared with other jobs (1-minute load average {load[0]:.1f} "
        f"at the start, {load[1]:.1f} at the end). {args.patterns} patterns per network, a "
        f"target and {args.observed} observed variables. *own*: the min-weight order of each "
        "plan's own factors; *network*: the engine's order (the network-wide order restricted "
        "to the plan, evidence-free sub-trees first, replaced by the plan's own where its "
        "arithmetic is not negligible). *ordering*: CPU µs per pattern, the fastest of "
        f"{ROUNDS} alternating rounds (the load inflates it); *network order*: its one-off CPU "
        "ms per network; *changed*: patterns whose order differs from the own one; "
        "*multiply-adds*: every step's, summed over the patterns (the worst pattern's ratio "
        "beside); *warm steps*: the steps that join evidence (a repeated question runs only "
        "these) and their multiply-adds, summed. Counts, not times, except the time columns. "
        "`random-S`: 60-variable random DAGs; `banded-S`: 300 variables, parents among the "
        "10 before.",
        "",
        "| network | vars | factors (median) | network order ms | ordering own µs | network µs "
        "| changed | multiply-adds own | network | worst ratio | warm steps own | network "
        "| warm multiply-adds own | network |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['network']} | {r['variables']} | {r['factors']:.0f} | {r['network_ms']:.1f} "
            f"| {r['own_us']:.0f} | {r['network_us']:.0f} | {r['changed']}/{r['patterns']} "
            f"| {r['own_cost']:,} | {r['network_cost']:,} | {r['cost_ratio_max']:.1f} "
            f"| {r['own_warm_steps']:,} | {r['network_warm_steps']:,} "
            f"| {r['own_warm_cost']:,} | {r['network_warm_cost']:,} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("networks", nargs="*", default=NETWORKS)
    parser.add_argument("--patterns", type=int, default=200)
    parser.add_argument("--observed", type=int, default=3)
    parser.add_argument("--seed", type=int, default=20261202)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    load_start = os.getloadavg()[0]
    rows = []
    for k, name in enumerate(args.networks):
        row = measure(name, args.patterns, args.observed, args.seed + k)
        rows.append(row)
        print(
            f"{name:11s} ordering {row['own_us']:.0f} -> {row['network_us']:.0f} µs, "
            f"multiply-adds {row['own_cost']:,} -> {row['network_cost']:,}, warm steps "
            f"{row['own_warm_steps']:,} -> {row['network_warm_steps']:,} "
            f"(load {os.getloadavg()[0]:.1f})",
            flush=True,
        )
    text = markdown(rows, args, (load_start, os.getloadavg()[0]))
    print(text)
    if not args.no_write and args.networks == NETWORKS:
        update_section("bn_orders", text)


if __name__ == "__main__":
    main()
