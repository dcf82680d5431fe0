"""``bayesmap bn info|query|convert`` on a small network file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import bayesmap.bn as bn
from bayesmap.cli import app

runner = CliRunner()


@pytest.fixture
def rain_file(tmp_path: Path) -> Path:
    net = bn.BayesNet("rain")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2], kind="B")
    net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    path = tmp_path / "rain.xml"
    bn.write(net, path)
    return path


def run_json(*args: str) -> dict:
    result = runner.invoke(app, [*args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_info(rain_file: Path) -> None:
    data = run_json("bn", "info", str(rain_file))
    assert [v["name"] for v in data["variables"]] == ["Rain", "Wet"]
    assert data["variables"][0]["kind"] == "B"
    assert runner.invoke(app, ["bn", "info", str(rain_file)]).exit_code == 0


def test_query_posterior_map_and_proposition(rain_file: Path) -> None:
    data = run_json("bn", "query", str(rain_file), "--target", "Rain", "--evidence", "Wet=yes")
    assert data["posterior"]["yes"] == pytest.approx(0.18 / 0.26)
    data = run_json("bn", "query", str(rain_file), "--map", "-e", "Wet=yes")
    assert data["map"] == {"Rain": "yes"}
    assert data["probability"] == pytest.approx(0.18 / 0.26)
    data = run_json("bn", "query", str(rain_file), "--probability", "Rain=yes or Wet=yes")
    assert data["probability"] == pytest.approx(0.2 + 0.08)
    data = run_json("bn", "query", str(rain_file), "-t", "Rain", "-t", "Wet")
    assert sum(row["p"] for row in data["joint"]) == pytest.approx(1.0)
    text = runner.invoke(app, ["bn", "query", str(rain_file), "-t", "Rain", "-e", "Wet=yes"])
    assert text.exit_code == 0 and "0.692" in text.output


def test_query_fixed_point_reports_the_bound(rain_file: Path) -> None:
    data = run_json(
        "bn", "query", str(rain_file), "-t", "Rain", "-e", "Wet=yes", "--fixed-point", "Q8.24"
    )
    assert data["fixed_point"] == "Q8.24"
    for state, p in data["posterior"].items():
        exact = {"no": 0.08 / 0.26, "yes": 0.18 / 0.26}[state]
        assert abs(p - exact) <= data["error_bound"][state]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["-t", "Snow"], "no variable 'Snow'"),
        (["-t", "Rain", "-e", "Wet=damp"], "no state 'damp'"),
        (["-t", "Rain", "--fixed-point", "Q99"], "Q99"),
        (["--probability", "Rain=yes | Wet=yes"], "write 'or'"),
        (["--probability", "Rain=yes", "--given", "Wet=no and Wet=yes"], "probability zero"),
    ],
)
def test_query_errors_are_reported_not_raised(
    rain_file: Path, args: list[str], needle: str
) -> None:
    result = runner.invoke(app, ["bn", "query", str(rain_file), *args])
    assert result.exit_code == 1
    assert needle in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_convert_round_trip(rain_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "rain.bif"
    result = runner.invoke(app, ["bn", "convert", str(rain_file), str(out)])
    assert result.exit_code == 0, result.output
    assert bn.read(out).structurally_equal(bn.read(rain_file), atol=1e-12)
    missing = runner.invoke(app, ["bn", "convert", str(tmp_path / "nope.xml"), str(out)])
    assert missing.exit_code == 1
