"""Start-up time of ``import bayesmap.bn`` and of the ``bayesmap`` command.

Each command runs ``N_RUNS`` times in a fresh interpreter, with Python's bytecode cache on
(as after ``pip install``, even if this shell sets ``PYTHONDONTWRITEBYTECODE``); the table
gives the best wall time and the best CPU time (user + system, from ``os.wait4``) of the
runs. ``python -c pass``, ``import numpy`` and ``import pyagrum`` are the yardsticks.
Targets (issue 15): ``import bayesmap.bn`` under 0.2 s, ``bayesmap --help`` and
``bayesmap bn ...`` commands under 0.5 s. The verdict is on the best wall time, which is
what a user waits for: the CPU time adds the threads OpenBLAS starts with numpy, which run
beside the import rather than delay it (``import numpy`` alone takes more CPU time than
wall time). The best of nine runs drops most of what other jobs add, but not all: the load
average is printed with the table, and a verdict taken under load is provisional. A last
row times bayesmap's own part of the import inside the interpreter (``import numpy`` first,
then the clocks around ``import bayesmap.bn``): it leaves out the interpreter's and numpy's
start, which on a busy machine move more than that part weighs. Run
``python benchmarks/bn_startup.py``; it rewrites its section of docs/benchmarks.md.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import pgmpy  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402

N_RUNS = 9
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
PYTHON = sys.executable
BAYESMAP = str(Path(sys.executable).with_name("bayesmap"))
ALARM = str(Path(pgmpy.__file__).parent / "utils" / "example_models" / "alarm.bif.gz")
COMMANDS: list[tuple[str, list[str], float | None]] = [
    ("python -c pass", [PYTHON, "-c", "pass"], None),
    ("python -c 'import numpy'", [PYTHON, "-c", "import numpy"], None),
    ("python -c 'import pyagrum'", [PYTHON, "-c", "import pyagrum"], None),
    ("python -c 'import bayesmap.bn'", [PYTHON, "-c", "import bayesmap.bn"], 0.2),
    (
        "python -c 'from bayesmap.bn import read'",
        [PYTHON, "-c", "from bayesmap.bn import read"],
        None,
    ),
    ("bayesmap --version", [BAYESMAP, "--version"], 0.5),
    ("bayesmap --help", [BAYESMAP, "--help"], 0.5),
    ("bayesmap bn --help", [BAYESMAP, "bn", "--help"], 0.5),
    ("bayesmap bn info alarm --json", [BAYESMAP, "bn", "info", ALARM, "--json"], 0.5),
    (
        "bayesmap bn query alarm -t HYPOVOLEMIA -e BP=LOW",
        [BAYESMAP, "bn", "query", ALARM, "-t", "HYPOVOLEMIA", "-e", "BP=LOW"],
        0.5,
    ),
]


OWN_PART = (
    "import time, numpy\n"
    "wall, cpu = time.perf_counter(), time.process_time()\n"
    "import bayesmap.bn\n"
    "print(time.perf_counter() - wall, time.process_time() - cpu)\n"
)
"""``import bayesmap.bn`` beyond numpy, clocked inside the interpreter."""


def own_part() -> tuple[float, float]:
    """Wall and CPU seconds of ``import bayesmap.bn`` after ``import numpy``, in one run."""
    result = subprocess.run(
        [PYTHON, "-c", OWN_PART], capture_output=True, text=True, env=ENV, check=True
    )
    wall, cpu = result.stdout.split()
    return float(wall), float(cpu)


def run(command: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of one run."""
    start = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=ENV)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    if status != 0:
        raise SystemExit(
            f"{command} failed: {process.stderr.read().decode() if process.stderr else ''}"
        )
    return wall, usage.ru_utime + usage.ru_stime


def main() -> None:
    load_start = os.getloadavg()[0]
    rows = []
    for label, command, target in COMMANDS:
        run(command)  # warm the file cache and the bytecode
        walls, cpus = zip(*(run(command) for _ in range(N_RUNS)), strict=True)
        wall, cpu = min(walls), min(cpus)
        verdict = "" if target is None else ("met" if wall < target else "missed")
        rows.append((label, wall, cpu, target, verdict))
        print(f"{label}: wall {wall:.3f} s, cpu {cpu:.3f} s {verdict}", flush=True)
    own_part()
    walls, cpus = zip(*(own_part() for _ in range(N_RUNS)), strict=True)
    own = (min(walls), min(cpus))
    print(f"import bayesmap.bn after numpy: wall {own[0]:.4f} s, cpu {own[1]:.4f} s", flush=True)
    busy = max(load_start, os.getloadavg()[0]) >= (os.cpu_count() or 1)
    if busy:  # other jobs queue for the cores: a wall time says more about them than us
        rows = [(*row[:4], row[4] and f"{row[4]}?") for row in rows]
    lines = [
        "## Start-up (`benchmarks/bn_startup.py`)",
        "",
        f"Machine: {machine()}, shared with other jobs (1-minute load average "
        f"{load_start:.1f} at the start, {os.getloadavg()[0]:.1f} at the end; under load the "
        f"wall times are inflated). Best of {N_RUNS} fresh interpreters, bytecode cached. The "
        "verdict is on wall time, what a user waits for; the CPU column adds the threads "
        "OpenBLAS starts with numpy, which run beside the import (numpy alone spends more "
        "CPU than wall time)."
        + (
            " The load average exceeded the number of cores, so the verdicts carry a "
            "question mark: they need a run on an idle machine."
            if busy
            else ""
        ),
        "",
        "| command | wall s | CPU s | target | |",
        "|---|---:|---:|---:|---|",
    ]
    for label, wall, cpu, target, verdict in rows:
        shown = "" if target is None else f"< {target}"
        lines.append(f"| `{label}` | {wall:.3f} | {cpu:.3f} | {shown} | {verdict} |")
    lines.append(
        f"| `import bayesmap.bn` after `import numpy`, timed inside the interpreter | "
        f"{own[0]:.4f} | {own[1]:.4f} |  |  |"
    )
    update_section("bn_startup", "\n".join(lines))


if __name__ == "__main__":
    main()
