"""Instructions per cold and warm question, two source trees: an A/B the machine's load
cannot move.

On a shared machine a timed A/B of changes worth a few per cent drowns in noise (identical
code measures ±10 % apart in ``benchmarks/bn_ab.py``). Here each tree answers the same
questions under Valgrind's ``callgrind``, which counts the machine instructions executed
(Ir): the count is the same whatever else runs. Per network and tree, two runs of one process
each — one answering ``--questions`` new patterns (cold) or re-asked patterns with new
values (warm) after the set-up, one stopping after the set-up — and the difference divided
by the number of questions is the instructions per question. Instructions are not time
(cache misses and numpy's arithmetic weigh differently), but on these small questions,
which are Python bookkeeping, they track CPU time closely.

    python benchmarks/bn_cold_ir.py 4e2828d . --networks alarm   # A and B: a commit or a tree

``--count steps`` counts Python bytecode instructions instead (``sys.settrace`` opcode
events, no valgrind; seconds per network): the interpreter's share, which is most of a cold
question; it too is the same whatever else runs.

Instructions need ``valgrind``; each run takes 1–5 minutes on a busy machine. Writes the
``bn_cold_ir`` section of docs/benchmarks.md (``bn_cold_steps`` with ``--count steps``;
``--no-write`` to only print).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from contextlib import ExitStack
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

# The worker uses only the public API old and new trees share; PYTHONHASHSEED is fixed so
# that both trees hash names alike.
WORKER = r"""
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, sys.argv[1])
import bayesmap.bn as bn

src, models, name, mode, n = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5])
net = bn.read(Path(models) / f"{name}.bif.gz")
rng = np.random.default_rng(20261201)
names = list(net.variables)
total = 201
draws = net.copy().sample(2 * total, rng=rng)
questions = []
for k in range(total):
    chosen = [str(v) for v in rng.choice(names, size=4, replace=False)]
    values = [
        {v: net.states(v)[int(draws[2 * k + j, names.index(v)])] for v in chosen[1:]}
        for j in range(2)
    ]
    questions.append((chosen[0], values))
(t0, (e0, _)), questions = questions[0], questions[1:]
net.posterior(t0, e0)  # the network's first question: set-up, counted in both runs
if mode == "warm":
    for target, values in questions[:n]:
        net.posterior(target, values[0])  # set-up: the patterns asked once
asked = [(target, values[mode == "warm"]) for target, values in questions[:n]]
steps = 0


def tracer(frame, event, arg):
    global steps
    frame.f_trace_opcodes = True
    if event == "opcode":
        steps += 1
    return tracer


if sys.argv[6:] == ["steps"]:  # count the questions' bytecode instructions
    sys.settrace(tracer)
for target, evidence in asked:
    net.posterior(target, evidence)
sys.settrace(None)
print(steps)
"""


def models_dir() -> Path:
    """The bnlearn networks shipped with pgmpy (located without importing it)."""
    import importlib.util

    spec = importlib.util.find_spec("pgmpy")
    if spec is None or spec.origin is None:
        raise SystemExit("bn_cold_ir: pgmpy (the bnlearn networks) is not installed")
    return Path(spec.origin).parent / "utils" / "example_models"


def instructions(tree: Path, name: str, mode: str, n: int) -> int:
    """Instructions (Ir) callgrind counts for one worker process."""
    command = [
        "valgrind",
        "--tool=callgrind",
        "--callgrind-out-file=/dev/null",
        sys.executable,
        "-c",
        WORKER,
        str(tree / "src"),
        str(models_dir()),
        name,
        mode,
        str(n),
    ]
    env = dict(os.environ, PYTHONPATH="", PYTHONHASHSEED="0")
    done = subprocess.run(command, capture_output=True, text=True, env=env)
    found = re.search(r"Collected : (\d+)", done.stderr)
    if done.returncode != 0 or found is None:
        tail = done.stderr.strip().splitlines()[-3:]
        raise SystemExit(f"bn_cold_ir: {tree} on {name} failed: {' '.join(tail)}")
    return int(found.group(1))


def steps(tree: Path, name: str, mode: str, n: int) -> int:
    """Python bytecode instructions the worker's questions execute (``sys.settrace``)."""
    command = [sys.executable, "-c", WORKER, str(tree / "src"), str(models_dir())]
    env = dict(os.environ, PYTHONPATH="", PYTHONHASHSEED="0")
    done = subprocess.run(
        [*command, name, mode, str(n), "steps"], capture_output=True, text=True, env=env
    )
    if done.returncode != 0:
        tail = done.stderr.strip().splitlines()[-3:]
        raise SystemExit(f"bn_cold_ir: {tree} on {name} failed: {' '.join(tail)}")
    return int(done.stdout.split()[-1])


def per_question(
    tree: Path, name: str, mode: str, n: int, base: dict[Path, int], count: str
) -> float:
    """Instructions (or interpreter steps) per question of ``mode`` (for instructions, the
    set-up-only run is counted once per tree and subtracted)."""
    if count == "steps":
        return steps(tree, name, mode, n) / n
    if tree not in base:
        base[tree] = instructions(tree, name, "cold", 0)
    return (instructions(tree, name, mode, n) - base[tree]) / n


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", help="source tree A (the reference): a directory or a commit")
    parser.add_argument("b", help="source tree B: a directory or a commit")
    parser.add_argument("--networks", nargs="+", default=["alarm", "pathfinder", "win95pts"])
    parser.add_argument("--questions", type=int, default=100)
    parser.add_argument("--modes", nargs="+", default=["cold"], choices=["cold", "warm"])
    parser.add_argument(
        "--count",
        choices=["instructions", "steps"],
        default="instructions",
        help="machine instructions under valgrind, or Python bytecode instructions (seconds)",
    )
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    if args.count == "instructions" and shutil.which("valgrind") is None:
        raise SystemExit("bn_cold_ir: valgrind is not installed")
    from benchmarks._report import machine, update_section
    from benchmarks._trees import source_tree

    with ExitStack() as stack:
        (tree_a, label_a), (tree_b, label_b) = (source_tree(t, stack) for t in (args.a, args.b))
        rows = []
        for name in args.networks:
            base: dict[Path, int] = {}
            for mode in args.modes:
                a, b = (
                    per_question(tree, name, mode, args.questions, base, args.count)
                    for tree in (tree_a, tree_b)
                )
                rows.append((name, mode, a, b))
                unit = "Ir" if args.count == "instructions" else "steps"
                print(
                    f"{name:11s} {mode}: A {a:,.0f}, B {b:,.0f} {unit}/question ({b / a - 1:+.1%})"
                )
    if args.count == "instructions":
        section, unit = "bn_cold_ir", "Ir"
        title = "Instructions per question, two source trees (`benchmarks/bn_cold_ir.py`)"
        what = "Machine instructions (Valgrind callgrind's Ir)"
    else:
        section, unit = "bn_cold_steps", "steps"
        title = (
            "Interpreter steps per question, two source trees "
            "(`benchmarks/bn_cold_ir.py --count steps`)"
        )
        what = "Python bytecode instructions (`sys.settrace` opcode events)"
    lines = [
        f"## {title}",
        "",
        f"A = {label_a}, B = {label_b}. {what} "
        f"per question, {args.questions} questions (a target and 3 observed variables, "
        "values forward-sampled) after the network's first question; *cold*: each a new "
        "pattern, *warm*: the same patterns re-asked with other values. Independent of the "
        "machine's load.",
        "",
        f"| network | mode | A ({unit}) | B ({unit}) | B/A−1 |",
        "|---|---|--:|--:|--:|",
    ]
    for name, mode, a, b in rows:
        lines.append(f"| {name} | {mode} | {a:,.0f} | {b:,.0f} | {b / a - 1:+.1%} |")
    lines += [
        "",
        f"{machine()}. Rerun: `python benchmarks/bn_cold_ir.py A B` (each a source tree or a commit"
        + (", with `--count steps`)." if args.count == "steps" else ")."),
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        update_section(section, text)


if __name__ == "__main__":
    main()
