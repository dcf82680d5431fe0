"""Benchmark: a sweep of 24 blackboard runs, serial against a 2-worker ``LocalCluster``.

Expands ``bayesmap sweep blackboard --worlds 4 --seeds 6 --set poses=P --set
conditions=[normal]`` (24 distinct runs, each a whole experiment run with its figures) and
runs it into fresh folders: every task in this process, then on a ``distributed.LocalCluster``
of two single-threaded worker processes as ``bayesmap sweep`` starts it (cluster start-up
and shut-down included in the time), then — to show what those settings are worth — on a
``LocalCluster`` with Dask's default worker settings (``--no-dask-defaults`` skips it). It
checks that every run gives the same metrics (timings aside) and reports the wall times,
the speed-up (target ≥ 1.7× on a 2-core machine) and where the workers' time went
(:mod:`bayesmap.sweeps.timing`): the tasks' CPU, their system part, start-up, idle gaps
between tasks, the tail spent waiting for the last task, and shut-down. The load average
before and after is measured and the text says what it means (:func:`load_note`): on a
machine shared with other work the speed-up is what was left over, not what the method
can do. Run from the repository root as ``python benchmarks/sweeps.py``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap.experiments import load  # noqa: E402
from bayesmap.sweeps import aggregate, expand, run_sweep, runner  # noqa: E402
from bayesmap.sweeps.timing import SweepAccount  # noqa: E402

TIMINGS = ("_ms_median", "_ms_p95", "wall_s")
"""Suffixes of the wall-clock columns (``per_pose_ms_median``, ``fused_wall_s``, ...)."""
TARGET = 1.7
COLUMNS = (
    "executor",
    "wall [s]",
    "speed-up",
    "task CPU [s]",
    "of it system [s]",
    "CPU vs serial",
    "task wall [s]",
    "imports [s]",
    "start-up [s]",
    "gaps [s]",
    "tail [s]",
    "shut-down [s]",
    "workers busy",
)
HEADER = f"| {' | '.join(COLUMNS)} |\n|{'---|' * len(COLUMNS)}"
"""The head of the table: one column per cell of :func:`row`."""
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


def row(name: str, wall: float, serial_wall: float, got: SweepAccount, serial: SweepAccount) -> str:
    """One line of the table: wall time, speed-up and the account of the workers' time."""
    runs, serial_runs = got.task_cpu_s - got.import_cpu_s, serial.task_cpu_s - serial.import_cpu_s
    per_task = runs / serial_runs - 1 if serial_runs else 0.0
    cells = [
        name,
        f"{wall:.1f}",
        f"{serial_wall / wall:.2f}×",
        f"{got.task_cpu_s:.1f}",
        f"{got.system_s:.1f}",
        f"{per_task:+.0%}",
        f"{got.task_wall_s:.1f}",
        f"{got.import_s:.1f}",
        f"{got.startup_s:.1f}",
        f"{got.gaps_s:.1f}",
        f"{got.tail_s:.1f}",
        f"{got.shutdown_s:.1f}",
        f"{got.busy:.0%}",
    ]
    return "| " + " | ".join(cells) + " |"


def losses(got: SweepAccount, serial: SweepAccount, serial_wall: float) -> str:
    """Where a cluster run's wall time went beyond ``serial_wall / workers``, in words."""
    w = got.workers
    imports = (got.import_cpu_s - serial.import_cpu_s) / w
    more_cpu = (got.task_cpu_s - serial.task_cpu_s) / w - imports
    waiting = ((got.task_wall_s - got.task_cpu_s) - (serial.task_wall_s - serial.task_cpu_s)) / w
    parts = [
        ("importing the experiment", imports),
        ("more CPU in the runs", more_cpu),
        ("tasks waiting for a core", waiting),
        ("start-up", got.startup_s / w),
        ("gaps between tasks", got.gaps_s / w),
        ("the tail", got.tail_s / w),
        ("shut-down", got.shutdown_s / w),
        ("minus the serial run's own overhead", -(serial_wall - serial.task_wall_s) / w),
    ]
    listed = "; ".join(f"{label} {value:+.1f} s" for label, value in parts)
    return (
        f"{serial_wall / w:.1f} s would be the serial time shared perfectly by {w} workers; "
        f"the rest, in seconds of wall time: {listed}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=40)
    parser.add_argument("--worlds", type=int, default=4)
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--no-dask-defaults",
        action="store_true",
        help="skip the run on a LocalCluster with Dask's default worker settings",
    )
    args = parser.parse_args()
    load_before = os.getloadavg()
    modes = [("serial", "serial, in one process"), ("cluster", "LocalCluster as `bayesmap sweep`")]
    if not args.no_dask_defaults:
        modes.append(("defaults", "LocalCluster, Dask's default worker settings"))
    walls: dict[str, float] = {}
    outcomes: dict[str, runner.SweepOutcome] = {}
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
        for mode, label in modes:
            print(f"{label}: {len(plan.tasks)} runs ...", flush=True)
            settings = {} if mode == "defaults" else runner.LOCAL_CLUSTER_CONFIG
            started = time.perf_counter()
            with mock.patch.object(runner, "LOCAL_CLUSTER_CONFIG", settings):
                outcomes[mode] = run_sweep(
                    plan, Path(tmp) / mode, serial=mode == "serial", workers=args.workers
                )
            walls[mode] = time.perf_counter() - started
            if outcomes[mode].failed:
                raise SystemExit(f"{label}: failed tasks: {outcomes[mode].failed}")
        tables = [aggregate.tidy(plan, Path(tmp) / mode) for mode, _ in modes]
        tables = [t[[c for c in t.columns if not c.endswith(TIMINGS)]] for t in tables]
    load_after = os.getloadavg()
    same = all(table.equals(tables[0]) for table in tables[1:])
    accounts = {mode: outcome.account() for mode, outcome in outcomes.items()}
    serial = accounts["serial"]
    speedup = walls["serial"] / walls["cluster"]
    verdict = "met" if speedup >= TARGET else f"missed by {TARGET - speedup:.2f}×"
    durations = sorted(t.wall_s for t in outcomes["serial"].timings.values())
    command = (
        f"bayesmap sweep blackboard --worlds {args.worlds} --seeds {args.seeds} "
        f"--set poses={args.poses} --set 'conditions=[normal]' --workers {args.workers} "
        "--out runs/bench"
    )
    note = load_note(load_before, load_after, os.cpu_count() or 1)
    rows = "\n".join(
        row(label, walls[mode], walls["serial"], accounts[mode], serial) for mode, label in modes
    )
    why = "\n".join(
        f"- {label}: {losses(accounts[mode], serial, walls['serial'])}."
        for mode, label in modes
        if mode != "serial"
    )
    markdown = f"""## Sweeps: {len(plan.tasks)} blackboard runs, serial vs LocalCluster

`python benchmarks/sweeps.py` — {machine()}. {note}

Each run is a whole `blackboard` experiment ({args.poses} poses, condition `normal`,
figures included) on one of {args.worlds} generated rooms (WORLD.json files of
`bayesmap blackboard world`) with one of {args.seeds} seeds; a run took
{durations[0]:.1f}–{durations[-1]:.1f} s in the serial run (median
{statistics.median(durations):.1f} s). Clusters have {args.workers} single-threaded worker
processes; their times include starting and stopping the cluster.

{HEADER}
{rows}

Speed-up of `bayesmap sweep` on {args.workers} workers: **{speedup:.2f}×** (target ≥
{TARGET}×: {verdict}). Same metrics from every executor (timings aside):
{"yes" if same else "NO"}.

*Task CPU* adds up, over the runs, the CPU time (user + system) of the process that ran
each; *CPU vs serial* is how much more the same runs cost on the workers, their imports
left out. *Task wall* adds up the runs' wall times (*imports*: the part spent importing
the experiment, paid by each worker's first run; the serial run imported it before).
*Start-up*, *gaps*, *tail* and *shut-down* are worker-seconds
without a task: before a worker's first run (starting the cluster), between its runs
(the scheduler's round trip), after its last run while another worker finished, and from
the last run's end until the sweep returned; with the task wall they add up to workers ×
wall. *Workers busy* is the task wall's share of that. Where the cluster runs' wall time
went:

{why}

Dask's default worker settings differ from those of `bayesmap sweep`'s cluster
(`bayesmap.sweeps.runner.LOCAL_CLUSTER_CONFIG`, explained in docs/cluster.md): Dask's
nanny starts workers with `MALLOC_TRIM_THRESHOLD_=65536`, which also freezes glibc's mmap
threshold so that every numpy array over 128 KiB is mapped, faulted in and unmapped again;
its profiler samples the running task every 10 ms; it hands each worker a second task
before the first is done; and its processes wake every 20 ms. Every executor runs each
task with one BLAS thread.

The same sweep from the command line, locally: `{command}`; on a cluster, start
`dask scheduler` and `dask worker` processes and add `--scheduler tcp://HOST:8786`
(see docs/cluster.md, which also says how to start those workers with the same settings).
"""
    print(markdown)
    update_section("sweeps", markdown)


if __name__ == "__main__":
    main()
