"""The HTML report: self-contained, holds the sweep's numbers, renders in a real browser."""

from __future__ import annotations

import re

import pytest

from bayesmap.sweeps import aggregate, expand, run_sweep
from bayesmap.sweeps.report import sections_from_sweep, write_report

from . import browser, toy


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    plan = expand(
        "sweeps.toy",
        toy,
        worlds=2,
        seeds=3,
        root_seed=5,
        conditions={"base": {}, "double": {"scale": 2.0}},
        out_dir=out,
    )
    run_sweep(plan, out, serial=True)
    html = write_report(sections_from_sweep(out), out / "report.html", title="toy sweep")
    return plan, out, html


def _summary_cells(plan, out):
    summary = aggregate.summarise(aggregate.tidy(plan, out))
    return summary[summary["metric"] == "value"]


def test_the_page_is_self_contained_and_holds_the_summary(sweep):
    plan, out, html = sweep
    text = html.read_text()
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", text)
    assert text.count("data:image/png;base64,") == 2  # key metrics + the run's figure
    for _, row in _summary_cells(plan, out).iterrows():
        assert f"{row['mean']:.4g} ± {row['sd']:.4g}" in text
    assert "world-001" in text and "Paired comparisons" in text


def test_the_report_command_refuses_a_folder_without_a_sweep(tmp_path):
    from typer.testing import CliRunner

    from bayesmap.cli import app

    result = CliRunner().invoke(app, ["report", str(tmp_path), "--out", str(tmp_path / "r.html")])
    assert result.exit_code == 1
    assert "sweep.json missing" in result.output and "Traceback" not in result.output
    assert not (tmp_path / "r.html").exists()


@pytest.mark.skipif(browser.chromium() is None, reason="no chromium (apt-get install chromium)")
def test_the_report_renders_in_chromium(sweep, tmp_path):
    plan, out, html = sweep
    page = browser.inspect(html.resolve().as_uri())
    browser.save(page, out / "report.png")
    assert page.errors == []
    assert len(page.images) == 2
    assert all(i["complete"] and i["width"] > 100 and i["inline"] for i in page.images)
    summary_table = page.tables[0]
    for _, row in _summary_cells(plan, out).iterrows():
        assert f"{row['mean']:.4g} ± {row['sd']:.4g}" in summary_table
    assert page.screenshot[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_single_run_report_shows_its_values_and_figures(tmp_path, monkeypatch):
    from bayesmap import experiments
    from bayesmap.sweeps.report import section_from_run

    monkeypatch.setitem(experiments.EXPERIMENTS, "toy", "sweeps.toy")
    (tmp_path / "w.json").write_text('{"offset": 1.0}')
    config = toy.Config(seed=4, world=tmp_path / "w.json")
    result = toy.run(config, tmp_path / "toy")
    section = section_from_run("toy", result, config.model_dump(mode="json"))
    assert list(section.table["method"]) == ["a", "b"]
    text = write_report([section], tmp_path / "report.html", title="reproduce").read_text()
    for value in section.table["value"]:
        assert f"<td>{value:.4g}</td><td>–</td><td>1</td>" in text  # one run: no spread, no CI
    assert text.count("data:image/png;base64,") == 2
