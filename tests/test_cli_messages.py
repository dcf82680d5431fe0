"""Every command prints user text literally and turns hostile input into one clear line."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rich.console import Console
from typer.testing import CliRunner

from bayesmap import bn
from bayesmap.bn.model import BayesNet
from bayesmap.cli import app, main
from bayesmap.cli._console import headline_text, print_error, print_note

runner = CliRunner()
DATA = Path(__file__).parent / "sonar" / "data"
BAYESMAP = [sys.executable, "-c", "from bayesmap.cli import main; main()"]


def _net(tmp_path: Path) -> Path:
    net = BayesNet("n[m]")
    net.add_variable("A[/x]", ["[red]", "b"], cpt=[0.5, 0.5])
    return bn.write(net, tmp_path / "n.bif")


@pytest.mark.parametrize("text", ["[/x]", "[m] metres", "[red]boom[/red]", "[bold"])
def test_messages_print_brackets_literally(text: str) -> None:
    out = Console(record=True, width=200)
    print_error(f"value {text}", out=out)
    print_note(f"wrote {text}", out=out)
    assert out.export_text() == f"error: value {text}\nwrote {text}\n"


def test_headline_numbers_read_the_same_in_every_command() -> None:
    headline = {"coverage": 0.019995152690256906, "precision": float("nan"), "collisions": 0}
    assert headline_text(headline) == "coverage 0.020, precision undefined, collisions 0"


def test_evidence_with_markup_is_echoed_literally(tmp_path: Path) -> None:
    path = _net(tmp_path)
    result = runner.invoke(app, ["bn", "query", str(path), "-t", "A[/x]", "-e", "A[/x]=[/x]"])
    assert result.exit_code == 1
    assert "[/x]" in result.output and "Traceback" not in result.output
    shown = runner.invoke(app, ["bn", "query", str(path), "-t", "A[/x]", "-e", "A[/x]=[red]"])
    assert shown.exit_code == 0, shown.output
    assert "n[m]" in shown.output and "A[/x]=[red]" in shown.output
    info = runner.invoke(app, ["bn", "info", str(path)])
    assert "[red]" in info.output and "A[/x]" in info.output


def test_convert_into_a_path_under_a_file_is_a_clear_error(tmp_path: Path) -> None:
    path = _net(tmp_path)
    (tmp_path / "file").write_text("x")
    result = runner.invoke(app, ["bn", "convert", str(path), str(tmp_path / "file" / "n.xml")])
    assert result.exit_code == 1
    assert "is a file" in result.output and "Traceback" not in result.output
    (tmp_path / "dir.xml").mkdir()
    result = runner.invoke(app, ["bn", "convert", str(path), str(tmp_path / "dir.xml")])
    assert result.exit_code == 1 and "is a folder" in result.output


def test_convert_refuses_its_own_input_and_says_what_uai_drops(tmp_path: Path) -> None:
    path = _net(tmp_path)
    before = path.read_bytes()
    result = runner.invoke(app, ["bn", "convert", str(path), str(tmp_path / "." / path.name)])
    assert result.exit_code == 2 and "is the input file" in result.output
    assert path.read_bytes() == before
    result = runner.invoke(app, ["bn", "convert", str(path), str(tmp_path / "n.uai")])
    assert result.exit_code == 0 and "keeps no variable or state names" in result.output
    result = runner.invoke(app, ["bn", "convert", str(path), str(tmp_path / "n.xml")])
    assert result.exit_code == 0 and "warning" not in result.output


def _main(monkeypatch, capsys, *args: str) -> tuple[int, str]:
    """Run the ``bayesmap`` entry point in-process: exit code and stderr."""
    monkeypatch.setattr(sys, "argv", ["bayesmap", *args])
    with pytest.raises(SystemExit) as caught:
        main()
    return int(caught.value.code or 0), capsys.readouterr().err


def test_hostile_inputs_end_in_one_line_not_a_traceback(tmp_path: Path, monkeypatch, capsys):
    angles = ",".join(str(22.5 * k) for k in range(16))
    sonar = [
        "sonar",
        "map",
        str(DATA / "example_log.txt"),
        "--angles-deg",
        angles,
        "--range-unit",
        "mm",
        "--position-unit",
        "mm",
        "--heading-unit",
        "deg",
        "--max-range",
        "5000",
        "--resolution",
        "1e-5",
        "--out",
        str(tmp_path / "map"),
    ]
    code, err = _main(monkeypatch, capsys, *sonar)
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert code == 1 and len(errors) == 1 and "over the limit" in errors[0]
    fifo = tmp_path / "pipe.bif"
    os.mkfifo(fifo)
    code, err = _main(monkeypatch, capsys, "bn", "info", str(fifo))
    assert code == 1 and "regular file" in err


@pytest.mark.slow
def test_sigterm_during_reproduce_leaves_no_partial_results(tmp_path: Path) -> None:
    out = tmp_path / "results"
    # stderr goes to a file, so the child can never block on a full pipe; on a hang the
    # test sends SIGABRT, and PYTHONFAULTHANDLER makes the child print where it was.
    err_path = tmp_path / "stderr.txt"
    with err_path.open("w") as err:
        child = subprocess.Popen(
            [*BAYESMAP, "reproduce", "sonar", "--out", str(out)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=err,
            env={**os.environ, "PYTHONFAULTHANDLER": "1"},
        )
    deadline = time.monotonic() + 120
    while not (out.exists() and any(out.iterdir())) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert out.exists(), "the experiment never started"
    time.sleep(1.0)
    child.send_signal(signal.SIGTERM)
    try:
        child.wait(60)
    except subprocess.TimeoutExpired:
        child.send_signal(signal.SIGABRT)
        child.wait(30)
        pytest.fail(f"no exit 60 s after SIGTERM; its stderr:\n{err_path.read_text()[-6000:]}")
    assert child.returncode != 0, err_path.read_text()[-6000:]
    assert list(out.iterdir()) == [], err_path.read_text()[-6000:]


def test_library_warnings_print_as_one_literal_line(tmp_path: Path) -> None:
    """A skipped row and a renormalised table each print as ``warning: …``, without the
    logger's name or Python's file, line and source echo."""
    rows = ["1,2,0,40,40,40", "1,2,0,nan,40,40", "3,2,0,41,41,41"]
    log = tmp_path / "drive[m].csv"
    log.write_text("x,y,heading,ir_0,ir_1,ir_2\n" + "\n".join(rows) + "\n")
    mapped = runner.invoke(app, ["rover", "map", str(log), "--out", str(tmp_path / "m")])
    assert mapped.exit_code == 0, mapped.output
    skipped = [line for line in mapped.output.splitlines() if "line 3" in line]
    assert len(skipped) == 1 and skipped[0].startswith("warning: "), mapped.output
    assert "drive[m].csv, line 3: " in skipped[0] and "bayesmap.rover" not in mapped.output
    (tmp_path / "n.bif").write_text(
        "network n {}\nvariable A { type discrete [ 2 ] { a, b }; }\n"
        "probability ( A ) { table 0.4, 0.5999; }\n"
    )
    info = runner.invoke(app, ["bn", "info", str(tmp_path / "n.bif")])
    assert info.exit_code == 0, info.output
    lines = info.output.splitlines()
    assert lines[0].startswith("warning: ") and "renormalised" in lines[0], info.output
    assert "Warning" not in info.output and "table 0.4" not in info.output
