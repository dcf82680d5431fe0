"""``bayesmap bn codegen``: files written, errors as one literal line."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import bayesmap.bn as bn
from bayesmap.cli import app

runner = CliRunner()


@pytest.fixture
def rain_file(tmp_path: Path) -> Path:
    net = bn.BayesNet("rain")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Sprinkler", ["off", "on"], parents=["Rain"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    net.add_variable(
        "Wet",
        ["no", "yes"],
        parents=["Rain", "Sprinkler"],
        cpt=[[[1, 0.1], [0.2, 0.01]], [[0, 0.9], [0.8, 0.99]]],
    )
    path = tmp_path / "rain.xml"
    bn.write(net, path)
    return path


def test_codegen_writes_header_and_source(rain_file, tmp_path):
    out = tmp_path / "c"
    result = runner.invoke(
        app,
        [
            "bn",
            "codegen",
            str(rain_file),
            "--out",
            str(out),
            "--target",
            "Rain",
            "--evidence",
            "Wet,Sprinkler",
            "--arith",
            "q8.24",
        ],
    )
    assert result.exit_code == 0, result.output
    header = (out / "rain.h").read_text()
    assert "#define RAIN_EV_WET 0" in header and "#define RAIN_EV_SPRINKLER 1" in header
    assert "RAIN_FRAC_BITS 24" in header
    assert "int rain_posterior_Rain(" in (out / "rain.c").read_text()
    assert "4 pattern functions" in result.output


def test_codegen_name_and_soft_evidence(rain_file, tmp_path):
    result = runner.invoke(
        app,
        [
            "bn",
            "codegen",
            str(rain_file),
            "-o",
            str(tmp_path),
            "-t",
            "Rain",
            "-t",
            "Sprinkler",
            "--soft",
            "Wet",
            "--arith",
            "double",
            "--name",
            "garden",
        ],
    )
    assert result.exit_code == 0, result.output
    header = (tmp_path / "garden.h").read_text()
    assert "typedef double garden_value;" in header and "#define GARDEN_SOFT_WET 0" in header


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["-t", "Rain", "-e", "Rain"], "both a target and evidence"),
        (["-t", "[red]Nope[/red]"], "no variable '[red]Nope[/red]'"),
        (["-t", "Rain", "--arith", "q40.40"], "Q40.40 is not supported"),
        (["-t", "Rain", "--name", "9lives"], "cannot prefix C names"),
    ],
)
def test_codegen_errors_are_one_literal_line(rain_file, tmp_path, args, message):
    a_file = tmp_path / "a_file"
    a_file.write_text("mine")
    result = runner.invoke(app, ["bn", "codegen", str(rain_file), "-o", str(a_file), "-t", "Rain"])
    assert result.exit_code == 1 and "is a file" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and a_file.read_text() == "mine"
    result = runner.invoke(app, ["bn", "codegen", str(rain_file), "-o", str(tmp_path), *args])
    assert result.exit_code == 1
    assert message in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.output
