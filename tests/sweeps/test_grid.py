"""Grid expansion: seeds from SeedSequence.spawn, identical runs found, bad settings refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bayesmap.errors import ConfigError, FormatError
from bayesmap.experiments import load
from bayesmap.sweeps.grid import expand, parse_condition, parse_setting, task_key

from . import toy

EXPERIMENT = "sweeps.toy"


def _plan(**kwargs):
    args = {"worlds": None, "seeds": 3, "root_seed": 7} | kwargs
    return expand(EXPERIMENT, toy, **args)


def test_seeds_are_shared_across_worlds_and_conditions_and_stable_when_extended():
    plan = _plan(worlds=2, conditions={"x": {}, "y": {"scale": 2.0}})
    assert len(plan.points) == 2 * 3 * 2
    by_index = {}
    for point in plan.points:
        by_index.setdefault(point.seed_index, set()).add(point.seed)
    assert all(len(seeds) == 1 for seeds in by_index.values())
    assert len({s.pop() for s in by_index.values()}) == 3
    longer = _plan(worlds=2, seeds=5, conditions={"x": {}, "y": {"scale": 2.0}})
    assert {p.task for p in plan.points} <= {p.task for p in longer.points}
    assert _plan(root_seed=8).points[0].seed != plan.points[0].seed


def test_same_request_same_plan():
    a, b = _plan(worlds=3), _plan(worlds=3)
    assert a.to_json() == b.to_json()
    assert [p.world for p in a.points[::3]] == [p.world for p in b.points[::3]]


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


def test_experiments_without_world_support_refuse_worlds():
    with pytest.raises(ConfigError, match="cannot take --worlds.*generate_world"):
        expand("sonar", load("sonar"), worlds=2, seeds=1, root_seed=0)


def test_worlds_from_a_folder(tmp_path):
    for name, offset in [("b", 2.0), ("a", 1.0)]:
        (tmp_path / f"{name}.json").write_text(json.dumps({"offset": offset}))
    (tmp_path / "notes.txt").write_text("not a world")
    plan = _plan(worlds=tmp_path, seeds=1)
    assert [p.world for p in plan.points] == ["a", "b"]
    assert [plan.tasks[p.task].config["world"]["offset"] for p in plan.points] == [1.0, 2.0]
    (tmp_path / "c.json").write_text("{}")
    with pytest.raises(FormatError, match="c.json"):
        _plan(worlds=tmp_path, seeds=1)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="no world files"):
        _plan(worlds=tmp_path / "empty", seeds=1)
    with pytest.raises(ConfigError, match="not a number and not a folder"):
        _plan(worlds=tmp_path / "missing", seeds=1)


def test_blackboard_generates_and_loads_worlds(tmp_path):
    blackboard = load("blackboard")
    world = blackboard.generate_world(np.random.default_rng(3))
    assert len(world["tables"]) == 6 and world["name"].startswith("whisker-tables-v1-")
    assert blackboard.generate_world(np.random.default_rng(3)) == world
    path = tmp_path / "w.yaml"
    path.write_text(json.dumps(world))
    assert blackboard.load_world(path) == world
    path.write_text("tables: [[1, 2]]")
    with pytest.raises(FormatError, match=r"w\.yaml.*x, y, theta"):
        blackboard.load_world(path)
    path.write_text("tables: [[1, 2, .nan]]")
    with pytest.raises(FormatError, match="finite"):
        blackboard.load_world(path)
    plan = expand("blackboard", blackboard, worlds=2, seeds=1, root_seed=0)
    assert len({p.world for p in plan.points}) == 2


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
