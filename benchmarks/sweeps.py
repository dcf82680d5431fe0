"""Benchmark: a sweep of 24 blackboard runs, serial against a 2-worker ``LocalCluster``.

Expands ``bayesmap sweep blackboard --worlds 4 --seeds 6 --set poses=P --set
conditions=[normal]`` (24 distinct runs, each a whole experiment run with its figures) and
runs it twice into fresh folders: every task in this process, then on a
``distributed.LocalCluster`` of two single-threaded worker processes (cluster start-up
included in the time). It checks that both give the same metrics (timings aside) and
reports both wall times and the speed-up; target ≥ 1.7× on a 2-core machine. The load
average before and after is measured and the text says what it means (:func:`load_note`):
on a machine shared with other work the speed-up is what was left over, not what the
method can do. Run from the repository root as ``python benchmarks/sweeps.py``.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap.experiments import load  # noqa: E402
from bayesmap.sweeps import aggregate, expand, run_sweep  # noqa: E402

TIMINGS = ("_ms_median", "_ms_p95", "wall_s")
"""Suffixes of the wall-clock columns (``per_pose_ms_median``, ``fused_wall_s``, ...)."""
TARGET = 1.7
IDLE_LOAD = 0.5
"""A 1-minute load average below this before the run counts as an otherwise idle machine."""


def load_note(before: tuple[float, ...], after: tuple[float, ...], cores: int) -> str:
    """What the load averages measured around the benchmark say about its timings.

    ``before`` and ``after`` are :func:`os.getloadavg` triples; the load before the run is
    other work, the load after also counts the benchmark's own processes.
    """
    measured = (
        f"the 1-minute load average was {before[0]:.1f} before the run and {after[0]:.1f} "
        f"after it (which counts the benchmark's own processes) on {cores} cores"
    )
    if before[0] < IDLE_LOAD:
        return f"The machine was otherwise idle: {measured}."
    if before[0] < cores:
        return (
            f"Other work kept about {before[0]:.1f} of the {cores} cores busy when the run "
            f"started, so the timings are somewhat slower than on an idle machine: {measured}."
        )
    return (
        "The machine was **shared with other jobs**: the serial run and the workers competed "
        "with that load for the cores, so these timings say how a sweep fares on a busy "
        f"machine, not what it gives on an idle one; {measured}."
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=40)
    parser.add_argument("--worlds", type=int, default=4)
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        plan = expand(
            "blackboard",
            load("blackboard"),
            worlds=args.worlds,
            seeds=args.seeds,
            root_seed=2011,
            settings={"poses": args.poses, "conditions": ["normal"]},
            out_dir=Path(tmp) / "serial",
        )
        started = time.perf_counter()
        serial = run_sweep(plan, Path(tmp) / "serial", serial=True)
        serial_s = time.perf_counter() - started
        started = time.perf_counter()
        cluster = run_sweep(plan, Path(tmp) / "cluster", workers=args.workers)
        cluster_s = time.perf_counter() - started
        tables = [aggregate.tidy(plan, Path(tmp) / name) for name in ("serial", "cluster")]
        tables = [t[[c for c in t.columns if not c.endswith(TIMINGS)]] for t in tables]
    load_after = os.getloadavg()
    if serial.failed or cluster.failed:
        raise SystemExit(f"failed tasks: {serial.failed or cluster.failed}")
    same = tables[0].equals(tables[1])
    speedup = serial_s / cluster_s
    per_run = cluster_s / len(plan.tasks)
    verdict = "met" if speedup >= TARGET else f"missed by {TARGET - speedup:.2f}×"
    command = (
        f"bayesmap sweep blackboard --worlds {args.worlds} --seeds {args.seeds} "
        f"--set poses={args.poses} --set 'conditions=[normal]' --workers {args.workers} "
        "--out runs/bench"
    )
    note = load_note(load_before, load_after, os.cpu_count() or 1)
    markdown = f"""## Sweeps: {len(plan.tasks)} blackboard runs, serial vs LocalCluster

`python benchmarks/sweeps.py` — {machine()}. {note}

Each run is a whole `blackboard` experiment ({args.poses} poses, condition `normal`,
figures included) on one of {args.worlds} generated rooms (WORLD.json files of
`bayesmap blackboard world`) with one of {args.seeds} seeds.

| executor | wall time [s] | per run [s] |
|---|---|---|
| serial, in one process | {serial_s:.1f} | {serial_s / len(plan.tasks):.2f} |
| LocalCluster, {args.workers} workers, start-up included | {cluster_s:.1f} | {per_run:.2f} |

Speed-up **{speedup:.2f}×** (target ≥ {TARGET}×: {verdict}). Same metrics from both
(timings aside): {"yes" if same else "NO"}.

The same sweep from the command line, locally: `{command}`; on a cluster, start
`dask scheduler` and `dask worker` processes and add `--scheduler tcp://HOST:8786`
(see docs/cluster.md).
"""
    print(markdown)
    update_section("sweeps", markdown)


if __name__ == "__main__":
    main()
