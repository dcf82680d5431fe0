"""Tests of ``bayesmap sonar map`` on the example real-format logs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.sonar.helpers import carmen_lines, player_lines, simulated_drive, write_log_lines
from typer.testing import CliRunner

from bayesmap.cli import app
from bayesmap.grid.ros import read_ros_map

DATA = Path(__file__).parent / "sonar" / "data"
ANGLES = ",".join(str(22.5 * k) for k in range(16))
runner = CliRunner()


def _map(
    out: Path, *extra: str, log: str = "example_log.txt", resolution: str | None = "0.2"
) -> object:
    args = [
        "sonar",
        "map",
        str(DATA / log),
        "--angles-deg",
        ANGLES,
        "--range-unit",
        "mm",
        "--position-unit",
        "mm",
        "--heading-unit",
        "deg",
        "--max-range",
        "5000",
        *(["--resolution", resolution] if resolution is not None else []),
        "--out",
        str(out),
        *extra,
    ]
    return runner.invoke(app, args)


def test_map_writes_png_ros_map_and_summary(tmp_path: Path) -> None:
    result = _map(tmp_path)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["rows"] == 146 and summary["rows_skipped"] == 4
    assert summary["readings"] == (146 - 4) * 16
    assert set(summary["rejected"]) == {
        "acceptability",
        "agreeability",
        "trait_verification",
        "map_verdict",
    }
    assert sum(summary["rejected"].values()) > 0
    assert [row["line"] for row in summary["skipped"]] == [13, 21, 31, 41]
    assert (tmp_path / "map.png").stat().st_size > 1000
    ros = read_ros_map(tmp_path / "map.yaml")
    assert ros.resolution == pytest.approx(0.2)
    assert ros.probability.shape == tuple(summary["map"]["shape"])


def test_the_cell_side_defaults_to_the_experiments(tmp_path: Path) -> None:
    result = _map(tmp_path, resolution=None)
    assert result.exit_code == 0, result.output
    assert read_ros_map(tmp_path / "map.yaml").resolution == pytest.approx(0.1)


def test_no_filter_rejects_nothing_and_strict_aborts(tmp_path: Path) -> None:
    result = _map(tmp_path / "plain", "--no-filter")
    assert result.exit_code == 0, result.output
    assert (
        sum(json.loads((tmp_path / "plain" / "summary.json").read_text())["rejected"].values()) == 0
    )
    result = _map(tmp_path / "strict", "--strict")
    assert result.exit_code != 0
    assert not (tmp_path / "strict" / "summary.json").exists()


def test_two_file_log(tmp_path: Path) -> None:
    args = [
        "sonar",
        "map",
        str(DATA / "example_ranges.csv"),
        "--poses",
        str(DATA / "example_poses.csv"),
        "--angles-deg",
        ANGLES,
        "--range-unit",
        "cm",
        "--position-unit",
        "cm",
        "--heading-unit",
        "rad",
        "--max-range",
        "500",
        "--resolution",
        "0.2",
        "--out",
        str(tmp_path),
    ]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    # The two ranges rows without a pose of their own get one interpolated from their neighbours.
    assert summary["rows_skipped"] == 0 and summary["poses"].endswith("example_poses.csv")
    result = runner.invoke(app, [*args, "--max-pose-gap", "0", "--pose-tolerance", "0.000001"])
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [row["line"] for row in summary["skipped"]] == [8, 9]
    poses = tmp_path / "poses.csv"
    lines = (DATA / "example_poses.csv").read_text().splitlines()
    poses.write_text("\n".join([lines[0], "1e9 nan nan nan", *lines[1:]]) + "\n")
    result = runner.invoke(app, [*args[:4], str(poses), *args[5:-1], str(tmp_path / "p")])
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert summary["rows_skipped"] == 0 and summary["pose_rows_skipped"] == 1
    assert "(0 skipped; 1 pose rows skipped)" in result.output


@pytest.mark.parametrize(
    ("angles", "words"),
    [
        ("0,abc", "must be comma-separated numbers"),
        ("0,,22.5", "must be comma-separated numbers"),
        ("nan,1,15", "angles must be finite"),
        ("45", "at least two angles"),
    ],
)
def test_bad_angles_are_an_input_error(tmp_path: Path, angles: str, words: str) -> None:
    result = runner.invoke(
        app,
        [
            "sonar",
            "map",
            str(DATA / "example_log.txt"),
            "--angles-deg",
            angles,
            "--max-range",
            "5",
            "--resolution",
            "0.1",
            "--out",
            str(tmp_path),
        ],
    )
    assert result.exit_code != 0 and words in _text(result)


def test_poses_with_a_bag_are_refused(tmp_path: Path) -> None:
    result = _map(
        tmp_path / "o", "--topics", ",".join(f"/s{k}" for k in range(16)), "--poses", "p.csv"
    )
    assert result.exit_code != 0 and "a bag's poses come from --pose-topic" in _text(result)
    twice = ",".join(["/s0", *(f"/s{k}" for k in range(15))])
    result = _map(tmp_path / "o", "--topics", twice)
    assert result.exit_code == 2 and "--topics names /s0 twice" in _text(result)


def _text(result: object) -> str:
    out = getattr(result, "output", "")
    try:
        err = getattr(result, "stderr", "")
    except ValueError:
        err = ""
    return f"{out}\n{err}"


def test_out_naming_a_file_is_a_one_line_error(tmp_path: Path) -> None:
    target = tmp_path / "taken.txt"
    target.write_text("keep me")
    result = _map(target)
    assert result.exit_code == 1
    assert "is a file" in _text(result) and "Traceback" not in _text(result)
    assert target.read_text() == "keep me"


def test_forgotten_position_unit_is_refused_before_allocating(tmp_path: Path) -> None:
    args = [
        "sonar", "map", str(DATA / "example_log.txt"), "--angles-deg", ANGLES,
        "--range-unit", "mm", "--heading-unit", "deg", "--max-range", "5000",
        "--resolution", "0.01", "--out", str(tmp_path / "o"), "--max-cells", "1000000",
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 1
    text = _text(result)
    assert "cells" in text and "Traceback" not in text and "position unit" in text


def test_a_cell_side_in_cm_is_refused(tmp_path: Path) -> None:
    args = [
        "sonar", "map", str(DATA / "example_log.txt"), "--angles-deg", ANGLES,
        "--range-unit", "mm", "--position-unit", "mm", "--heading-unit", "deg",
        "--resolution", "10", "--out", str(tmp_path / "o"),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 1
    text = _text(result)
    assert "--resolution is 10 m" in text and "cm or mm" in text and "Traceback" not in text
    assert not (tmp_path / "o").exists()


def test_max_range_in_the_wrong_unit_is_refused(tmp_path: Path) -> None:
    args = [
        "sonar", "map", str(DATA / "example_log.txt"), "--angles-deg", ANGLES,
        "--range-unit", "mm", "--position-unit", "mm", "--heading-unit", "deg",
        "--resolution", "0.2", "--out", str(tmp_path / "out"), "--max-range",
    ]  # fmt: skip
    result = runner.invoke(app, [*args, "5"])  # 5 m meant, read as 5 mm
    assert result.exit_code == 1 and not (tmp_path / "out").exists()
    assert "--max-range 5 in --range-unit mm is 0.005 m, shorter than any sonar" in _text(result)
    result = runner.invoke(app, [*args, "5", "--range-unit", "m"])  # ranges in mm as metres
    assert result.exit_code == 0, _text(result)
    assert "100 % of readings are at or above the max range (5 m)" in _text(result)
    result = runner.invoke(app, [*args, "5e7"])
    assert result.exit_code == 1 and "is 50000 m, beyond any sonar's reach" in _text(result)


def test_ring_preset_pipeline_choice_and_literal_messages(tmp_path: Path) -> None:
    base = [
        "sonar", "map", str(DATA / "example_log.txt"), "--range-unit", "mm",
        "--position-unit", "mm", "--heading-unit", "deg", "--resolution", "0.2",
    ]  # fmt: skip
    result = runner.invoke(app, [*base, "--ring", "pioneer16", "--out", str(tmp_path / "a")])
    assert result.exit_code == 0, _text(result)
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["pipeline"] == "default"
    result = runner.invoke(
        app, [*base, "--ring", "pioneer16", "--pipeline", "ros", "--out", str(tmp_path / "b")]
    )
    assert result.exit_code == 0
    assert json.loads((tmp_path / "b" / "summary.json").read_text())["filter"] is False
    ring = tmp_path / "[m]ring.yaml"
    result = runner.invoke(app, [*base, "--ring", str(ring), "--out", str(tmp_path / "c")])
    assert result.exit_code == 1 and "[m]ring.yaml" in _text(result)


def test_a_pioneers_bearings_given_alone_get_a_hint_to_use_its_preset(tmp_path: Path) -> None:
    base = [
        "sonar", "map", str(DATA / "example_log.txt"), "--range-unit", "mm",
        "--position-unit", "mm", "--heading-unit", "deg", "--resolution", "0.2",
        "--max-range", "5000",
    ]  # fmt: skip
    # the Pioneer 3-DX front array's bearings, in its order, to a degree
    front = "90,50,30,10,-10,-30,-50,-90.5"
    result = runner.invoke(app, [*base, "--angles-deg", front, "--out", str(tmp_path / "a")])
    # (the example log has 16 readings a ring: the ring is refused after the hint)
    assert "bearings of the pioneer8 ring" in _text(result)
    assert "--ring pioneer8" in _text(result)
    result = runner.invoke(app, [*base, "--angles-deg", ANGLES, "--out", str(tmp_path / "b")])
    assert result.exit_code == 0 and "bearings of the" not in _text(result)


def test_sigma_follows_the_range_unit() -> None:
    from bayesmap.cli.sonar import _geometry

    geometry = _geometry(None, "0,90,180,270", 5000.0, None, 20.0, "mm")
    assert geometry.sigma == pytest.approx(0.02) and geometry.max_range == pytest.approx(5.0)


def test_a_map_folder_is_replaced_whole_with_a_manifest(tmp_path: Path) -> None:
    """The outputs appear together, listed in manifest.json; a second run replaces them whole;
    a folder of someone else's files, or a run's folder a file was put in since (the log,
    say), is refused rather than overwritten."""
    out = tmp_path / "map"
    assert _map(out).exit_code == 0
    manifest = json.loads((out / "manifest.json").read_text())
    listed = {entry["path"] for entry in manifest["files"]}
    assert {"map.png", "map.yaml", "map.pgm", "summary.json"} <= listed
    assert manifest["configuration"]["resolution_m"] == 0.2
    (out / "log.txt").write_text("put here since")
    result = _map(out, "--no-filter")
    assert result.exit_code != 0 and "holds 'log.txt'" in result.output
    assert (out / "log.txt").read_text() == "put here since"
    (out / "log.txt").unlink()
    assert _map(out, "--no-filter").exit_code == 0
    replaced = json.loads((out / "manifest.json").read_text())
    assert replaced["started"] >= manifest["finished"]
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["manifest.json", *(entry["path"] for entry in replaced["files"])]
    )
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    result = _map(foreign)
    assert result.exit_code == 1 and (foreign / "notes.txt").read_text() == "keep me"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.slow
def test_run_scores_the_pipelines_on_a_world_file(tmp_path: Path) -> None:
    import numpy as np

    from bayesmap.sim.sonar_worlds import generate_world, save_world

    world = save_world(generate_world(np.random.default_rng(5)), tmp_path / "world.json")
    out = tmp_path / "run"
    args = ["sonar", "run", "--world", str(world), "--out", str(out), "--runs", "1"]
    result = runner.invoke(app, [*args, "--pipeline", "default", "--pipeline", "elfes"])
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["pipelines"] == ["default", "elfes"]
    (record,) = metrics["runs"]
    assert set(record["pipelines"]) == {"default", "elfes"}
    assert -1.0 <= record["pipelines"]["default"]["kappa"] <= 1.0
    assert list(out.glob("maps_*.png"))


def test_run_names_a_bad_world_file_or_pipeline_in_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "world.json"
    bad.write_text("{not json")
    out = tmp_path / "run"
    result = runner.invoke(app, ["sonar", "run", "--world", str(bad), "--out", str(out)])
    assert result.exit_code == 1
    assert "world.json" in result.output and "Traceback" not in result.output
    assert not out.exists()
    args = ["sonar", "run", "--world", str(bad), "--out", str(out), "--pipeline", "best"]
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and "unknown pipeline 'best'" in result.output
    in_mm = {"outline": [[0, 0], [4e5, 0], [4e5, 3e5], [0, 3e5]], "waypoints": [[1, 1], [5, 5]]}
    bad.write_text(json.dumps(in_mm))
    result = runner.invoke(app, ["sonar", "run", "--world", str(bad), "--out", str(out)])
    assert result.exit_code == 1 and not out.exists()
    assert "world.json: a 400002 m x 300002 m grid" in result.output and "mm?" in result.output


def _map_file(log: Path, out: Path, *extra: str) -> object:
    return runner.invoke(
        app, ["sonar", "map", str(log), "--resolution", "0.2", "--out", str(out), *extra]
    )


def test_a_player_log_is_mapped_with_the_ring_it_describes(tmp_path: Path) -> None:
    log = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive()))
    result = _map_file(log, tmp_path / "o")
    assert result.exit_code == 0, _text(result)
    assert "ring: the log's sonar geometry, 16 transducers, 25 deg beams, max range 5 m" in _text(
        result
    )
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["readings"] == 240 * 16 and summary["rows_skipped"] == 0
    assert summary["rows"] == 240 + 121 + 1  # sonar, odometry and geometry lines
    manifest = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert manifest["configuration"]["format"] == "player"
    assert read_ros_map(tmp_path / "o" / "map.yaml").resolution == pytest.approx(0.2)
    old = write_log_lines(tmp_path / "old.log", player_lines(simulated_drive(), "0.2.0", False))
    given = ["--format", "player", "--ring", "pioneer16", "--max-range", "5"]
    result = _map_file(old, tmp_path / "p", *given, "--sonar-index", "0")
    assert result.exit_code == 0, _text(result)
    assert "sonar geometry" not in _text(result)


def test_a_carmen_log_is_mapped_as_the_player_log_of_the_same_drive(tmp_path: Path) -> None:
    drive = simulated_drive()
    carmen = write_log_lines(tmp_path / "drive.clf", carmen_lines(drive))
    result = _map_file(carmen, tmp_path / "c")
    assert result.exit_code == 0, _text(result)
    assert "ring: the log's sonar geometry, 16 transducers, 25 deg beams" in _text(result)
    manifest = json.loads((tmp_path / "c" / "manifest.json").read_text())
    assert manifest["configuration"]["format"] == "carmen"
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    assert summary["readings"] == 240 * 16 and summary["rows"] == 240 + 121
    player = write_log_lines(tmp_path / "drive.log", player_lines(drive))
    assert _map_file(player, tmp_path / "p").exit_code == 0
    ours, theirs = (read_ros_map(tmp_path / d / "map.yaml").probability for d in "cp")
    assert np.mean(ours == theirs) > 0.999  # poses differ by CARMEN's and Player's rounding
    result = _map_file(carmen, tmp_path / "l", "--clock", "logger", "--format", "carmen")
    assert result.exit_code == 0, _text(result)


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--poses", "p.txt"], "--poses is for text logs; a Player log holds its own odometry"),
        (["--clock", "logger"], "--clock is for CARMEN logs; LOG is read as player"),
        (["--range-unit", "mm"], "a Player log is in metres, radians and seconds"),
        (["--time-unit", "ns"], "a Player log is in metres, radians and seconds"),
        (["--format", "text", "--sonar-index", "1"], "--sonar-index is for Player logs"),
        (["--format", "player", "--topics", "/a,/b"], "--format player is for log files"),
        (["--pose-tolerance", "nan"], "--pose-tolerance must be a number of seconds, got nan"),
        (["--max-cells", "-1"], "greater than or equal to 1"),
    ],
)
def test_options_that_do_not_go_with_the_format_exit_2(
    tmp_path: Path, extra: list[str], words: str
) -> None:
    log = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive())[:40])
    result = _map_file(log, tmp_path / "o", *extra)
    assert result.exit_code == 2 and words in _text(result)
    assert "Traceback" not in _text(result) and not (tmp_path / "o").exists()


def test_a_beam_width_of_a_half_turn_or_more_is_refused_in_degrees(tmp_path: Path) -> None:
    log = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive())[:40])
    result = _map_file(log, tmp_path / "o", "--beam-width-deg", "720")
    assert result.exit_code == 1 and "--beam-width-deg must be below 180" in _text(result)


def test_a_carmen_log_with_options_of_other_formats_exits_2(tmp_path: Path) -> None:
    log = write_log_lines(tmp_path / "drive.clf", carmen_lines(simulated_drive())[:40])
    result = _map_file(log, tmp_path / "o", "--sonar-index", "1")
    assert result.exit_code == 2 and "--sonar-index is for Player logs; LOG is read as carmen" in (
        _text(result)
    )
    result = _map_file(log, tmp_path / "o", "--heading-unit", "deg")
    assert result.exit_code == 2 and "a CARMEN log is in metres, radians and seconds" in (
        _text(result)
    )
    result = _map_file(DATA / "example_log.txt", tmp_path / "o", "--format", "carmen")
    assert result.exit_code == 1 and "no SONAR lines" in _text(result)
    assert not (tmp_path / "o").exists()


def test_player_logs_that_cannot_be_mapped_are_one_line_errors(tmp_path: Path) -> None:
    result = _map_file(DATA / "example_log.txt", tmp_path / "o", "--format", "player")
    assert result.exit_code == 1 and "not a Player log" in _text(result)
    bare = player_lines(simulated_drive(), geometry=False)[:40]
    result = _map_file(write_log_lines(tmp_path / "bare.log", bare), tmp_path / "o")
    assert result.exit_code == 1 and "no usable sonar geometry" in _text(result)
    result = _map_file(tmp_path / "bare.log", tmp_path / "o", "--ring", "pioneer8")
    assert result.exit_code == 1
    assert "the log's rings hold 16 ranges, the ring has 8 transducers" in _text(result)
    assert "Traceback" not in _text(result) and not (tmp_path / "o").exists()
