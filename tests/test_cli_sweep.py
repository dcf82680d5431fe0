"""``bayesmap sweep`` and ``bayesmap report`` from the command line: files, errors, resume."""

from __future__ import annotations

import json

import pandas as pd
from typer.testing import CliRunner

from bayesmap.cli import app

runner = CliRunner()


def _sweep(out, *extra):
    args = ["sweep", "sweeps.toy", "--worlds", "2", "--seeds", "2", "--serial", "--out", str(out)]
    return runner.invoke(app, [*args, *extra])


def test_a_sweep_writes_tables_and_a_report_and_resumes(tmp_path):
    result = _sweep(tmp_path, "--condition", "base", "--condition", "twice:scale=2")
    assert result.exit_code == 0, result.output
    assert "8 grid point(s), 8 distinct run(s)" in result.output
    assert "ran 8, skipped 0" in result.output
    assert "1 worker process(es) busy" in result.output  # --serial: this process
    # toy method b is a plus one on the same noise: every pair differs by exactly -1
    assert "value: base / a − base / b = -1 (95 % CI -1 to -1, 4 pairs)" in result.output
    tidy = pd.read_parquet(tmp_path / "tidy.parquet")
    assert len(tidy) == 16 and set(tidy["condition"]) == {"base", "twice"}
    assert pd.read_csv(tmp_path / "tidy.csv").shape == tidy.shape
    assert (tmp_path / "report.html").read_text().count("data:image/png;base64,") == 2
    again = _sweep(tmp_path, "--condition", "base", "--condition", "twice:scale=2")
    assert again.exit_code == 0 and "ran 0, skipped 8" in again.output
    assert "busy" not in again.output  # nothing ran, nothing to account for
    out = tmp_path / "elsewhere.html"
    report = runner.invoke(app, ["report", str(tmp_path), "--out", str(out)])
    assert report.exit_code == 0 and out.read_text().startswith("<!DOCTYPE html>")
    pdf = runner.invoke(app, ["report", str(tmp_path), "--out", str(tmp_path / "r.pdf")])
    assert pdf.exit_code == 2 and "an HTML page" in pdf.output
    record = runner.invoke(app, ["report", str(tmp_path / "sweep.json"), "--out", str(out)])
    assert record.exit_code == 2 and "give the sweep's folder" in record.output


def test_failures_are_listed_and_the_exit_status_says_so(tmp_path):
    result = _sweep(tmp_path, "--condition", "ok", "--condition", "bad:fail=true")
    assert result.exit_code == 1
    assert result.output.count("failed ") >= 4
    assert "the toy experiment was told to fail" in result.output
    assert len(json.loads((tmp_path / "failures.json").read_text())) == 4
    assert len(pd.read_parquet(tmp_path / "tidy.parquet")) == 8


def test_a_report_of_a_sweep_with_no_finished_task_is_an_error(tmp_path):
    result = _sweep(tmp_path / "s", "--condition", "bad:fail=true")
    assert result.exit_code == 1 and "the toy experiment was told to fail" in result.output
    report = runner.invoke(app, ["report", str(tmp_path / "s"), "--out", str(tmp_path / "r.html")])
    assert report.exit_code == 1 and "none of the sweep's 4 tasks has finished" in report.output
    assert not (tmp_path / "r.html").exists()


def test_bad_requests_get_one_line_errors_and_write_nothing(tmp_path):
    cases = [
        (["--set", "nope=1"], "unknown setting(s) nope"),
        (["--set", "scale"], "expected KEY=VALUE"),
        (["--set", "scale=[1"], "not valid YAML"),
        (["--condition", "x:scale=[big]"], "condition 'x'"),
        (["--set", "scale=2", "--set", "scale=3"], "--set scale is given more than once"),
        (["--scheduler", "tcp://127.0.0.1:1"], "give it without --serial"),  # _sweep: serial
        (["--workers", "2"], "--serial runs every task in this process"),
        (["--workers", "0"], "--workers must be at least 1, got 0"),
    ]
    for extra, message in cases:
        result = _sweep(tmp_path / "out", *extra)
        assert result.exit_code == 2, extra
        assert message in result.output and "Traceback" not in result.output
        assert not (tmp_path / "out").exists()
    no_worlds = "bayesmap.experiments.rover_world"
    result = runner.invoke(
        app, ["sweep", no_worlds, "--worlds", "3", "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 2 and "cannot take --worlds" in result.output
    result = runner.invoke(app, ["sweep", "nosuch", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "unknown experiment 'nosuch'" in result.output
    result = _sweep(tmp_path / "out", "--scheduler", str(tmp_path / "gone.json"))
    assert result.exit_code == 2 and "no such scheduler file" in result.output
    assert not (tmp_path / "out").exists()


def test_a_negative_root_seed_is_a_usage_error(tmp_path):
    result = _sweep(tmp_path / "out", "--root-seed", "-1")
    assert (
        result.exit_code == 2
        and "--root-seed': Input should be greater than or equal to 0" in result.output
    )
    assert "Traceback" not in result.output and not (tmp_path / "out").exists()


def test_a_folder_of_other_files_is_not_swept_into(tmp_path):
    (tmp_path / "tidy.csv").write_text("mine\n")
    result = _sweep(tmp_path)
    assert result.exit_code == 1
    assert "holds something other than a bayesmap sweep" in result.output
    assert (tmp_path / "tidy.csv").read_text() == "mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tidy.csv"]


def test_messages_print_user_text_literally(tmp_path):
    result = _sweep(tmp_path / "out", "--set", "[red]x[/red]=1")
    assert result.exit_code == 2 and "[red]x[/red]" in result.output
