"""Running a sweep in this process: resume, failures that do not stop the others, tables."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from bayesmap.errors import ConfigError
from bayesmap.sweeps import aggregate, expand, run_sweep
from bayesmap.sweeps.protocol import TASK_RECORD, task_complete
from bayesmap.sweeps.runner import LOCAL_CLUSTER_CONFIG, task_folder

from . import toy


def _plan(out_dir, **kwargs):
    args = {"worlds": 2, "seeds": 3, "root_seed": 1, "out_dir": out_dir} | kwargs
    return expand("sweeps.toy", toy, **args)


def test_runs_every_task_once_and_resumes(tmp_path):
    plan = _plan(
        tmp_path, conditions={"base": {}, "same": {"ignored": 1}, "double": {"scale": 2.0}}
    )
    calls = []
    outcome = run_sweep(plan, tmp_path, serial=True, progress=lambda *a: calls.append(a))
    assert len(outcome.ran) == len(plan.tasks) == 2 * 3 * 2 and not outcome.failed
    assert calls[-1] == ("runs, 0 failed", len(plan.tasks), len(plan.tasks))
    assert all(task_complete(task_folder(tmp_path, key)) for key in plan.tasks)
    assert sorted(p.name for p in (tmp_path / "worlds").iterdir()) == [
        "world-000.json",
        "world-001.json",
    ]
    again = run_sweep(plan, tmp_path, serial=True)
    assert again.ran == () and set(again.skipped) == set(plan.tasks)
    victim = next(iter(plan.tasks))
    (task_folder(tmp_path, victim) / TASK_RECORD).write_text("{not json")
    assert run_sweep(plan, tmp_path, serial=True).ran == (victim,)


def test_a_sweep_is_extended_but_never_overwritten_by_another(tmp_path):
    run_sweep(_plan(tmp_path, seeds=1), tmp_path, serial=True)
    worlds = {p.name: p.read_text() for p in (tmp_path / "worlds").iterdir()}
    more = run_sweep(_plan(tmp_path, worlds=3, seeds=2), tmp_path, serial=True)  # extended
    assert len(more.skipped) == 2 and len(more.ran) == 4
    assert all((tmp_path / "worlds" / name).read_text() == text for name, text in worlds.items())
    with pytest.raises(ConfigError, match=r"world-000.json differs .* --root-seed"):
        run_sweep(_plan(tmp_path, root_seed=2), tmp_path, serial=True)
    other = expand("sweeps.toy2", toy, worlds=1, seeds=1, root_seed=1, out_dir=tmp_path)
    with pytest.raises(ConfigError, match="holds a sweep of 'sweeps.toy', not 'sweeps.toy2'"):
        run_sweep(other, tmp_path, serial=True)
    assert all((tmp_path / "worlds" / name).read_text() == text for name, text in worlds.items())
    assert json.loads((tmp_path / "sweep.json").read_text())["experiment"] == "sweeps.toy"


def test_a_failed_task_is_reported_and_the_others_finish(tmp_path):
    plan = _plan(tmp_path, conditions={"ok": {}, "broken": {"fail": True}})
    outcome = run_sweep(plan, tmp_path, serial=True)
    broken = {p.task for p in plan.points if p.condition == "broken"}
    assert set(outcome.failed) == broken
    assert all(
        "InputError: the toy experiment was told to fail" in e for e in outcome.failed.values()
    )
    assert json.loads((tmp_path / "failures.json").read_text()) == outcome.failed
    table = aggregate.tidy(plan, tmp_path)
    assert set(table["condition"]) == {"ok"} and len(table) == 2 * 3 * 2


def test_the_tidy_table_holds_every_point_and_the_known_values(tmp_path):
    plan = _plan(tmp_path, conditions={"base": {}, "same": {"ignored": 1}})
    run_sweep(plan, tmp_path, serial=True)
    table = aggregate.tidy(plan, tmp_path)
    assert len(table) == len(plan.points) * 2
    for _, row in table.iterrows():
        offset = toy.load_world(plan.tasks[row["task"]].config["world"])
        noise = np.random.default_rng(int(row["seed"])).normal()
        assert math.isclose(row["value"], noise + offset + (row["method"] == "b"))
    written = aggregate.write_tables(table, tmp_path)
    assert aggregate.read_table(written["tidy"]).equals(table)
    assert (tmp_path / "summary.csv").read_text().startswith("experiment,arm,unit,metric")


def test_paired_differences_are_exact_when_the_methods_differ_by_a_constant(tmp_path):
    plan = _plan(tmp_path)
    run_sweep(plan, tmp_path, serial=True)
    pairs = aggregate.paired(aggregate.tidy(plan, tmp_path))
    row = pairs.set_index("metric").loc["value"]
    assert (row["arm_a"], row["arm_b"], row["n"]) == ("default / a", "default / b", 6)
    assert row["mean"] == pytest.approx(-1.0)
    assert row["ci_low"] == pytest.approx(-1.0) and row["ci_high"] == pytest.approx(-1.0)


@pytest.mark.slow
def test_a_rover_sweep_over_generated_worlds_pairs_the_two_explorers(tmp_path):
    """`bayesmap sweep rover --worlds N`: the worlds are rover WORLD.json files, and the
    paper's explorer and the frontier explorer are paired on the same worlds and seeds."""
    from bayesmap.experiments import load
    from bayesmap.sim.rover_worlds import load_world
    from bayesmap.sweeps.report import sections_from_sweep, write_report

    rover = load("rover")
    settings = {"max_steps": 4, "runs": ["obstacles-flat"], "curve_every": 2}
    plan = expand(
        "rover", rover, worlds=1, seeds=2, root_seed=0, settings=settings, out_dir=tmp_path
    )
    outcome = run_sweep(plan, tmp_path, serial=True)
    assert not outcome.failed and len(outcome.ran) == 2
    spec = load_world(tmp_path / "worlds" / "world-000.json")
    table = aggregate.tidy(plan, tmp_path)
    assert set(table["world"]) == {"world-000"} and set(table["unit"]) == {"flat"}
    assert set(table["method"]) == {"entropy", "frontier"}
    assert (table["world_index"] == 0).all() and spec.world.width >= 20.0
    pairs = aggregate.paired(table)
    coverage = pairs[pairs["metric"] == "coverage"].iloc[0]
    assert (coverage["arm_a"], coverage["arm_b"], coverage["n"]) == (
        "default / entropy",
        "default / frontier",
        2,
    )
    by = table.set_index(["seed_index", "method"])["coverage"]
    expected = np.mean([by[(k, "entropy")] - by[(k, "frontier")] for k in (0, 1)])
    assert coverage["mean"] == pytest.approx(expected)
    html = write_report(sections_from_sweep(tmp_path), tmp_path / "report.html", title="r")
    text = html.read_text()
    assert "Paired comparisons with entropy" in text
    assert '<td class="name">entropy</td><td class="name">frontier</td>' in text


def test_the_worker_settings_in_the_cluster_guide_are_those_of_the_local_cluster():
    """docs/cluster.md gives users the YAML of the settings `bayesmap sweep` starts its
    LocalCluster with; the two must not drift apart."""
    guide = (Path(__file__).resolve().parents[2] / "docs" / "cluster.md").read_text()
    block = re.search(r"<!-- dask-config -->\n```yaml\n(.*?)```", guide, re.DOTALL)
    assert block is not None

    def flat(tree, prefix=""):
        for key, value in tree.items():
            if isinstance(value, dict):
                yield from flat(value, f"{prefix}{key}.")
            else:
                yield f"{prefix}{key}", value

    assert dict(flat(yaml.safe_load(block.group(1)))) == LOCAL_CLUSTER_CONFIG
