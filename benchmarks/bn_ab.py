"""A/B of exact-inference speed between two source trees of bayesmap (e.g. an old commit's
worktree and this one): did a change make single questions slower?

For each network, ``--patterns`` random questions (a target and 3 observed variables, the
values forward-sampled so the evidence is possible) are asked twice each: *cold* (the
pattern's first question: plan, pruning and order built) and *warm* (the same pattern with
other values). Each tree answers in a process of its own (its ``src`` first on ``sys.path``),
started fresh for each of ``--rounds`` rounds; both answer the same questions, and each
question goes to A and B one right after the other (which goes first alternates), so
that drift in the machine's load falls on both alike. Every process first asks one
untimed question of another pattern (the network-wide set-up, which
``benchmarks/bn_startup.py`` times). Reported: the median CPU time
(``time.process_time``) of the pooled questions per tree and mode, B/A − 1 of those
medians, and *paired*: the median over questions of B/A of each question's median.

    python benchmarks/bn_ab.py 65608c5 . --rounds 4   # A and B: a commit or a source tree

writes the ``bn_ab`` section of docs/benchmarks.md (``--no-write`` to only print).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from contextlib import ExitStack
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

NETWORKS = ["alarm", "child", "hailfinder", "win95pts", "pathfinder"]
N_EVIDENCE = 3

# The worker runs with a tree's src first on sys.path and uses only the public API that old
# and new trees share (bn.read, BayesNet.sample, BayesNet.posterior).
WORKER = r"""
import gc, json, sys, time
from pathlib import Path
import numpy as np
sys.path.insert(0, sys.argv[1])
import pgmpy
import bayesmap.bn as bn

src, name, mode, path = sys.argv[1:5]
net = bn.read(Path(pgmpy.__file__).parent / "utils" / "example_models" / f"{name}.bif.gz")
if mode == "questions":
    n, seed = int(sys.argv[5]), int(sys.argv[6])
    rng = np.random.default_rng(seed)
    names = list(net.variables)
    draws = net.copy().sample(2 * n + 2, rng=rng)
    column = {v: draws[:, i] for i, v in enumerate(names)}
    questions = []
    for k in range(n + 1):
        chosen = [str(v) for v in rng.choice(names, size=4, replace=False)]
        values = [
            {v: net.states(v)[int(column[v][2 * k + j])] for v in chosen[1:]} for j in range(2)
        ]
        questions.append([chosen[0], values])
    Path(path).write_text(json.dumps(questions))
    sys.exit(0)
questions = json.loads(Path(path).read_text())
(t0, (e0, _)), questions = questions[0], questions[1:]
net.posterior(t0, e0)
clock = time.process_time
print("ready", flush=True)
for line in sys.stdin:  # "cold K" or "warm K": ask question K, print its CPU seconds
    mode, k = line.split()
    target, values = questions[int(k)]
    evidence = values[0 if mode == "cold" else 1]
    start = clock()
    net.posterior(target, evidence)
    print(clock() - start, flush=True)
"""


def _command(tree: Path, *args: str) -> list[str]:
    return [sys.executable, "-c", WORKER, str(tree / "src"), *args]


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH="")


def write_questions(tree: Path, name: str, path: Path, patterns: int, seed: int) -> None:
    """Draw the questions of network ``name`` once (with ``tree``) into ``path``."""
    args = (name, "questions", str(path), str(patterns), str(seed))
    done = subprocess.run(_command(tree, *args), capture_output=True, text=True, env=_env())
    if done.returncode != 0:
        raise SystemExit(f"bn_ab: {tree} could not draw questions: {done.stderr.strip()}")


def compare(
    trees: list[Path], networks: list[str], patterns: int, rounds: int, seed: int
) -> dict[str, dict[str, list[list[float]]]]:
    """Per network and mode, each tree's CPU seconds per question and round (question-major).

    Each round starts one fresh worker per tree; the two are asked the same question one
    right after the other (which goes first alternates), so both see the same load.
    """
    times: dict[str, dict[str, list[list[float]]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k, name in enumerate(networks):
            questions = Path(tmp) / f"{name}.json"
            write_questions(trees[0], name, questions, patterns, seed + k)
            pooled: dict[str, list[list[float]]] = {"cold": [[], []], "warm": [[], []]}
            for r in range(rounds):
                workers = [
                    subprocess.Popen(
                        _command(tree, name, "time", str(questions)),
                        stdin=subprocess.PIPE,
                        stdout=subprocess.PIPE,
                        text=True,
                        env=_env(),
                    )
                    for tree in trees
                ]
                for worker, tree in zip(workers, trees, strict=True):
                    assert worker.stdout is not None
                    if worker.stdout.readline().strip() != "ready":
                        raise SystemExit(f"bn_ab: the worker on {tree} did not start")
                for mode in ("cold", "warm"):
                    for q in range(patterns):
                        first = (q + r) % 2
                        for i in (first, 1 - first):
                            stdin, stdout = workers[i].stdin, workers[i].stdout
                            assert stdin is not None and stdout is not None
                            stdin.write(f"{mode} {q}\n")
                            stdin.flush()
                            pooled[mode][i].append(float(stdout.readline()))
                for worker in workers:
                    assert worker.stdin is not None
                    worker.stdin.close()
                    worker.wait()
                print(f"  {name}: round {r + 1}/{rounds}", file=sys.stderr, flush=True)
            times[name] = pooled
    return times


def table(times: dict[str, dict[str, list[list[float]]]], patterns: int) -> str:
    """Median ms per tree and mode, B/A − 1 of the medians, and the median over questions of
    B/A of each question's median time (paired: the same questions, the same moments)."""
    lines = [
        "| network | cold A (ms) | cold B (ms) | cold B/A−1 | cold paired | "
        "warm A (ms) | warm B (ms) | warm B/A−1 | warm paired |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for name, pooled in times.items():
        cells = [name]
        for mode in ("cold", "warm"):
            a, b = (statistics.median(x) * 1e3 for x in pooled[mode])
            per_question = [
                [statistics.median(x[q::patterns]) for q in range(patterns)] for x in pooled[mode]
            ]
            paired = statistics.median(
                qb / qa for qa, qb in zip(*per_question, strict=True) if qa > 0
            )
            cells += [f"{a:.3f}", f"{b:.3f}", f"{b / a - 1:+.1%}", f"{paired - 1:+.1%}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="source tree A (the reference): a directory or a commit")
    parser.add_argument("b", help="source tree B: a directory or a commit")
    parser.add_argument("--networks", nargs="+", default=NETWORKS)
    parser.add_argument("--patterns", type=int, default=60)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--seed", type=int, default=13)
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    from benchmarks._report import machine, update_section
    from benchmarks._trees import source_tree

    with ExitStack() as stack:
        (tree_a, label_a), (tree_b, label_b) = (source_tree(t, stack) for t in (args.a, args.b))
        load_before = os.getloadavg()
        times = compare([tree_a, tree_b], args.networks, args.patterns, args.rounds, args.seed)
        load_after = os.getloadavg()

    text = (
        "## Single questions, two source trees (`benchmarks/bn_ab.py`)\n\n"
        f"A = {label_a}, B = {label_b}. Median CPU time "
        f"(`time.process_time`) of {args.patterns} random patterns × {args.rounds} "
        "rounds (a fresh process per tree and round; a target and 3 observed variables; "
        "cold = the pattern's first question, warm = the same pattern with other values; "
        "each question asked of A and B back to back). *paired*: median over the "
        "questions of B/A of each question's median time. "
        f"Load average {load_before[0]:.2f} before, {load_after[0]:.2f} after (other jobs "
        "inflate CPU time less than wall time, but not to nothing).\n\n"
        f"{table(times, args.patterns)}\n\n"
        f"{machine()}. Rerun: `python benchmarks/bn_ab.py A B` (each a source tree or a "
        "commit, e.g. `python benchmarks/bn_ab.py 65608c5 .`).\n"
    )
    print(text)
    if not args.no_write:
        update_section("bn_ab", text)


if __name__ == "__main__":
    main()
