"""Every posterior at once: bayesmap ``posteriors`` vs pyAgrum LazyPropagation vs the loop.

For each bnlearn network shipped with pgmpy, ``N_CASES`` evidence cases (``N_EVIDENCE``
variables each, values drawn by forward sampling so the evidence is possible) ask for the
posterior of every unobserved variable:

- bayesmap *first*: ``net.posteriors(e)`` the first time the case's pattern of observed
  variables is met (plans, contraction order and the choice of method are built);
- bayesmap *warm*: the same pattern asked again with other values;
- bayesmap *loop*: one ``net.posterior`` per unobserved variable (the engine before
  ``posteriors`` existed), warm;
- pyAgrum: one ``LazyPropagation`` per network; per case ``setEvidence``, one
  ``makeInference``, then ``posterior`` of every variable.

Medians per case. Exactness: the largest |Δ| between ``posteriors`` and the per-variable
answers, and between ``posteriors`` and pyAgrum. Run ``python benchmarks/bn_posteriors.py``;
it rewrites its section of docs/benchmarks.md. Timings on a shared 2-core machine vary
by tens of percent between runs.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import pyagrum as gum  # noqa: E402
from benchmarks._bnlearn import MODELS  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks.bn_inference import load_pyagrum  # noqa: E402

import bayesmap.bn as bn  # noqa: E402
from bayesmap.bn.plans import QueryKind  # noqa: E402

NETWORKS = [
    "asia",
    "alarm",
    "child",
    "insurance",
    "water",
    "hailfinder",
    "hepar2",
    "win95pts",
    "pathfinder",
    "andes",
    "pigs",
    "munin1",
]
N_CASES = 5
N_EVIDENCE = 3


def cases(net: bn.BayesNet, rng: np.random.Generator) -> list[tuple[dict[str, str], ...]]:
    """Per case two evidence values of one pattern (first ask, warm ask)."""
    draws = net.copy().sample(2 * N_CASES, rng=rng)
    names = list(net.variables)
    out = []
    for k in range(N_CASES):
        chosen = rng.choice(len(names), size=N_EVIDENCE, replace=False)
        out.append(
            tuple(
                {names[j]: net.states(names[j])[int(draws[2 * k + i, j])] for j in chosen}
                for i in range(2)
            )
        )
    return out


def measure(name: str, rng: np.random.Generator) -> dict[str, Any]:
    net = bn.read(MODELS / f"{name}.bif.gz")
    g, _ = load_pyagrum(name, net)
    questions = cases(net, rng)
    first, warm, loop, theirs = [], [], [], []
    diff_loop = diff_pyagrum = 0.0
    methods = set()
    engine = gum.LazyPropagation(g)
    for one, two in questions:
        start = time.perf_counter()
        net.posteriors(one)
        first.append(time.perf_counter() - start)
        start = time.perf_counter()
        answers = net.posteriors(two)
        warm.append(time.perf_counter() - start)
        plan = net._engine.plan(  # the method chosen for this pattern (benchmark peeks)
            QueryKind.WHOLE,
            tuple(v for v in range(len(net)) if net.variables[v] not in two),
            frozenset(net.variables.index(v) for v in two),
        )
        methods.add("two-pass" if plan.cache.two_pass_pays else "per variable")
        start = time.perf_counter()
        singles = {v: net.posterior(v, two) for v in net.variables if v not in two}
        loop.append(time.perf_counter() - start)
        start = time.perf_counter()
        engine.setEvidence(two)
        engine.makeInference()
        peer = {v: engine.posterior(v).toarray() for v in net.variables}
        theirs.append(time.perf_counter() - start)
        for v, posterior in answers.items():
            ours = np.array(list(posterior.values()))
            diff_loop = max(diff_loop, float(np.abs(ours - list(singles[v].values())).max()))
            diff_pyagrum = max(diff_pyagrum, float(np.abs(ours - peer[v]).max()))
    ms = {
        k: 1e3 * statistics.median(v)
        for k, v in {"first": first, "warm": warm, "loop": loop, "pyagrum": theirs}.items()
    }
    return {
        "network": name,
        "variables": len(net),
        **ms,
        "speedup": ms["pyagrum"] / ms["warm"],
        "vs_loop": ms["loop"] / ms["warm"],
        "diff_loop": diff_loop,
        "diff_pyagrum": diff_pyagrum,
        "method": "/".join(sorted(methods)),
    }


def main() -> None:
    rng = np.random.default_rng(2026)
    rows = []
    for name in NETWORKS:
        row = measure(name, rng)
        rows.append(row)
        print(
            f"{name}: warm {row['warm']:.2f} ms, pyAgrum {row['pyagrum']:.2f} ms "
            f"({row['speedup']:.2f}x), loop {row['loop']:.2f} ms, {row['method']}",
            flush=True,
        )
    lines = [
        "## All posteriors at once (`benchmarks/bn_posteriors.py`)",
        "",
        f"Machine: {machine()} (shared by several jobs: timings vary by tens of percent). "
        f"{N_CASES} cases per network, {N_EVIDENCE} observed variables each; medians per "
        "case of the posterior of every unobserved variable. *first*: the pattern's first "
        "question; *warm*: asked again with other values; *loop*: one `posterior` per "
        "variable (warm); pyAgrum: `setEvidence`, one `makeInference`, every `posterior`, "
        "on one `LazyPropagation` per network. |Δ|: largest difference from the "
        "per-variable answers and from pyAgrum. *method*: what `posteriors` chose.",
        "",
        "| network | vars | first ms | warm ms | loop ms | pyAgrum ms | × pyAgrum | × loop "
        "| |Δ| loop | |Δ| pyAgrum | method |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['network']} | {r['variables']} | {r['first']:.1f} | {r['warm']:.2f} | "
            f"{r['loop']:.2f} | {r['pyagrum']:.2f} | {r['speedup']:.2f} | {r['vs_loop']:.2f} | "
            f"{r['diff_loop']:.1e} | {r['diff_pyagrum']:.1e} | {r['method']} |"
        )
    met = [r["network"] for r in rows if r["speedup"] >= 2.0]
    missed = [f"{r['network']} ({r['speedup']:.2f}×)" for r in rows if r["speedup"] < 2.0]
    lines += [
        "",
        f"Target ≥ 2× pyAgrum: met on {', '.join(met) or 'none'}; missed on "
        f"{', '.join(missed) or 'none'}. Not run here (hours on this machine): link, "
        "munin, munin2–4, diabetes, mildew, barley.",
    ]
    update_section("bn_posteriors", "\n".join(lines))


if __name__ == "__main__":
    main()
