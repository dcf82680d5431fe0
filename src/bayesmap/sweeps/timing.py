"""Where a sweep's time went: each task's clock and CPU, and the account of a whole sweep.

A sweep on ``W`` worker processes can be at most ``W`` times faster than the same tasks run
one after another; what it loses shows in these records. Each task measures, in the
process that runs it, its wall time, the CPU time that process used meanwhile (user and
system: :func:`os.times`) and how long importing the experiment took (only a process's
first task pays that). :func:`account` adds up the worker-seconds of a sweep:

``workers × span = task wall + start-up + gaps + tail + shut-down``

where start-up is the time before each worker's first task (starting the cluster,
importing Dask), gaps the idle time between a worker's tasks (the scheduler's round trip,
sending the result back), tail the time a worker waited for the others' last tasks, and
shut-down the time from the last task's end until the sweep returned. Task CPU well below
task wall means the task waited for a core (other processes on the machine); more CPU per
task than in a serial run means the work itself got dearer (memory returned to the
operating system and faulted in again, shared caches, threads oversubscribing the cores).

Start times are Unix times (:func:`time.time`), comparable between processes on one
machine; across machines they are only as good as the clocks' synchronisation.
"""

from __future__ import annotations

import os
import socket
import time
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass

__all__ = ["SweepAccount", "TaskClock", "TaskTiming", "account"]


@dataclass(frozen=True)
class TaskTiming:
    """Where and when one task ran, and what it cost.

    Attributes
    ----------
    worker
        ``host:pid`` of the process that ran it.
    started
        Unix time at which it started.
    wall_s
        Its wall-clock seconds.
    cpu_s
        CPU seconds (user + system) its process used while it ran: every thread of the
        process, so a worker's own threads (heartbeats, profiler) count too.
    system_s
        The system part of ``cpu_s`` (page faults, memory mapped and returned).
    import_s, import_cpu_s
        Wall and CPU seconds spent importing the experiment's module (its process's first
        task), included in ``wall_s`` and ``cpu_s``.
    """

    worker: str
    started: float
    wall_s: float
    cpu_s: float
    system_s: float
    import_s: float = 0.0
    import_cpu_s: float = 0.0

    @property
    def finished(self) -> float:
        """Unix time at which the task ended."""
        return self.started + self.wall_s


def _cpu() -> float:
    times = os.times()
    return times.user + times.system


class TaskClock:
    """Measures one task from its creation until :meth:`stop`; :meth:`imported` marks the
    end of its import."""

    def __init__(self) -> None:
        self._unix = time.time()
        self._perf = time.perf_counter()
        self._times = os.times()
        self._import = (0.0, 0.0)

    def imported(self) -> None:
        """Mark that the experiment's module is imported: what went before was the import."""
        spent = _cpu() - (self._times.user + self._times.system)
        self._import = (time.perf_counter() - self._perf, spent)

    def stop(self) -> TaskTiming:
        """The task's :class:`TaskTiming`, measured up to now."""
        times = os.times()
        user = times.user - self._times.user
        system = times.system - self._times.system
        return TaskTiming(
            worker=f"{socket.gethostname()}:{os.getpid()}",
            started=self._unix,
            wall_s=time.perf_counter() - self._perf,
            cpu_s=user + system,
            system_s=system,
            import_s=self._import[0],
            import_cpu_s=self._import[1],
        )


@dataclass(frozen=True)
class SweepAccount:
    """The worker-seconds of a sweep, added up by :func:`account` (all in seconds).

    ``workers × span_s == task_wall_s + startup_s + gaps_s + tail_s + shutdown_s``.
    """

    tasks: int
    workers: int
    span_s: float
    task_wall_s: float
    task_cpu_s: float
    system_s: float
    import_s: float
    import_cpu_s: float
    startup_s: float
    gaps_s: float
    tail_s: float
    shutdown_s: float

    @property
    def busy(self) -> float:
        """The share of the workers' time spent running tasks (1 = never idle)."""
        total = self.workers * self.span_s
        return self.task_wall_s / total if total > 0 else 0.0


def account(timings: Iterable[TaskTiming], started: float, finished: float) -> SweepAccount:
    """Add up the worker-seconds of a sweep that ran from ``started`` to ``finished``.

    ``timings`` are the tasks that ran (not those skipped as complete); ``started`` and
    ``finished`` are the Unix times at which the sweep began and returned. Each process
    that ran at least one task counts as a worker.
    """
    by_worker: dict[str, list[TaskTiming]] = defaultdict(list)
    for timing in timings:
        by_worker[timing.worker].append(timing)
    runs = [t for group in by_worker.values() for t in group]
    last = max((t.finished for t in runs), default=started)
    startup = gaps = tail = 0.0
    for group in by_worker.values():
        group.sort(key=lambda t: t.started)
        startup += group[0].started - started
        gaps += sum(b.started - a.finished for a, b in zip(group, group[1:], strict=False))
        tail += last - group[-1].finished
    return SweepAccount(
        tasks=len(runs),
        workers=len(by_worker),
        span_s=finished - started,
        task_wall_s=sum(t.wall_s for t in runs),
        task_cpu_s=sum(t.cpu_s for t in runs),
        system_s=sum(t.system_s for t in runs),
        import_s=sum(t.import_s for t in runs),
        import_cpu_s=sum(t.import_cpu_s for t in runs),
        startup_s=startup,
        gaps_s=gaps,
        tail_s=tail,
        shutdown_s=len(by_worker) * (finished - last),
    )
