"""Generated C: size on x86-64 and Cortex-M4, and µs per question in C vs the Python engine.

For each network — the bnlearn asia, alarm, child, insurance and hailfinder shipped with
pgmpy, and the rover's decision network — one question pattern: for bnlearn, one random
target, 4 random variables that may be observed and one soft-evidence variable (seeded); for
the rover, ``P(Motors | IR_k, ProbabilityMap)`` over its rangers with its data nodes. 100 random
questions (evidence from forward samples, each slot observed with probability 0.6).

- size: ``size -A`` of the generated ``.c`` compiled alone — ``.text`` (code), ``.rodata``
  (the CPTs and priors) and ``.bss`` (the work array) — with the host ``cc -O2`` and with
  ``arm-none-eabi-gcc -Os -mcpu=cortex-m4 -mthumb`` (Q16.16 soft float; float with the
  FPv4 single-precision FPU);
- µs per question: the C driver timed with ``clock()`` over enough repeats of all 100
  questions (the data nodes' tables are inputs, prepared outside the timing), against the
  Python engine's ``posterior_fixed`` (Q16.16) and ``posterior`` (float64) on the same
  questions, each pattern warm;
- agreement: how many of the C answers equal the engine's raw Q16.16 integers.

Run ``python benchmarks/bn_codegen.py`` (it needs gcc; the Cortex-M4 columns need Debian's
gcc-arm-none-eabi).
"""

from __future__ import annotations

import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402
from tests.bn.codegen.conftest import (  # noqa: E402
    Question,
    bnlearn,
    engine_answer,
    pattern,
    random_question,
)

from bayesmap.bn import BayesNet  # noqa: E402
from bayesmap.bn.codegen import CSources, SoftNetwork, generate  # noqa: E402
from bayesmap.bn.codegen.native import (  # noqa: E402
    DriverQuestion,
    ObjectSize,
    object_size,
    run_driver,
)
from bayesmap.bn.fixed_point import QFormat  # noqa: E402
from bayesmap.rover.network import DecisionNetwork  # noqa: E402
from bayesmap.rover.params import RoverParams  # noqa: E402

N_QUESTIONS = 100
CORTEX_M4 = ("arm-none-eabi-gcc", "-Os", "-mcpu=cortex-m4", "-mthumb")
M4_FLOAT = {"q16.16": ("-mfloat-abi=soft",), "float": ("-mfloat-abi=hard", "-mfpu=fpv4-sp-d16")}


def rover_network(rng: np.random.Generator) -> tuple[BayesNet, Callable[[], None]]:
    """The decision network, and a function that draws new readings and map values."""
    decision = DecisionNetwork(RoverParams())
    m = decision.params.n_headings

    def draw() -> None:
        decision.inputs_.ranges = rng.uniform(0.1, decision.params.r_max, decision.n_sensors)
        p_t = rng.random(m)
        decision.inputs_.p_t = p_t / p_t.sum()
        decision.inputs_.p_o = np.minimum(rng.random(m), 0.99)

    draw()
    return decision.net, draw


def questions(
    net: BayesNet, code: CSources, rng: np.random.Generator, draw: Callable[[], None] | None
) -> tuple[list[Question], list[dict[str, np.ndarray]]]:
    """Random questions, and the data nodes' tables of each (as the engine asks them)."""
    asked, tables = [], []
    compiled = net._engine.compiled
    for _ in range(N_QUESTIONS):
        if draw is not None:
            draw()
        question = random_question(net, code, rng, 1 << 16)
        evidence = {
            compiled.id(v): s for v, s in zip(code.evidence, question.slots, strict=True) if s >= 0
        }
        names = compiled.evidence_names(evidence)
        tables.append({v: compiled.table(compiled.id(v), names) for v in code.data})
        asked.append(question)
    return asked, tables


def time_engine(call: Callable[[], object]) -> float:
    """Seconds per call (median of 5 passes after a warm-up)."""
    call()
    runs = []
    for _ in range(5):
        start = time.perf_counter()
        call()
        runs.append(time.perf_counter() - start)
    return statistics.median(runs)


def one_network(name: str, rng: np.random.Generator, work: Path) -> dict[str, object]:
    draw = None
    if name == "rover":
        net, draw = rover_network(rng)
        rangers = sorted(v for v in net.variables if v.startswith("IR_"))
        targets, evidence, soft = ["Motors"], [*rangers, "ProbabilityMap"], []
    else:
        net = bnlearn(name)
        targets, evidence, soft = pattern(net, rng, n_evidence=4, n_soft=1)
        targets = targets[:1]
    q = QFormat.parse("q16.16")
    row: dict[str, object] = {"network": name, "variables": len(net), "target": targets[0]}
    codes = {
        arith: generate(net, targets, evidence, arith, soft=soft, name=f"{name}_{arith[0]}")
        for arith in ("q16.16", "float")
    }
    fixed = codes["q16.16"]
    row["functions"] = fixed.functions
    row["x86"] = object_size(fixed, work / "x86", build=("cc", "-O2"))
    if shutil.which("arm-none-eabi-gcc"):
        for arith, code in codes.items():
            row[f"m4_{arith}"] = object_size(
                code,
                work / f"m4_{arith}",
                build=(*CORTEX_M4, *M4_FLOAT[arith]),
                tools="arm-none-eabi-",
            )
    asked, tables = questions(net, fixed, rng, draw)
    soft_net = SoftNetwork.build(net, soft)
    driver_questions = [
        DriverQuestion(
            question.target,
            question.slots,
            {v: np.rint(x * q.scale).astype(np.int64) for v, x in question.soft.items()},
            {v: q.quantise(t).raw for v, t in table.items()},
        )
        for question, table in zip(asked, tables, strict=True)
    ]
    probe = run_driver(fixed, driver_questions, work / "probe", repeat=1)
    repeat = max(1, int(0.3e9 / max(probe.ns_per_question * N_QUESTIONS, 1.0)))
    result = run_driver(fixed, driver_questions, work / "timed", repeat=repeat)
    row["c_us"] = result.ns_per_question / 1e3

    def ask_all(fixed_point: bool) -> Callable[[], None]:
        def run() -> None:
            for question in asked:
                engine_answer(soft_net, fixed, question, "q16.16" if fixed_point else "double")

        return run

    if draw is None:
        row["py_fixed_us"] = time_engine(ask_all(True)) / N_QUESTIONS * 1e6
        row["py_float_us"] = time_engine(ask_all(False)) / N_QUESTIONS * 1e6
        same = 0
        for question, got in zip(asked, result.answers, strict=True):
            same += bool(np.array_equal(got, engine_answer(soft_net, fixed, question, "q16.16")))
        row["equal"] = same
    else:
        row.update(rover_engine(net, fixed, asked, tables, result.answers))
    return row


def rover_engine(
    net: BayesNet,
    code: CSources,
    asked: list[Question],
    tables: list[dict[str, np.ndarray]],
    answers: list[np.ndarray],
) -> dict[str, object]:
    """The rover's engine times and agreement, each question's data tables pinned first."""
    holders: dict[str, dict[str, np.ndarray]] = {v: {} for v in code.data}
    for v in code.data:
        net.set_source(v, _fixed_table(holders[v]))

    def evidence(question: Question) -> dict[str, int]:
        return {v: s for v, s in zip(code.evidence, question.slots, strict=True) if s >= 0}

    def run(fixed_point: bool) -> Callable[[], None]:
        def go() -> None:
            for question, table in zip(asked, tables, strict=True):
                for v in code.data:
                    holders[v]["table"] = table[v]
                if fixed_point:
                    net.posterior_fixed(question.target, evidence(question), "q16.16")
                else:
                    net.posterior(question.target, evidence(question))

        return go

    out: dict[str, object] = {
        "py_fixed_us": time_engine(run(True)) / N_QUESTIONS * 1e6,
        "py_float_us": time_engine(run(False)) / N_QUESTIONS * 1e6,
    }
    same = 0
    for question, table, got in zip(asked, tables, answers, strict=True):
        for v in code.data:
            holders[v]["table"] = table[v]
        want = net.posterior_fixed(question.target, evidence(question), "q16.16").raw
        same += bool(np.array_equal(got, want))
    out["equal"] = same
    return out


def _fixed_table(holder: dict[str, np.ndarray]) -> Callable[[object], np.ndarray]:
    def source(evidence: object) -> np.ndarray:
        del evidence
        return holder["table"]

    return source


def _size(size: object) -> str:
    if not isinstance(size, ObjectSize):
        return "–"
    return f"{size.code:,} / {size.const:,} / {size.ram:,}"


def main() -> None:
    rng = np.random.default_rng(2026)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name in ("asia", "alarm", "child", "insurance", "hailfinder", "rover"):
            print(f"{name} ...", file=sys.stderr)
            rows.append(one_network(name, rng, Path(folder) / name))
    lines = [
        "## Generated C (`bayesmap bn codegen`)",
        "",
        f"`python benchmarks/bn_codegen.py` on {machine()} — a machine shared with other "
        "jobs, so timings are indicative. One pattern per network (1 target, 4 variables "
        "that may be observed, 1 soft-evidence variable; the rover: Motors given its "
        "rangers and the map node, with its data nodes as inputs), 100 random questions. "
        "Sizes are bytes of code / constant data / RAM (the static work array) of the "
        "generated `.c` alone, from `size -A`.",
        "",
        "| network | vars | target | C functions | x86-64 -O2 Q16.16 | Cortex-M4 -Os Q16.16 "
        "| Cortex-M4 -Os float (FPU) | C µs/question | engine Q16.16 µs | engine float µs "
        "| C = engine (raw) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['network']} | {r['variables']} | {r['target']} | {r['functions']} "
            f"| {_size(r['x86'])} | {_size(r.get('m4_q16.16'))} | {_size(r.get('m4_float'))} "
            f"| {r['c_us']:.2f} | {r['py_fixed_us']:.0f} | {r['py_float_us']:.0f} "
            f"| {r['equal']}/{N_QUESTIONS} |"
        )
    lines += [
        "",
        "C µs/question is the x86-64 build timed in C (`clock()`), not through ctypes; the "
        "engine columns are the Python engine with its plan for the pattern already cached. "
        "Every pattern function of the pattern is compiled in (2^4 per target here), so "
        "the code size covers every subset of observed variables.",
    ]
    text = "\n".join(lines)
    print(text)
    update_section("bn_codegen", text)


if __name__ == "__main__":
    main()
