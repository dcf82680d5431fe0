"""``bayesmap bn query`` without traps: usage mistakes, hints, soft evidence, every posterior,
conditional probabilities, literal printing, and batches from CSV and Parquet files."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import bayesmap.bn as bn
from bayesmap.cli import app, main

runner = CliRunner()


def sprinkler() -> bn.BayesNet:
    net = bn.BayesNet("lawn")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Sprinkler", ["off", "on"], parents=["Rain"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    net.add_variable(
        "Wet",
        ["no", "yes"],
        parents=["Rain", "Sprinkler"],
        cpt=[[[1.0, 0.1], [0.2, 0.01]], [[0.0, 0.9], [0.8, 0.99]]],
    )
    return net


@pytest.fixture
def lawn(tmp_path: Path) -> Path:
    path = tmp_path / "lawn.xml"
    bn.write(sprinkler(), path)
    return path


def query(*args: str) -> dict:
    result = runner.invoke(app, ["bn", "query", *args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["-t", "Rain", "-e", "Wet=yes", "-e", "Wet=no"], "gives 'Wet' twice"),
        (["-t", "Rain", "-e", "Wet=yes", "-e", "Wet=yes"], "gives 'Wet' twice"),
        (["-t", "Rain", "-t", "Rain"], "'Rain' is given twice"),
        (["--map", "--probability", "Rain=yes"], "give one"),
        (["-t", "Rain", "--probability", "Rain=yes"], "takes no --target"),
        (["--given", "Rain=yes"], "give --probability too"),
        (["-t", "Rain", "-e", "Wet"], "VARIABLE=STATE"),
        (["-t", "Rain", "-e", "Wet=yes", "--soft", "Wet=1,2"], "both --evidence and --soft"),
        (["-t", "Rain", "--soft", "Wet=a,b"], "not a number"),
        (["-t", "Rain", "--cases", "cases.csv"], "go together"),
        (["--cases", "c.csv", "--out", "o.csv"], "needs --target"),
        (["-t", "Rain", "--cases", "c.csv", "--out", "o.csv", "--map"], "drop --map"),
        (["-t", "Rain", "--chunk-rows", "5"], "--chunk-rows sizes a batch"),
        (["-t", "Rain", "--scheduler", "tcp://127.0.0.1:1"], "--scheduler answers a batch"),
    ],
)
def test_contradicting_or_repeated_options_exit_2(lawn: Path, args: list[str], needle: str) -> None:
    result = runner.invoke(app, ["bn", "query", str(lawn), *args])
    assert result.exit_code == 2, result.output
    assert needle in result.stderr
    assert result.stderr.count("\\n") == 0 and len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("args", "hint"),
    [
        (["-t", "Rian"], "did you mean 'Rain'?"),
        (["-t", "rain"], "did you mean 'Rain'?"),
        (["-t", "Rain", "-e", "Sprinkler=of"], "did you mean 'off'?"),
        (["--probability", "Sprinkler=onn"], "did you mean 'on'?"),
    ],
)
def test_unknown_names_get_a_suggestion(lawn: Path, args: list[str], hint: str) -> None:
    result = runner.invoke(app, ["bn", "query", str(lawn), *args])
    assert result.exit_code == 1
    assert hint in result.stderr


def test_fixed_point_prints_a_table_with_bounds(lawn: Path) -> None:
    result = runner.invoke(app, ["bn", "query", str(lawn), "-t", "Rain", "--fixed-point", "Q16.16"])
    assert result.exit_code == 0, result.output
    assert "± bound" in result.stdout and "Q16.16" in result.stdout
    every = runner.invoke(
        app, ["bn", "query", str(lawn), "-e", "Wet=yes", "--fixed-point", "Q8.24"]
    )
    assert every.exit_code == 0 and "Sprinkler" in every.stdout


def test_given_is_a_conditional_probability_and_or_is_a_disjunction(lawn: Path) -> None:
    net = sprinkler()
    data = query(str(lawn), "--probability", "Rain=yes", "--given", "Wet=yes")
    assert data["probability"] == pytest.approx(net.posterior("Rain", {"Wet": "yes"})["yes"])
    assert data["given"] == "Wet=yes"
    joint = net.joint_posterior(["Rain", "Wet"])
    data = query(str(lawn), "--probability", "Rain=yes or Wet=yes")
    assert data["probability"] == pytest.approx(1.0 - joint[0, 0])
    data = query(str(lawn), "--probability", "Rain=yes", "--given", "Sprinkler=on or Wet=yes")
    both = net.joint_posterior(["Rain", "Sprinkler", "Wet"])
    condition = both[:, 1, :].sum() + both[:, 0, 1].sum()
    assert data["probability"] == pytest.approx((both[1, 1, :].sum() + both[1, 0, 1]) / condition)
    fixed = query(
        str(lawn), "--probability", "Rain=yes", "--given", "Wet=yes", "--fixed-point", "Q16.16"
    )
    exact = net.posterior("Rain", {"Wet": "yes"})["yes"]
    assert abs(fixed["probability"] - exact) <= fixed["error_bound"]
    text = runner.invoke(
        app, ["bn", "query", str(lawn), "--probability", "Rain=yes", "--given", "Wet=yes"]
    )
    assert "P(Rain=yes | Wet=yes, evidence)" in text.stdout


def test_no_target_gives_every_unobserved_posterior(lawn: Path) -> None:
    net = sprinkler()
    data = query(str(lawn), "-e", "Wet=yes")
    assert set(data["posteriors"]) == {"Rain", "Sprinkler"}
    for name, posterior in data["posteriors"].items():
        assert posterior == pytest.approx(net.posterior(name, {"Wet": "yes"}))
    fixed = query(str(lawn), "-e", "Wet=yes", "--fixed-point", "Q16.16")
    for name, posterior in fixed["posteriors"].items():
        for state, p in posterior.items():
            exact = net.posterior(name, {"Wet": "yes"})[state]
            assert abs(p - exact) <= fixed["error_bounds"][name][state]


def test_soft_evidence_on_the_command_line(lawn: Path) -> None:
    net = sprinkler()
    expected = net.posterior("Rain", soft={"Wet": [0.3, 0.9]})
    assert query(str(lawn), "-t", "Rain", "--soft", "Wet=0.3,0.9")["posterior"] == pytest.approx(
        expected
    )
    named = query(str(lawn), "-t", "Rain", "--soft", "Wet=yes:0.9,no:0.3")
    assert named["posterior"] == pytest.approx(expected)
    mapped = query(str(lawn), "--map", "--soft", "Wet=0.3,0.9")
    assert mapped["map"] == net.map(soft={"Wet": [0.3, 0.9]})[0]


def test_user_text_prints_literally(tmp_path: Path) -> None:
    net = bn.BayesNet("markup")
    net.add_variable("[bold]X[/bold]", ["[red]a[/red]", "b"], cpt=[0.25, 0.75])
    path = tmp_path / "markup.xml"
    bn.write(net, path)
    result = runner.invoke(app, ["bn", "query", str(path), "-t", "[bold]X[/bold]"])
    assert result.exit_code == 0, result.output
    assert "[red]a[/red]" in result.stdout
    bad = runner.invoke(
        app, ["bn", "query", str(path), "-t", "[bold]X[/bold]", "-e", "[bold]X[/bold]=[b]"]
    )
    assert "'[b]'" in bad.stderr


def test_main_reports_click_usage_errors_in_one_line(
    lawn: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(sys, "argv", ["bayesmap", "bn", "query", str(lawn), "--targt", "Rain"])
    with pytest.raises(SystemExit) as exit_info:
        main()
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: No such option: --targt") and err.count("\n") == 1


# ------------------------------------------------------------------ batches from files
def lawn_cases(n: int, seed: int) -> pd.DataFrame:
    net = sprinkler()
    rng = np.random.default_rng(seed)
    draws = net.sample(n, rng=rng)
    frame = pd.DataFrame(
        {
            name: np.array(net.states(name), dtype=object)[draws[:, j]]
            for j, name in enumerate(net.variables)
        }
    )
    frame = frame.drop(columns=["Rain"])
    return frame.mask(rng.random(frame.shape) < 0.3)


@pytest.mark.parametrize(("suffix_in", "suffix_out"), [(".csv", ".parquet"), (".parquet", ".csv")])
def test_batch_from_a_file_matches_one_case_at_a_time(
    lawn: Path, tmp_path: Path, suffix_in: str, suffix_out: str
) -> None:
    cases = lawn_cases(300, seed=len(suffix_in))
    path_in, path_out = tmp_path / f"cases{suffix_in}", tmp_path / f"answers{suffix_out}"
    if suffix_in == ".csv":
        cases.to_csv(path_in, index=False)
    else:
        cases.to_parquet(path_in, index=False)
    result = runner.invoke(
        app,
        [
            "bn",
            "query",
            str(lawn),
            "--cases",
            str(path_in),
            "-t",
            "Rain",
            "-t",
            "Sprinkler",
            "--out",
            str(path_out),
            "--chunk-rows",
            "64",
        ],
    )
    assert result.exit_code == 0, result.output
    answers = pd.read_csv(path_out) if suffix_out == ".csv" else pd.read_parquet(path_out)
    assert list(answers.columns) == ["Rain=no", "Rain=yes", "Sprinkler=off", "Sprinkler=on"]
    assert len(answers) == len(cases)
    net = sprinkler()
    for i, row in cases.iterrows():
        evidence = {k: v for k, v in row.items() if isinstance(v, str)}
        for target in ("Rain", "Sprinkler"):
            expected = net.posterior(target, evidence)  # one-hot where it is observed
            for state, p in expected.items():
                assert answers.loc[i, f"{target}={state}"] == pytest.approx(p, abs=1e-12)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("Wet,Sprinklr\nyes,on\n", "did you mean 'Sprinkler'?"),
        ("Wet,Sprinkler\nyes,on\nyes,onn\n", "cases line 3, column 'Sprinkler'"),
        ("Rain,Sprinkler,Wet\nno,off,no\nno,off,yes\n", "cases line 3: "),
        ("Wet,Sprinkler\nyes,on\nno,off,yes\n", "cases line 3 has more values than the header"),
        ("Wet,Wet\nyes,no\n", "column 'Wet' appears more than once"),
        ("\n", "no header line"),
    ],
)
def test_batch_errors_name_the_row_and_leave_no_output(
    lawn: Path, tmp_path: Path, text: str, needle: str
) -> None:
    path_in, path_out = tmp_path / "cases.csv", tmp_path / "answers.csv"
    path_in.write_text(text)
    result = runner.invoke(
        app,
        ["bn", "query", str(lawn), "--cases", str(path_in), "-t", "Rain", "--out", str(path_out)],
    )
    assert result.exit_code == 1
    assert needle in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not path_out.exists()


def test_csv_cells_are_read_exactly_and_every_line_is_a_case(lawn: Path, tmp_path: Path) -> None:
    """A state named like a missing-value marker is a state; a trailing comma is harmless;
    an empty line is a case with nothing observed, so the answers line up with the lines."""
    net = bn.BayesNet("markers")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("Sprinkler", ["off", "on"], parents=["Rain"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    net.add_variable("Wet", ["None", "NA"], parents=["Rain"], cpt=[[0.9, 0.2], [0.1, 0.8]])
    bif = tmp_path / "markers.bif"
    bn.write(net, bif)
    path_in, path_out = tmp_path / "cases.csv", tmp_path / "answers.csv"
    path_in.write_text("Wet,Sprinkler\nNone,\n\nNA,on,\n")
    result = runner.invoke(
        app,
        ["bn", "query", str(bif), "--cases", str(path_in), "-t", "Rain", "--out", str(path_out)],
    )
    assert result.exit_code == 0, result.output
    answers = pd.read_csv(path_out)["Rain=yes"].tolist()
    expected = [
        net.posterior("Rain", evidence)["yes"]
        for evidence in ({"Wet": "None"}, {}, {"Wet": "NA", "Sprinkler": "on"})
    ]
    assert answers == pytest.approx(expected, abs=1e-12)
    assert len(set(answers)) == 3


def test_the_answers_never_overwrite_the_cases(lawn: Path, tmp_path: Path) -> None:
    path = tmp_path / "cases.csv"
    path.write_text("Wet\nyes\n")
    result = runner.invoke(
        app, ["bn", "query", str(lawn), "--cases", str(path), "-t", "Rain", "--out", str(path)]
    )
    assert result.exit_code == 1 and "is the cases file" in result.stderr
    assert path.read_text() == "Wet\nyes\n"


def test_an_empty_cases_file_writes_an_empty_table(lawn: Path, tmp_path: Path) -> None:
    path_in, path_out = tmp_path / "cases.csv", tmp_path / "answers.parquet"
    path_in.write_text("Wet\n")
    result = runner.invoke(
        app,
        ["bn", "query", str(lawn), "--cases", str(path_in), "-t", "Rain", "--out", str(path_out)],
    )
    assert result.exit_code == 0, result.output
    assert list(pd.read_parquet(path_out).columns) == ["Rain=no", "Rain=yes"]
    as_csv = tmp_path / "answers.csv"
    result = runner.invoke(
        app, ["bn", "query", str(lawn), "--cases", str(path_in), "-t", "Rain", "--out", str(as_csv)]
    )
    assert result.exit_code == 0, result.output
    assert as_csv.read_text().splitlines() == ["Rain=no,Rain=yes"]
