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

Every task runs with one BLAS/OpenMP thread (:func:`threadpoolctl.threadpool_limits`), in
this process as on a worker: the experiments' arrays are small, and W single-threaded
workers on W cores must not start W × cores threads. A ``LocalCluster``'s workers are
started without Dask's ``MALLOC_TRIM_THRESHOLD_``, its profiler and most of its
housekeeping (:data:`LOCAL_CLUSTER_CONFIG`), so a task's memory is handled as in a serial
run and its worker's own threads take little from it. Each task's clock and CPU come
back with its outcome (:mod:`~bayesmap.sweeps.timing`).
"""

from __future__ import annotations

import contextlib
import json
import os
import time
import traceback
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_limits

from bayesmap import __version__
from bayesmap._io import check_own_folder, write_json, write_text
from bayesmap._typing import ProgressHook
from bayesmap.errors import ConfigError
from bayesmap.experiments import load
from bayesmap.experiments._common import no_progress
from bayesmap.sweeps import protocol
from bayesmap.sweeps.grid import SweepPlan, Task, build_config
from bayesmap.sweeps.timing import SweepAccount, TaskClock, TaskTiming, account

__all__ = [
    "LOCAL_CLUSTER_CONFIG",
    "SWEEP_RECORD",
    "SweepOutcome",
    "TaskOutcome",
    "run_sweep",
    "run_task",
    "task_folder",
]

SWEEP_RECORD = "sweep.json"
"""The plan of a sweep, written to its output folder before any task runs."""

FAILURES = "failures.json"
"""The tasks that failed in the last attempt, with their errors."""

LOCAL_CLUSTER_CONFIG: dict[str, Any] = {
    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in its workers' environment so that
    # freed memory goes back to the operating system. Setting any trim threshold also
    # freezes glibc's mmap threshold at 128 KiB (mallopt(3)), so each larger numpy array
    # is mapped, faulted in page by page and unmapped again: a blackboard run took about
    # 15 % more CPU in a process started with it. None leaves glibc's adaptive default.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    # The worker's sampling profiler walks the running task's stack every 10 ms, taking
    # the interpreter lock from it; nobody reads its profiles here.
    "distributed.worker.profile.enabled": False,
    # One task per worker at a time; the rest wait on the scheduler, which hands each to
    # the first worker that is free (so no task queues behind a long one).
    "distributed.scheduler.worker-saturation": 1.0,
    # Each process's event loop wakes every 20 ms to check that it is not blocked, and
    # polls its memory and the system's counters every 0.1 s and 0.5 s: with two workers,
    # their nannies and the scheduler, an idle cluster kept about 7 % of one core busy.
    # At 1 s, 1 s and 5 s it keeps under 2 %; the sweep's tasks last seconds to minutes.
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}
"""Dask settings of the ``LocalCluster`` a sweep starts (:func:`dask_client`), and those
docs/cluster.md suggests for a cluster started by hand."""

_UNSET_IN_WORKERS = tuple(
    key.rsplit(".", 1)[1]
    for key, value in LOCAL_CLUSTER_CONFIG.items()
    if key.startswith("distributed.nanny.pre-spawn-environ.") and value is None
)
"""Environment variables the local cluster's workers must not have (from
:data:`LOCAL_CLUSTER_CONFIG`)."""


@dataclass(frozen=True)
class TaskOutcome:
    """What a worker sends back: the rows on success, the error otherwise, and the timing
    (``None`` when the worker died before it could measure one)."""

    key: str
    rows: list[dict[str, Any]] = field(default_factory=list)
    timing: TaskTiming | None = None
    error: str | None = None


@dataclass(frozen=True)
class SweepOutcome:
    """How a sweep went: tasks run now, skipped as complete, and failed with their errors.

    ``timings`` holds every task that ran now (failed ones too, when their worker
    survived); ``started`` and ``finished`` are the Unix times at which the sweep began
    and returned (cluster start and shut-down included), ``seconds`` the time between.
    """

    ran: tuple[str, ...]
    skipped: tuple[str, ...]
    failed: dict[str, str]
    seconds: float
    timings: dict[str, TaskTiming] = field(default_factory=dict)
    started: float = 0.0
    finished: float = 0.0

    def account(self) -> SweepAccount:
        """Where the workers' time went (:func:`~bayesmap.sweeps.timing.account`)."""
        return account(self.timings.values(), self.started, self.finished)


def task_folder(out_dir: Path, key: str) -> Path:
    """Where task ``key`` of the sweep in ``out_dir`` writes its outputs."""
    return Path(out_dir) / "tasks" / key


def run_task(task: Task, out_dir: str) -> TaskOutcome:
    """Run one task (on a worker): the experiment's ``run`` into the task's folder.

    Never raises: an error becomes the outcome's ``error`` (its type, message and the
    innermost frame), so one bad task cannot stop the sweep. Runs with one BLAS/OpenMP
    thread whatever the process's settings.
    """
    clock = TaskClock()
    try:
        with threadpool_limits(limits=1):
            module = load(task.experiment)
            clock.imported()
            config = build_config(module, task.config, where=f"task {task.key}")
            result = module.run(config, task_folder(Path(out_dir), task.key))
            rows = protocol.metric_rows(module, result)
    except Exception as error:  # a worker reports every failure instead of dying
        frame = traceback.extract_tb(error.__traceback__)[-1:]
        where = f" ({frame[0].filename}:{frame[0].lineno})" if frame else ""
        message = str(error).splitlines()[0] if str(error) else ""
        return TaskOutcome(
            task.key,
            timing=clock.stop(),
            error=f"{type(error).__name__}: {message}{where}",
        )
    return TaskOutcome(task.key, rows, clock.stop())


def _record(out_dir: Path, task: Task, outcome: TaskOutcome) -> None:
    timing = outcome.timing
    write_json(
        task_folder(out_dir, task.key) / protocol.TASK_RECORD,
        {
            "experiment": task.experiment,
            "key": task.key,
            "config": task.config,
            "bayesmap": __version__,
            "seconds": None if timing is None else timing.wall_s,
            "cpu_seconds": None if timing is None else timing.cpu_s,
            "worker": None if timing is None else timing.worker,
            "rows": outcome.rows,
        },
    )


@contextlib.contextmanager
def _environment_restored() -> Iterator[None]:
    """Put this process's environment back as it was: a ``LocalCluster``'s nannies run in
    this process and write their workers' pre-spawn variables (``OMP_NUM_THREADS=1``, ...)
    into it, where every later child process would inherit them."""
    saved = dict(os.environ)
    try:
        yield
    finally:
        for name in set(os.environ) - set(saved):
            del os.environ[name]
        os.environ.update(saved)


def scheduler_problem(scheduler: str) -> str | None:
    """What is wrong with ``--scheduler`` before connecting, or ``None``: it must name an
    existing scheduler file or be an address (``tcp://host:8786``, ``host:8786``)."""
    if ":" in scheduler or Path(scheduler).is_file():
        return None
    return (
        f"--scheduler {scheduler}: no such scheduler file, and not an address such as "
        "tcp://host:8786"
    )


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int | None) -> Iterator[Any]:
    """A Dask client on the scheduler at ``scheduler`` or on a new local cluster.

    ``scheduler`` is an address (``tcp://host:8786``) or the path of the JSON file a
    ``dask scheduler --scheduler-file FILE`` wrote. A local cluster has ``workers``
    single-threaded processes (default: one per core), set up by
    :data:`LOCAL_CLUSTER_CONFIG`.
    """
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        problem = scheduler_problem(scheduler)
        if problem is not None:
            raise ConfigError(problem)
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
    with _environment_restored(), warnings.catch_warnings(), dask.config.set(LOCAL_CLUSTER_CONFIG):
        # Dask leaves a variable its config unsets to the environment the workers inherit,
        # where an earlier cluster's nanny in this process (or the shell) may have put it.
        for name in _UNSET_IN_WORKERS:
            os.environ.pop(name, None)
        # the scheduler serves health checks over HTTP on port 8787, or on a free port
        # with a warning when another cluster holds 8787; the sweep needs neither
        warnings.filterwarnings("ignore", "Port .* is already in use", UserWarning)
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
        Called as ``progress("runs, <failed> failed", done, total)`` after every task.

    Raises
    ------
    ConfigError
        ``out_dir`` is a file, or a folder with other files and no ``sweep.json``.
    """
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers must be at least 1, got {workers}")
    hook = progress or no_progress
    out_dir = Path(out_dir)
    check_own_folder(out_dir, SWEEP_RECORD, "sweep folder", "sweep")
    _check_resumable(out_dir, plan)
    write_json(out_dir / SWEEP_RECORD, {"bayesmap": __version__, **plan.to_json()})
    for world in plan.worlds:
        if not world.path.is_file():
            write_text(world.path, world.text)
    started, unix_started = time.perf_counter(), time.time()
    skipped = tuple(k for k in plan.tasks if protocol.task_complete(task_folder(out_dir, k)))
    pending = [task for key, task in plan.tasks.items() if key not in skipped]
    failed: dict[str, str] = {}
    timings: dict[str, TaskTiming] = {}
    done = len(skipped)
    total = len(plan.tasks)
    hook("runs, 0 failed", done, total)

    def finish(outcome: TaskOutcome) -> None:
        nonlocal done
        done += 1
        if outcome.timing is not None:
            timings[outcome.key] = outcome.timing
        if outcome.error is None:
            _record(out_dir, plan.tasks[outcome.key], outcome)
        else:
            failed[outcome.key] = outcome.error
        hook(f"runs, {len(failed)} failed", done, total)

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
        timings=timings,
        started=unix_started,
        finished=time.time(),
    )


def _check_resumable(out_dir: Path, plan: SweepPlan) -> None:
    """ConfigError unless a sweep already in ``out_dir`` is one ``plan`` may resume: the
    same experiment, and every world file it wrote the same as the plan's (more seeds or
    worlds extend a sweep; another experiment or ``--root-seed`` would overwrite the worlds
    its finished tasks ran on)."""
    record = out_dir / SWEEP_RECORD
    if not record.is_file():
        return
    try:
        earlier = json.loads(record.read_bytes())["experiment"]
    except (OSError, ValueError, KeyError, TypeError):
        raise ConfigError(
            f"the sweep folder {str(out_dir)!r} has a {SWEEP_RECORD} that cannot be read; "
            "choose another folder"
        ) from None
    if earlier != plan.experiment:
        raise ConfigError(
            f"the sweep folder {str(out_dir)!r} holds a sweep of {earlier!r}, not "
            f"{plan.experiment!r}; choose another folder"
        )
    for world in plan.worlds:
        if world.path.is_file() and world.path.read_text(encoding="utf-8") != world.text:
            raise ConfigError(
                f"{world.path} differs from the world this sweep would write there (another "
                "--root-seed, --worlds or bayesmap version?), and the sweep's finished tasks "
                "ran on it; resume with the same options or choose another folder"
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
