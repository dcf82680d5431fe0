"""``bayesmap rover run`` and ``bayesmap rover generate`` end to end on a small budget."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from bayesmap.cli import app
from bayesmap.grid.ros import read_ros_map

runner = CliRunner()


def test_generate_then_run_writes_metrics_figures_and_map(tmp_path: Path) -> None:
    made = runner.invoke(
        app, ["rover", "generate", "--out", str(tmp_path), "--count", "1", "--size", "20"]
    )
    assert made.exit_code == 0, made.output
    out = tmp_path / "run"
    args = ["rover", "run", "--world", str(tmp_path / "world_00.json"), "--out", str(out)]
    result = runner.invoke(
        app, [*args, "--explorer", "frontier", "--seed", "3", "--max-steps", "40"]
    )
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["steps"] == 40 and metrics["explorer"] == "frontier"
    for key in ("min_clearance_m", "stalled_cycles", "off_map_cycles", "collisions"):
        assert key in metrics
    assert all((out / name).stat().st_size > 0 for name in ("path.png", "map.pgm"))
    assert read_ros_map(out / "map.yaml").occupancy is not None


def test_generated_worlds_come_whole_and_never_mix_with_others(tmp_path: Path) -> None:
    out = tmp_path / "worlds"
    args = ["rover", "generate", "--out", str(out), "--size", "5"]
    assert runner.invoke(app, [*args, "--count", "101"]).exit_code == 0
    names = sorted(p.name for p in out.iterdir())
    assert names[:2] == ["manifest.json", "world_000.json"] and names[-1] == "world_100.json"
    assert runner.invoke(app, [*args, "--count", "2", "--seed", "5"]).exit_code == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "manifest.json",
        "world_00.json",
        "world_01.json",
    ]
    assert json.loads((out / "world_01.json").read_text())["name"].startswith(
        "rover-generated-v2-s5"
    )
    (out / "notes.txt").write_text("mine")
    refused = runner.invoke(app, [*args, "--count", "1"])
    assert refused.exit_code == 1 and "holds 'notes.txt'" in refused.output
    assert (out / "world_01.json").exists() and (out / "notes.txt").read_text() == "mine"


def test_a_bad_world_is_one_line_without_traceback(tmp_path: Path) -> None:
    world = tmp_path / "w.json"
    world.write_text('{"size": [20, 20], "obstacles": [], "start": [1, 1, "[red]x"]}')
    result = runner.invoke(app, ["rover", "run", "--world", str(world), "--out", str(tmp_path)])
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    assert "start[2]" in result.output and "[red]x" in result.output


def test_schema_prints_the_world_json_schema() -> None:
    result = runner.invoke(app, ["rover", "schema"])
    assert result.exit_code == 0
    schema = json.loads(result.output)
    assert schema["required"] == ["size", "obstacles", "start"]
