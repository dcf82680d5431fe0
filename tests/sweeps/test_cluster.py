"""Sweeps on real Dask clusters give the numbers of a serial run.

One test starts a ``dask scheduler`` and two ``dask worker`` processes on loopback (as a
user would on a cluster), the other the default ``LocalCluster``. Both compare the tidy
table with a serial run of the same plan; only wall-clock timings may differ.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from bayesmap.experiments import load
from bayesmap.sweeps import aggregate, expand, run_sweep

from . import toy

pytestmark = pytest.mark.slow

TIMING_SUFFIXES = ("_ms_median", "_ms_p95", "wall_s")
"""Wall-clock columns (``per_pose_ms_median``, ``fused_wall_s``, ...): the only ones that differ."""


def _without_timings(table: pd.DataFrame) -> pd.DataFrame:
    columns = [c for c in table.columns if not c.endswith(TIMING_SUFFIXES)]
    return table[columns].sort_values(["task", "method"]).reset_index(drop=True)


def _start(args, cwd, log):
    # the workers import the toy experiment as ``sweeps.toy``, as a user's own module would be
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parent.parent))
    return subprocess.Popen(
        [sys.executable, "-m", *args],
        cwd=cwd,
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )


def _wait_for(path, seconds):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if path.exists() and path.stat().st_size > 0:
            return
        time.sleep(0.2)
    raise TimeoutError(f"{path} did not appear in {seconds} s")


@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """A scheduler and two single-threaded workers, loopback only; stopped after the test."""
    tmp_path = tmp_path_factory.mktemp("dask")
    scheduler_file = tmp_path / "scheduler.json"
    log = (tmp_path / "dask.log").open("w")
    common = ["--no-dashboard", "--host", "127.0.0.1"]
    processes = [
        _start(
            [
                "distributed.cli.dask_scheduler",
                "--port",
                "0",
                "--scheduler-file",
                str(scheduler_file),
                *common,
            ],
            tmp_path,
            log,
        )
    ]
    try:
        _wait_for(scheduler_file, 60)
        for index in range(2):
            processes.append(
                _start(
                    [
                        "distributed.cli.dask_worker",
                        "--scheduler-file",
                        str(scheduler_file),
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--name",
                        f"w{index}",
                        "--local-directory",
                        str(tmp_path / f"w{index}"),
                        *common,
                    ],
                    tmp_path,
                    log,
                )
            )
        import json

        from distributed import Client

        address = json.loads(scheduler_file.read_text())["address"]
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for process in reversed(processes):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGTERM)
        for process in processes:
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
        log.close()


@pytest.mark.parametrize(
    ("experiment", "worlds", "seeds", "settings"),
    [
        ("sweeps.toy", 3, 4, {}),
        ("blackboard", 1, 1, {"poses": 4, "conditions": ["normal"]}),
    ],
)
def test_a_sweep_through_a_scheduler_and_two_workers_equals_a_serial_run(
    dask_cluster, tmp_path, experiment, worlds, seeds, settings
):
    module = toy if experiment == "sweeps.toy" else load(experiment)
    plan = expand(
        experiment,
        module,
        worlds=worlds,
        seeds=seeds,
        root_seed=3,
        settings=settings,
        out_dir=tmp_path / "serial",
    )
    serial = run_sweep(plan, tmp_path / "serial", serial=True)
    calls = []
    remote = run_sweep(
        plan, tmp_path / "remote", scheduler=dask_cluster, progress=lambda *a: calls.append(a)
    )
    assert not serial.failed and not remote.failed
    n = worlds * seeds
    assert len(remote.ran) == len(plan.tasks) == n
    assert calls[-1] == ("runs, 0 failed", n, n)
    expected = _without_timings(aggregate.tidy(plan, tmp_path / "serial"))
    got = _without_timings(aggregate.tidy(plan, tmp_path / "remote"))
    pd.testing.assert_frame_equal(got, expected)
    assert got["world"].nunique() == worlds and got["seed"].nunique() == seeds
    if experiment == "blackboard":  # the run mapped the generated layout it was given
        assert (got["scenario"] == got["world"]).all()


def test_a_local_cluster_gives_the_serial_numbers(tmp_path):
    plan = expand(
        "sweeps.toy",
        toy,
        worlds=2,
        seeds=3,
        root_seed=9,
        conditions={"ok": {}, "broken": {"fail": True}},
        out_dir=tmp_path / "serial",
    )
    serial = run_sweep(plan, tmp_path / "serial", serial=True)
    local = run_sweep(plan, tmp_path / "local", workers=2)
    assert local.failed.keys() == serial.failed.keys() and len(local.failed) == 6
    pd.testing.assert_frame_equal(
        aggregate.tidy(plan, tmp_path / "local"), aggregate.tidy(plan, tmp_path / "serial")
    )
    # every task, failed ones too, came back with its clock, from one of the two workers
    assert local.timings.keys() == plan.tasks.keys()
    pids = {timing.worker for timing in local.timings.values()}
    assert 1 <= len(pids) <= 2 and f":{os.getpid()}" not in " ".join(pids)
    spent = local.account()
    assert spent.tasks == len(plan.tasks) and spent.span_s == pytest.approx(local.seconds, 0.05)


def test_the_local_cluster_workers_run_one_thread_without_the_malloc_trim():
    """The workers `bayesmap sweep` starts: one thread, one BLAS thread, glibc's adaptive
    malloc (no MALLOC_TRIM_THRESHOLD_), no profiler; and this process's environment is
    left as it was."""
    from bayesmap.sweeps.runner import dask_client

    def probe():
        import dask
        from threadpoolctl import threadpool_info

        return (
            os.environ.get("MALLOC_TRIM_THRESHOLD_"),
            os.environ.get("OMP_NUM_THREADS"),
            dask.config.get("distributed.worker.profile.enabled"),
            max((pool["num_threads"] for pool in threadpool_info()), default=1),
        )

    before = dict(os.environ)
    with dask_client(None, 2) as client:
        threads = {w["nthreads"] for w in client.scheduler_info()["workers"].values()}
        answers = set(client.run(probe).values())
    assert threads == {1}
    assert answers == {(None, "1", False, 1)}
    assert dict(os.environ) == before


def test_the_sweep_command_runs_on_the_scheduler_of_a_scheduler_file_and_resumes(
    dask_cluster, tmp_path, monkeypatch
):
    """docs/cluster.md's recipe: `dask scheduler --scheduler-file`, workers, then
    `bayesmap sweep ... --scheduler FILE`; the same numbers as --serial, and a rerun resumes."""
    import json

    from typer.testing import CliRunner

    from bayesmap.cli import app

    monkeypatch.chdir(tmp_path)
    scheduler_file = tmp_path / "scheduler.json"
    scheduler_file.write_text(json.dumps({"address": dask_cluster}))
    runner = CliRunner()
    grid = ["sweep", "sweeps.toy", "--worlds", "2", "--seeds", "2", "--root-seed", "4"]
    remote = runner.invoke(app, [*grid, "--scheduler", str(scheduler_file), "--out", "r"])
    assert remote.exit_code == 0, remote.output
    assert "on the scheduler at" in remote.output and "ran 4, skipped 0" in remote.output
    again = runner.invoke(app, [*grid, "--scheduler", dask_cluster, "--out", "r"])
    assert again.exit_code == 0 and "ran 0, skipped 4" in again.output
    serial = runner.invoke(app, [*grid, "--serial", "--out", "s"])
    assert serial.exit_code == 0, serial.output
    pd.testing.assert_frame_equal(
        pd.read_parquet("r/summary.parquet"), pd.read_parquet("s/summary.parquet")
    )
    assert sorted(p.name for p in Path("r/worlds").iterdir()) == [
        "world-000.json",
        "world-001.json",
    ]
