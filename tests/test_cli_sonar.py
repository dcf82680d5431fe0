"""Tests of ``bayesmap sonar map`` on the example real-format logs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from bayesmap.cli import app
from bayesmap.grid.ros import read_ros_map

DATA = Path(__file__).parent / "sonar" / "data"
ANGLES = ",".join(str(22.5 * k) for k in range(16))
runner = CliRunner()


def _map(out: Path, *extra: str, log: str = "example_log.txt") -> object:
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
        "--resolution",
        "0.2",
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
    assert set(summary["rejected"]) == {"acceptability", "agreeability", "trait_verification"}
    assert sum(summary["rejected"].values()) > 0
    assert [row["line"] for row in summary["skipped"]] == [13, 21, 31, 41]
    assert (tmp_path / "map.png").stat().st_size > 1000
    ros = read_ros_map(tmp_path / "map.yaml")
    assert ros.resolution == pytest.approx(0.2)
    assert ros.probability.shape == tuple(summary["map"]["shape"])


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
    assert summary["rows_skipped"] == 2 and summary["poses"].endswith("example_poses.csv")


def test_bad_angles_are_an_input_error(tmp_path: Path) -> None:
    result = runner.invoke(
        app,
        [
            "sonar",
            "map",
            str(DATA / "example_log.txt"),
            "--angles-deg",
            "0,abc",
            "--max-range",
            "5",
            "--resolution",
            "0.1",
            "--out",
            str(tmp_path),
        ],
    )
    assert result.exit_code != 0
