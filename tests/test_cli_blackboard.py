"""Tests of ``bayesmap blackboard run``, ``map`` and ``world``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from bayesmap._io import verify_run_folder
from bayesmap.blackboard.fused import FusedMapper
from bayesmap.blackboard.logs import write_sweep_log
from bayesmap.cli import app
from bayesmap.experiments.blackboard_world import catalogue_of
from bayesmap.experiments.fused_run import fused_params
from bayesmap.sim.whisker_worlds import parse_world
from bayesmap.sim.whiskers import WhiskerParams, condition, observe

runner = CliRunner()

ROOM = {
    "arena": {"width": 4.0, "height": 3.0},
    "tables": [{"x": 2.0, "y": 1.5, "theta": 0.4, "length": 1.2, "width": 0.8, "leg": 0.1}],
    # six spots around the desk, each within a whisker's length (1 m) of one of its legs
    "poses": [
        [x, y, h * math.pi / 2]
        for x, y in ((1.0, 0.5), (3.0, 0.5), (1.0, 2.5), (3.0, 2.5), (0.5, 1.5), (3.5, 1.5))
        for h in range(4)
    ],
    "catalogue": [
        {"name": "desk", "length": 1.2, "width": 0.8, "leg": 0.1},
        {"name": "stool", "length": 0.8, "width": 0.8, "leg": 0.08},
    ],
}


def _run(tmp_path: Path, room: dict) -> tuple[Path, dict, str]:
    """``bayesmap blackboard run`` on ``room``: its output folder, metrics and printed text."""
    world = tmp_path / "room.json"
    world.write_text(json.dumps(room))
    out = tmp_path / "out"
    result = runner.invoke(app, ["blackboard", "run", "--world", str(world), "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out, json.loads((out / "metrics.json").read_text()), result.output


def test_run_writes_metrics_map_and_figure(tmp_path: Path) -> None:
    out, metrics, _ = _run(tmp_path, ROOM)
    for key in (
        "fused_precision",
        "fused_recall",
        "fused_wall_phantoms",
        "fused_gospa",
        "fused_position_error_mean",
        "fused_angle_error_mean",
        "type_accuracy",
        "precision",
        "recall",
        "contacts_mean",
        "contacts_std",
        "per_pose_ms_median",
        "per_pose_ms_p95",
        "wall_s",
    ):
        assert key in metrics, key
    assert metrics["fused_precision"] == 1.0 and metrics["fused_recall"] == 1.0
    assert metrics["tables_touched"] == 1
    objects = json.loads((out / "map.json").read_text())["objects"]
    for row in objects:
        assert row["type"] in ("desk", "stool") and 0.0 <= row["existence_probability"] <= 1.0
        assert set(row) >= {"type", "length", "width", "x", "y", "theta", "existence_probability"}
    assert (out / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_tour_that_touches_no_table_says_why_its_map_is_empty(tmp_path: Path) -> None:
    """Poses in the room's corners, every leg over a whisker's length away: the map is empty,
    its undefined precision is JSON null, and the run says which tables no whisker touched."""
    room = json.loads(json.dumps(ROOM))
    room["poses"] = [
        [x, y, h * math.pi / 2] for x in (0.5, 3.5) for y in (0.5, 2.5) for h in range(4)
    ]
    _, metrics, output = _run(tmp_path, room)
    assert metrics["fused_objects"] == 0 and metrics["fused_precision"] is None
    assert metrics["tables_touched"] == 0
    assert "1 of the world's 1 tables were never touched by a whisker" in output
    assert "fused_precision undefined" in output


def test_a_bad_world_is_one_line_naming_the_element(tmp_path: Path) -> None:
    room = json.loads(json.dumps(ROOM))
    room["tables"][0]["x"] = 0.2  # crosses the wall x = 0
    world = tmp_path / "[bad] room.json"
    world.write_text(json.dumps(room))
    result = runner.invoke(
        app, ["blackboard", "run", "--world", str(world), "--out", str(tmp_path / "o")]
    )
    assert result.exit_code == 1
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "[bad] room.json" in lines[0] and "tables[0]" in lines[0]
    assert "Traceback" not in result.output
    assert not (tmp_path / "o" / "metrics.json").exists()


def test_world_command_writes_a_loadable_world(tmp_path: Path) -> None:
    from bayesmap.sim.whisker_worlds import load_world

    result = runner.invoke(app, ["blackboard", "world", str(tmp_path / "w.json"), "--seed", "3"])
    assert result.exit_code == 0, result.output
    assert 4 <= len(load_world(tmp_path / "w.json").tables) <= 10


def test_paper_mode_maps_with_the_catalogues_largest_type(tmp_path: Path) -> None:
    """The paper's one-size model gets the catalogue's largest type, not sizes read off
    the true tables (a 1.1 x 0.75 m table here, off the catalogue)."""
    room = dict(ROOM, tables=[dict(ROOM["tables"][0], length=1.1, width=0.75, leg=0.09)])
    world = tmp_path / "room.json"
    world.write_text(json.dumps(room))
    out = tmp_path / "out"
    args = ["blackboard", "run", "--world", str(world), "--out", str(out), "--mode", "paper"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    objects = json.loads((out / "map.json").read_text())["objects"]
    assert objects and {(o["length"], o["width"], o["leg"]) for o in objects} == {(1.2, 0.8, 0.1)}


def _logged_tour(tmp_path: Path) -> tuple[Path, Path, np.ndarray, list[np.ndarray]]:
    """ROOM's tour simulated, written as a sweep log: the log, the room file, the tour."""
    room = parse_world(ROOM)
    poses = room.robot_poses()
    rng = np.random.default_rng(11)
    sweeps = [observe(room.world(), p, condition("normal"), rng=rng).sweeps for p in poses]
    world = tmp_path / "room.json"
    world.write_text(json.dumps(ROOM))
    return write_sweep_log(tmp_path / "tour.csv", poses, sweeps), world, poses, sweeps


def test_a_world_is_written_only_to_a_json_file(tmp_path: Path) -> None:
    log = tmp_path / "tour.csv"
    log.write_text("pose,x\n")
    result = runner.invoke(app, ["blackboard", "world", str(log)])
    assert result.exit_code == 2 and "ends in .json" in result.output
    assert log.read_text() == "pose,x\n"
    assert runner.invoke(app, ["blackboard", "world", str(tmp_path / "w.json")]).exit_code == 0


def test_map_of_a_logged_tour_is_the_mappers_own_and_is_scored(tmp_path: Path) -> None:
    log, world, poses, sweeps = _logged_tour(tmp_path)
    out = tmp_path / "out"
    args = ["blackboard", "map", str(log), "--world", str(world), "--out", str(out)]
    result = runner.invoke(app, [*args, "--seed", "4"])
    assert result.exit_code == 0, result.output
    assert f"{len(poses)} poses" in result.output and "fused_precision" in result.output
    # the same sweeps straight into the mapper, with the same settings and seed
    room = parse_world(ROOM)
    params = fused_params(WhiskerParams(sigma_r=0.02, sigma_theta=0.05, whisker_length=1.0))
    mapper = FusedMapper(catalogue_of(room), room.arena, params)
    rng = np.random.default_rng(4)
    for pose, rows in zip(poses, sweeps, strict=True):
        mapper.step(pose, rows, rng=rng)
    expected = mapper.finish(rng=rng).objects()
    assert json.loads((out / "map.json").read_text())["objects"] == json.loads(json.dumps(expected))
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["fused_precision"] == 1.0 and metrics["fused_recall"] == 1.0
    assert metrics["contacts"] == sum(int(np.isfinite(s[:, 3]).sum()) for s in sweeps)
    assert metrics["doubtful"] == 0 and "left off" not in result.output
    assert (out / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert verify_run_folder(out)["seed"] == 4  # written whole, with its manifest
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    args = ["blackboard", "map", str(log), "--world", str(world), "--out", str(mine)]
    refused = runner.invoke(app, args)
    assert refused.exit_code == 1 and "no manifest.json" in refused.output
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]


def test_a_log_in_a_room_without_truth_and_its_mistakes(tmp_path: Path) -> None:
    log, _, _, _ = _logged_tour(tmp_path)
    unknown = tmp_path / "unknown.json"
    unknown.write_text(json.dumps({**ROOM, "tables": []}))  # the catalogue names the types
    out = tmp_path / "out"
    args = ["blackboard", "map", str(log), "--world", str(unknown), "--out", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "fused_precision" not in json.loads((out / "metrics.json").read_text())
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps({"arena": ROOM["arena"], "tables": []}))
    result = runner.invoke(
        app, ["blackboard", "map", str(log), "--world", str(bare), "--out", str(out)]
    )
    assert result.exit_code == 1 and "must list its catalogue" in result.output
    # a log in millimetres read as metres: its poses lie far outside a 4 m room
    table = pd.read_csv(log)
    table[["x", "y", "length", "range"]] *= 1000.0
    table.to_csv(log, index=False)
    result = runner.invoke(app, args)
    assert result.exit_code == 1 and "outside" in result.output and "Traceback" not in result.output
    result = runner.invoke(app, [*args, "--length-unit", "mm"])
    assert result.exit_code == 0, result.output
    assert "warning" not in result.output
    # and in degrees read as radians: mapped, with a hint
    table[["heading", "start", "stop", "normal"]] = np.degrees(
        table[["heading", "start", "stop", "normal"]]
    )
    table.to_csv(log, index=False)
    result = runner.invoke(app, [*args, "--length-unit", "mm"])
    assert result.exit_code == 0 and "if the log is in degrees, give --angle-unit deg" in (
        result.output
    )


BOXES = {
    "arena": {"width": 4.0, "height": 3.0},
    "tables": [
        {"x": 1.2, "y": 1.5, "theta": 0.0, "length": 1.2, "width": 0.8, "leg": 0.1},
        *(
            {"x": x, "y": 1.0, "theta": 0.0, "length": 0.3, "width": 0.3, "leg": 0.15}
            for x in (2.9, 3.25, 3.6)
        ),
    ],
    "poses": {"grid": 8, "margin": 0.4, "headings": 4},
    "catalogue": [{"name": "desk", "length": 1.2, "width": 0.8, "leg": 0.1}],
}
"""A desk and a row of three boxes the catalogue does not list: desks laid over the boxes
are left off the map as doubtful."""


def test_both_commands_say_how_many_objects_were_left_off_the_map(tmp_path: Path) -> None:
    world = tmp_path / "boxes.json"
    world.write_text(json.dumps(BOXES))
    out = tmp_path / "run"
    result = runner.invoke(app, ["blackboard", "run", "--world", str(world), "--out", str(out)])
    assert result.exit_code == 0, result.output
    doubtful = json.loads((out / "map.json").read_text())["doubtful"]
    assert doubtful and f"doubtful (dashed in map.png) {len(doubtful)}" in result.output
    room = parse_world(BOXES)
    poses = room.robot_poses()
    # the sensor stream of ``blackboard run --seed 1``; desks over the boxes are in the MAP
    # of this tour's chain for seeds 0-2 (and on the map for none)
    rng = np.random.default_rng(np.random.SeedSequence(1).spawn(2)[0])
    sweeps = [observe(room.world(), p, condition("normal"), rng=rng).sweeps for p in poses]
    log = write_sweep_log(tmp_path / "tour.csv", poses, sweeps)
    out = tmp_path / "map"
    args = ["blackboard", "map", str(log), "--world", str(world), "--out", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    left_off = json.loads((out / "metrics.json").read_text())["doubtful"]
    assert left_off == len(json.loads((out / "map.json").read_text())["doubtful"]) > 0
    assert f"({left_off} more left off as doubtful, dashed in map.png)" in " ".join(
        result.output.split()
    )
