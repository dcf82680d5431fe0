"""Run a sweep's tasks: in this process, on a ``distributed.LocalCluster``, or on a scheduler.

A worker receives a :class:`~bayesmap.sweeps.grid.Task` (the experiment's name and its config
as plain data) and the output folder's path, calls the experiment's ``run(config)`` into
``<out>/tasks/<key>/`` and sends back a :class:`TaskOutcome` holding the tidy metric rows.
The client writes ``task.json`` with those rows, last, so a task counts as complete only
when it finished (:func:`~bayesmap.sweeps.protocol.task_complete`); a resumed sweep skips
complete tasks. A task that raises is reported with its error; the others go on.

Before any task runs, the client writes the sweep's world files to ``<out>/worlds/``, where
the tasks' configs point. Worlds are read and figures and maps written by the worker in
the output folder, so on a cluster of several machines that folder must be on a
filesystem they share; metrics come back through Dask.
"""

from __future__ import annotations

import contextlib
import os
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bayesmap import __version__
from bayesmap._io import write_json, write_text
from bayesmap.errors import ConfigError
from bayesmap.experiments import ProgressHook, load
from bayesmap.experiments._common import no_progress
from bayesmap.sweeps import protocol
from bayesmap.sweeps.grid import SweepPlan, Task, build_config

__all__ = ["SWEEP_RECORD", "SweepOutcome", "TaskOutcome", "run_sweep", "run_task", "task_folder"]

SWEEP_RECORD = "sweep.json"
"""The plan of a sweep, written to its output folder before any task runs."""

FAILURES = "failures.json"
"""The tasks that failed in the last attempt, with their errors."""


@dataclass(frozen=True)
class TaskOutcome:
    """What a worker sends back: the rows on success, the error otherwise."""

    key: str
    rows: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0
    error: str | None = None


@dataclass(frozen=True)
class SweepOutcome:
    """How a sweep went: tasks run now, skipped as complete, and failed with their errors."""

    ran: tuple[str, ...]
    skipped: tuple[str, ...]
    failed: dict[str, str]
    seconds: float


def task_folder(out_dir: Path, key: str) -> Path:
    """Where task ``key`` of the sweep in ``out_dir`` writes its outputs."""
    return Path(out_dir) / "tasks" / key


def run_task(task: Task, out_dir: str) -> TaskOutcome:
    """Run one task (on a worker): the experiment's ``run`` into the task's folder.

    Never raises: an error becomes the outcome's ``error`` (its type, message and the
    innermost frame), so one bad task cannot stop the sweep.
    """
    started = time.perf_counter()
    try:
        module = load(task.experiment)
        config = build_config(module, task.config, where=f"task {task.key}")
        result = module.run(config, task_folder(Path(out_dir), task.key))
        rows = protocol.metric_rows(module, result)
    except Exception as error:  # a worker reports every failure instead of dying
        frame = traceback.extract_tb(error.__traceback__)[-1:]
        where = f" ({frame[0].filename}:{frame[0].lineno})" if frame else ""
        message = str(error).splitlines()[0] if str(error) else ""
        return TaskOutcome(
            task.key,
            seconds=time.perf_counter() - started,
            error=f"{type(error).__name__}: {message}{where}",
        )
    return TaskOutcome(task.key, rows, time.perf_counter() - started)


def _record(out_dir: Path, task: Task, outcome: TaskOutcome) -> None:
    write_json(
        task_folder(out_dir, task.key) / protocol.TASK_RECORD,
        {
            "experiment": task.experiment,
            "key": task.key,
            "config": task.config,
            "bayesmap": __version__,
            "seconds": outcome.seconds,
            "rows": outcome.rows,
        },
    )


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int | None) -> Iterator[Any]:
    """A Dask client on the scheduler at ``scheduler`` or on a new local cluster.

    ``scheduler`` is an address (``tcp://host:8786``) or the path of the JSON file a
    ``dask scheduler --scheduler-file FILE`` wrote.
    """
    from distributed import Client, LocalCluster

    if scheduler is not None:
        by_file = Path(scheduler).is_file()
        try:
            client = (
                Client(scheduler_file=scheduler, timeout="20s")  # type: ignore[no-untyped-call]
                if by_file
                else Client(scheduler, timeout="20s")  # type: ignore[no-untyped-call]
            )
        except (OSError, TimeoutError, ValueError, KeyError) as error:
            raise ConfigError(f"--scheduler {scheduler}: cannot connect ({error})") from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    with (
        LocalCluster(  # type: ignore[no-untyped-call]
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            silence_logs=40,
        ) as cluster,
        Client(cluster) as client,  # type: ignore[no-untyped-call]
    ):
        yield client


def run_sweep(
    plan: SweepPlan,
    out_dir: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    serial: bool = False,
    progress: ProgressHook | None = None,
) -> SweepOutcome:
    """Run every task of ``plan`` not yet complete under ``out_dir``.

    Parameters
    ----------
    plan
        The expanded sweep (:func:`~bayesmap.sweeps.grid.expand`).
    out_dir
        The sweep's folder: ``sweep.json``, ``worlds/<name>.json`` (when the plan has
        world files), ``tasks/<key>/`` and, after the run, ``failures.json`` if any task
        failed.
    scheduler
        Address of a running Dask scheduler (``tcp://host:8786``) or the scheduler file it
        wrote (``--scheduler-file``); ``None`` starts a ``LocalCluster`` of ``workers``
        single-threaded processes (default: one per core).
    serial
        Run the tasks one after another in this process, without Dask.
    progress
        Called as ``progress("<failed> failed", done, total)`` after every task.
    """
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}")
    hook = progress or no_progress
    out_dir = Path(out_dir)
    write_json(out_dir / SWEEP_RECORD, {"bayesmap": __version__, **plan.to_json()})
    for world in plan.worlds:
        if not world.path.is_file() or world.path.read_text(encoding="utf-8") != world.text:
            write_text(world.path, world.text)
    started = time.perf_counter()
    skipped = tuple(k for k in plan.tasks if protocol.task_complete(task_folder(out_dir, k)))
    pending = [task for key, task in plan.tasks.items() if key not in skipped]
    failed: dict[str, str] = {}
    done = len(skipped)
    total = len(plan.tasks)
    hook("0 failed", done, total)

    def finish(outcome: TaskOutcome) -> None:
        nonlocal done
        done += 1
        if outcome.error is None:
            _record(out_dir, plan.tasks[outcome.key], outcome)
        else:
            failed[outcome.key] = outcome.error
        hook(f"{len(failed)} failed", done, total)

    if serial or not pending:
        for task in pending:
            finish(run_task(task, str(out_dir)))
    else:
        with dask_client(scheduler, workers) as client:
            _run_on(client, pending, out_dir, finish)
    failures = out_dir / FAILURES
    if failed:
        write_json(failures, failed)
    elif failures.exists():
        failures.unlink()
    return SweepOutcome(
        ran=tuple(t.key for t in pending if t.key not in failed),
        skipped=skipped,
        failed=failed,
        seconds=time.perf_counter() - started,
    )


def _run_on(
    client: Any, pending: list[Task], out_dir: Path, finish: Callable[[TaskOutcome], None]
) -> None:
    """Submit ``pending`` to ``client`` and hand each outcome to ``finish`` as it arrives."""
    from distributed import as_completed

    futures = client.map(
        run_task,
        pending,
        out_dir=str(out_dir.resolve()),
        key=[f"bayesmap-task-{task.key}" for task in pending],
        pure=False,
    )
    for future in as_completed(futures):  # type: ignore[no-untyped-call]
        try:
            outcome = future.result()
        except Exception as error:  # the worker itself died (killed, out of memory)
            key = future.key.removeprefix("bayesmap-task-")
            outcome = TaskOutcome(key, error=f"worker lost: {type(error).__name__}: {error}")
        finish(outcome)
