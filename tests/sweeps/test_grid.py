"""Grid expansion: seeds from SeedSequence.spawn, identical runs found, bad settings refused."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest

from bayesmap.errors import ConfigError, FormatError
from bayesmap.experiments import load
from bayesmap.sweeps.grid import expand, parse_condition, parse_setting, task_key

from . import toy

EXPERIMENT = "sweeps.toy"


def _plan(**kwargs):
    args = {"worlds": None, "seeds": 3, "root_seed": 7} | kwargs
    return expand(EXPERIMENT, toy, **args)


def test_seeds_are_shared_across_worlds_and_conditions_and_stable_when_extended(tmp_path):
    plan = _plan(worlds=2, conditions={"x": {}, "y": {"scale": 2.0}}, out_dir=tmp_path)
    assert len(plan.points) == 2 * 3 * 2
    by_index = {}
    for point in plan.points:
        by_index.setdefault(point.seed_index, set()).add(point.seed)
    assert all(len(seeds) == 1 for seeds in by_index.values())
    assert len({s.pop() for s in by_index.values()}) == 3
    longer = _plan(worlds=2, seeds=5, conditions={"x": {}, "y": {"scale": 2.0}}, out_dir=tmp_path)
    assert {p.task for p in plan.points} <= {p.task for p in longer.points}
    assert _plan(root_seed=8).points[0].seed != plan.points[0].seed


def test_same_request_same_plan_and_task_keys_follow_the_world_not_its_folder(tmp_path):
    a, b = _plan(worlds=3, out_dir=tmp_path), _plan(worlds=3, out_dir=tmp_path)
    assert a.to_json() == b.to_json()
    assert [w.text for w in a.worlds] == [w.text for w in b.worlds]
    moved = _plan(worlds=3, out_dir=tmp_path / "elsewhere")
    assert list(moved.tasks) == list(a.tasks)
    assert moved.tasks != a.tasks  # same keys, configs pointing at the moved world files
    assert len({w.digest for w in a.worlds}) == 3
    more = _plan(worlds=4, out_dir=tmp_path)  # more worlds keep the earlier ones, and their tasks
    assert [w.text for w in more.worlds[:3]] == [w.text for w in a.worlds]
    assert set(a.tasks) < set(more.tasks)


def test_identical_effective_configs_are_one_task():
    plan = _plan(conditions={"base": {}, "same": {"ignored": 5}, "other": {"scale": 3.0}})
    tasks_of = {c: {p.task for p in plan.points if p.condition == c} for c in ("base", "same")}
    assert tasks_of["base"] == tasks_of["same"]
    assert len(plan.tasks) == 2 * 3


def test_task_key_hashes_the_config():
    assert task_key("x", {"a": 1, "b": 2}) == task_key("x", {"b": 2, "a": 1})
    assert task_key("x", {"a": 1}) != task_key("x", {"a": 2}) != task_key("y", {"a": 1})


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("poses=40", ("poses", 40)),
        ("c=[normal, noisy]", ("c", ["normal", "noisy"])),
        ("m.t=2.5", ("m.t", 2.5)),
        ("flag=true", ("flag", True)),
    ],
)
def test_settings_read_yaml_values(text, expected):
    assert parse_setting(text) == expected


@pytest.mark.parametrize("text", ["poses", "=3", "x=[1, 2"])
def test_malformed_settings_are_refused(text):
    with pytest.raises(ConfigError, match="--set"):
        parse_setting(text)


def test_conditions_parse():
    assert parse_condition("hot") == ("hot", None)
    assert parse_condition("hot:scale=2") == ("hot", ("scale", 2))
    with pytest.raises(ConfigError):
        parse_condition(":scale=2")


def test_unknown_or_invalid_settings_name_the_problem():
    with pytest.raises(ConfigError, match="unknown setting.*nope"):
        _plan(settings={"nope": 1})
    with pytest.raises(ConfigError, match="condition 'bad'.*scale"):
        _plan(conditions={"bad": {"scale": "large"}})
    with pytest.raises(ConfigError, match="seed"):
        _plan(settings={"seed": 3})
    with pytest.raises(ConfigError, match="--seeds"):
        _plan(seeds=0)


def test_experiments_without_world_support_refuse_worlds(tmp_path):
    module = "bayesmap.experiments.rover_world"
    with pytest.raises(ConfigError, match="cannot take --worlds.*generate_world"):
        expand(module, load(module), worlds=2, seeds=1, root_seed=0, out_dir=tmp_path)
    with pytest.raises(ConfigError, match="needs an output folder"):
        _plan(worlds=2)


def test_worlds_from_a_folder(tmp_path):
    source = tmp_path / "mine"
    source.mkdir()
    for name, offset in [("b", 2.0), ("a", 1.0)]:
        (source / f"{name}.json").write_text(json.dumps({"offset": offset}))
    (source / "notes.txt").write_text("not a world")
    plan = _plan(worlds=source, seeds=1, out_dir=tmp_path / "out")
    assert [p.world for p in plan.points] == ["a", "b"]
    paths = [Path(plan.tasks[p.task].config["world"]) for p in plan.points]
    assert paths == [tmp_path.resolve() / "out" / "worlds" / f"{n}.json" for n in "ab"]
    assert [w.text for w in plan.worlds] == [(source / f"{n}.json").read_text() for n in "ab"]
    (source / "c.json").write_text("{}")
    with pytest.raises(FormatError, match="c.json"):
        _plan(worlds=source, seeds=1, out_dir=tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="no world files"):
        _plan(worlds=tmp_path / "empty", seeds=1, out_dir=tmp_path)
    with pytest.raises(ConfigError, match="not a number and not a folder"):
        _plan(worlds=tmp_path / "missing", seeds=1, out_dir=tmp_path)


@pytest.mark.parametrize(
    ("experiment", "reader"),
    [
        ("blackboard", "bayesmap.sim.whisker_worlds"),
        ("rover", "bayesmap.sim.rover_worlds"),
        ("sonar", "bayesmap.sim.sonar_worlds"),
    ],
)
def test_each_system_sweeps_the_world_files_its_own_reader_reads(tmp_path, experiment, reader):
    """Generated worlds are the system's WORLD.json files: its own reader takes them back."""
    module = load(experiment)
    plan = expand(experiment, module, worlds=2, seeds=1, root_seed=0, out_dir=tmp_path)
    assert [w.name for w in plan.worlds] == ["world-000", "world-001"]
    assert plan.worlds[0].text != plan.worlds[1].text
    again = expand(experiment, module, worlds=2, seeds=1, root_seed=0, out_dir=tmp_path)
    assert [w.text for w in again.worlds] == [w.text for w in plan.worlds]
    load_world = importlib.import_module(reader).load_world
    for world in plan.worlds:
        world.path.parent.mkdir(parents=True, exist_ok=True)
        world.path.write_text(world.text)
        load_world(world.path)  # raises FormatError if the file is not the system's format
    # a folder of those files is a sweep too, with the same tasks
    again = expand(
        experiment,
        module,
        worlds=plan.worlds[0].path.parent,
        seeds=1,
        root_seed=0,
        out_dir=tmp_path,
    )
    assert list(again.tasks) == list(plan.tasks)


def test_rover_runs_without_random_init_ignore_delta_h():
    rover = load("rover")
    plan = expand(
        "rover",
        rover,
        worlds=None,
        seeds=2,
        root_seed=0,
        settings={"runs": ["obstacles-flat"]},
        conditions={"a": {}, "b": {"delta_h": 0.05}},
    )
    assert len(plan.tasks) == 2
    plan = expand(
        "rover",
        rover,
        worlds=None,
        seeds=2,
        root_seed=0,
        settings={"runs": ["obstacles-random"]},
        conditions={"a": {}, "b": {"delta_h": 0.05}},
    )
    assert len(plan.tasks) == 4
