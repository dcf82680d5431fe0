"""Tests of ``bayesmap blackboard run`` and ``bayesmap blackboard world``."""

from __future__ import annotations

import json
import math
from pathlib import Path

from typer.testing import CliRunner

from bayesmap.cli import app

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
