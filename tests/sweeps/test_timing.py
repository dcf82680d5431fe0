"""The account of a sweep's worker-seconds adds up, and a task's clock measures its work."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap.sweeps.timing import TaskClock, TaskTiming, account


def _timing(worker, started, wall):
    return TaskTiming(worker, started, wall, cpu_s=wall, system_s=0.0)


def test_a_two_worker_sweep_is_accounted_for_worker_by_worker():
    # worker a: tasks at 2-5 and 6-9; worker b: one task at 3-10; sweep 0-11
    timings = [_timing("a", 2, 3), _timing("a", 6, 3), _timing("b", 3, 7)]
    got = account(timings, started=0.0, finished=11.0)
    assert (got.tasks, got.workers) == (3, 2)
    assert got.startup_s == pytest.approx(2 + 3)
    assert got.gaps_s == pytest.approx(1)
    assert got.tail_s == pytest.approx(1)  # a waits from 9 until b ends at 10
    assert got.shutdown_s == pytest.approx(2 * 1)
    assert got.task_wall_s == pytest.approx(13) and got.busy == pytest.approx(13 / 22)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 3), st.floats(0, 5), st.floats(0.01, 5)),
        min_size=1,
        max_size=12,
    ),
    st.floats(0, 3),
)
def test_the_worker_seconds_add_up_to_workers_times_the_span(tasks, after):
    # each worker runs its tasks one after another, with gaps drawn between them
    timings, ends = [], {}
    for worker, gap, wall in tasks:
        start = ends.get(worker, 0.0) + gap
        timings.append(_timing(f"w{worker}", start, wall))
        ends[worker] = start + wall
    finished = max(ends.values()) + after
    got = account(timings, started=0.0, finished=finished)
    parts = got.task_wall_s + got.startup_s + got.gaps_s + got.tail_s + got.shutdown_s
    assert parts == pytest.approx(got.workers * got.span_s)
    assert got.workers == len(ends) and got.tasks == len(tasks)
    assert min(got.startup_s, got.gaps_s, got.tail_s, got.shutdown_s) >= 0


def test_no_task_means_nothing_to_account_for():
    got = account([], started=5.0, finished=6.0)
    assert (got.tasks, got.workers, got.task_wall_s, got.busy) == (0, 0, 0.0, 0.0)


def test_a_task_clock_measures_the_cpu_its_process_spent():
    def burn(seconds):  # CPU seconds, however busy the machine
        spent = time.process_time() + seconds
        x = np.ones(1000)
        while time.process_time() < spent:
            x = np.sqrt(x + 1.0)

    clock = TaskClock()
    burn(0.2)
    clock.imported()
    burn(0.3)
    timing = clock.stop()
    assert timing.cpu_s >= 0.45 and timing.wall_s >= 0.45
    assert 0.15 <= timing.import_cpu_s <= timing.import_s + 0.02 < timing.wall_s
    assert 0 <= timing.system_s <= timing.cpu_s
    assert timing.worker.endswith(f":{os.getpid()}")
    assert timing.finished == pytest.approx(timing.started + timing.wall_s)
