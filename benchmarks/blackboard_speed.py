"""Benchmark: CPU time of whole fused whisker-mapper runs (issue 9's speed targets).

Each run is the whole 400-pose tour (or a world file's tour) through one
:class:`~bayesmap.blackboard.fused.FusedMapper` and its final pass
(:meth:`~bayesmap.blackboard.fused.FusedMapper.finish`), timed in CPU seconds of this
process (``time.process_time``: on a shared machine wall time measures the neighbours).
Runs, one after the other in this process:

- the shipped world (``reproduce blackboard``: ``whisker-tables-v1``, seed 2011) under the
  three conditions, with the experiment's own sensor and chain streams;
- generated stress worlds (:func:`bayesmap.sim.whisker_worlds.generate_world`, generator
  seeds ``--worlds``, default 9317 and 4: 7 tables in a 4.0 × 9.0 m arena and 10 tables in
  a 9.7 × 7.1 m one) under ``--conditions`` (default normal and noisy), run seed 0, as
  ``bayesmap blackboard run --world`` runs them;
- the slowest runs of the accuracy grid (``benchmarks/blackboard.py``): its worlds and run
  seeds ``--grid`` (default ``3:0 3:2 2:2``: world 3, seeds 0 and 2, and world 2, seed 2,
  small arenas of 4.5 × 5.4 m with 4 tables and 5.6 × 5.8 m with 6), noisy, so the table
  holds the worst case, not only the shipped world.

Reported per run: CPU seconds of the whole run and of the final pass, the median and 95th
percentile of the CPU time of each pose's step [ms] (a loaded machine still inflates them), fused
precision and recall, and the load average at the start and end. Targets: every run under
30 s, median pose under 50 ms, precision and recall unchanged (1.00). The table goes to
docs/benchmarks.md (section ``blackboard_speed``) and docs/blackboard-results.md (section
``blackboard-speed``). Run from the repository root as ``python benchmarks/blackboard_speed.py``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks.blackboard import world_of  # noqa: E402

from bayesmap.blackboard.fused import FusedMapper  # noqa: E402
from bayesmap.experiments import blackboard  # noqa: E402
from bayesmap.experiments.blackboard_world import fused_world_run  # noqa: E402
from bayesmap.sim.whisker_worlds import generate_world  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
RESULTS_DOC = ROOT / "docs" / "blackboard-results.md"
TARGET_RUN_S, TARGET_POSE_MS = 30.0, 50.0


class _CpuClock:
    """CPU seconds of each call of a :class:`FusedMapper` method (wraps it while alive)."""

    def __init__(self, method: str) -> None:
        self.calls: list[float] = []
        self._method = method
        self._original = getattr(FusedMapper, method)

    def __enter__(self) -> _CpuClock:
        original = self._original

        def timed(mapper: FusedMapper, *args: Any, **kwargs: Any) -> Any:
            tic = time.process_time()
            try:
                return original(mapper, *args, **kwargs)
            finally:
                self.calls.append(time.process_time() - tic)

        setattr(FusedMapper, self._method, timed)
        return self

    def __exit__(self, *_: object) -> None:
        setattr(FusedMapper, self._method, self._original)


def shipped_run(condition: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The fused run of ``reproduce blackboard`` for one condition (its world and streams)."""
    return blackboard.fused_condition(condition)


def measure(name: str, condition: str, runner: Any) -> dict[str, Any]:
    """One run: its CPU seconds, per-pose times, precision and recall, load averages."""
    load_before = os.getloadavg()[0]
    with _CpuClock("finish") as finish, _CpuClock("step") as step:
        result, scores = runner()
    step_ms = 1e3 * np.asarray(step.calls)
    row = {
        "world": name,
        "condition": condition,
        "poses": len(step_ms),
        "cpu_s": float(result["cpu_s"]),
        "finish_cpu_s": float(sum(finish.calls)),
        "median_ms": float(np.median(step_ms)),
        "p95_ms": float(np.percentile(step_ms, 95)),
        "wall_median_ms": float(np.median(result["step_ms"])),
        "precision": float(scores["fused_precision"]),
        "recall": float(scores["fused_recall"]),
        "load": (load_before, os.getloadavg()[0]),
    }
    print(
        f"{name} {condition}: {row['cpu_s']:.1f} s CPU (final pass {row['finish_cpu_s']:.1f} s), "
        f"median {row['median_ms']:.1f} ms, p95 {row['p95_ms']:.1f} ms CPU "
        f"(wall median {row['wall_median_ms']:.1f} ms), "
        f"precision {row['precision']:.2f}, recall {row['recall']:.2f}, "
        f"load {row['load'][0]:.1f}→{row['load'][1]:.1f}",
        flush=True,
    )
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of the runs, with each target met or missed."""
    lines = [
        "| world | condition | poses | CPU s (final pass) | median / p95 CPU ms per pose "
        "| precision / recall | load avg (start→end) | targets |",
        "|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        met = r["cpu_s"] < TARGET_RUN_S and r["median_ms"] < TARGET_POSE_MS
        lines.append(
            f"| {r['world']} | {r['condition']} | {r['poses']} | {r['cpu_s']:.1f} "
            f"({r['finish_cpu_s']:.1f}) | {r['median_ms']:.1f} / {r['p95_ms']:.1f} "
            f"| {r['precision']:.2f} / {r['recall']:.2f} "
            f"| {r['load'][0]:.1f}→{r['load'][1]:.1f} | {'met' if met else 'MISSED'} |"
        )
    return "\n".join(lines)


def write(rows: list[dict[str, Any]]) -> None:
    """The runs so far into both documents' sections."""
    note = (
        f"{machine()}. CPU seconds of this process (`time.process_time`), whole run and, in "
        "brackets, the final pass; per pose, the CPU milliseconds of each `step`. A loaded "
        "machine inflates even CPU time (shared caches and cores; the load average at each "
        "run's start and end is listed). "
        f"Targets: whole run under {TARGET_RUN_S:.0f} s, median pose under "
        f"{TARGET_POSE_MS:.0f} ms. `python benchmarks/blackboard_speed.py`"
    )
    update_section(
        "blackboard_speed", f"### Fused mapper speed (issue 9)\n\n{note}\n\n{table(rows)}\n"
    )
    update_section("blackboard-speed", f"{note}\n\n{table(rows)}\n", RESULTS_DOC)


def stress_worlds(seeds: list[int]) -> list[tuple[str, Any]]:
    """The generated stress worlds of ``seeds``, each with the name the tables show."""
    worlds = [generate_world(seed) for seed in seeds]
    return [
        (
            f"stress seed {seed} ({len(world.tables)} tables, "
            f"{world.arena[0]:.1f} × {world.arena[1]:.1f} m)",
            world,
        )
        for seed, world in zip(seeds, worlds, strict=True)
    ]


def grid_worlds(runs: list[str], plain: int = 4) -> list[tuple[str, Any, int]]:
    """The accuracy grid's worlds and run seeds ``WORLD:SEED``, each with its name."""
    out = []
    for run in runs:
        index, seed = (int(part) for part in run.split(":"))
        world = world_of(index, plain)
        name = (
            f"grid world {index} seed {seed} ({len(world.tables)} tables, "
            f"{world.arena[0]:.1f} × {world.arena[1]:.1f} m)"
        )
        out.append((name, world, seed))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, nargs="*", default=[9317, 4])
    parser.add_argument("--conditions", nargs="*", default=["normal", "noisy"])
    parser.add_argument("--shipped", nargs="*", default=["normal", "noiseless", "noisy"])
    parser.add_argument(
        "--grid", nargs="*", default=["3:0", "3:2", "2:2"], help="noisy grid runs WORLD:SEED"
    )
    args = parser.parse_args()
    runs: list[tuple[str, str, Any]] = [
        ("whisker-tables-v1", condition, lambda c=condition: shipped_run(c))
        for condition in args.shipped
    ]
    for name, world in stress_worlds(args.worlds):
        for condition in args.conditions:
            runs.append(
                (
                    name,
                    condition,
                    lambda w=world, c=condition, n=name: fused_world_run(w, c, 0, name=n)[1:],
                )
            )
    for name, world, seed in grid_worlds(args.grid):
        runs.append(
            (
                name,
                "noisy",
                lambda w=world, s=seed, n=name: fused_world_run(w, "noisy", s, name=n)[1:],
            )
        )
    runs.sort(key=lambda run: run[1] == "noisy")  # the slow noisy runs last
    rows: list[dict[str, Any]] = []
    for name, condition, runner in runs:
        rows.append(measure(name, condition, runner))
        write(rows)  # every finished run is on record, even if a later one is stopped


if __name__ == "__main__":
    main()
