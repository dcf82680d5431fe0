import subprocess
import sys
from pathlib import Path
from typing import Annotated

import pytest
from rich.console import Console
from typer.main import get_command
from typer.testing import CliRunner

from bayesmap.cli import COMMANDS, app, load_command
from bayesmap.cli.reproduce import _print_summary
from bayesmap.experiments import ExperimentResult

runner = CliRunner()


def _all_command_paths(command, prefix=()):
    yield prefix
    # a group by what it has: Typer's groups need not be instances of the click installed
    for name, sub in getattr(command, "commands", {}).items():
        yield from _all_command_paths(sub, prefix + (name,))


@pytest.mark.parametrize(
    "path", list(_all_command_paths(get_command(app))), ids=lambda p: " ".join(p) or "root"
)
def test_every_command_has_help(path):
    result = runner.invoke(app, [*path, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output
    assert "--install-completion" not in result.output  # the root offers none, nor do they


def test_reproduce_rejects_an_unknown_experiment(tmp_path):
    result = runner.invoke(app, ["reproduce", "no-such-experiment", "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "unknown experiment" in result.output
    assert not any(tmp_path.iterdir())


def test_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.startswith("bayesmap ")


def test_python_dash_m_runs_the_command_line_under_its_name():
    done = subprocess.run(
        [sys.executable, "-m", "bayesmap", "rover", "run", "--bogus"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2 and "bayesmap rover run" in done.stderr
    assert "__main__" not in done.stderr


def test_reproduce_summary_names_folders_and_headlines_in_a_narrow_terminal():
    out_dir = Path("results") / "blackboard"
    result = ExperimentResult(
        "blackboard",
        out_dir,
        figures=(out_dir / "a.png", out_dir / "b.png"),
        metrics=(out_dir / "normal" / "metrics.json", out_dir / "summary.md"),
        headline={"scenario": "whisker-tables-v1", "normal_precision": 0.41625},
    )
    console = Console(width=80, record=True)
    _print_summary([(result, 12.34)], console)
    text = console.export_text()
    assert str(out_dir) in text and "summary.md" in text and "12.3 s" in text
    assert "blackboard: scenario whisker-tables-v1, normal_precision 0.416" in text


def test_the_stage_eta_follows_the_current_stage_pace():
    import re
    import time

    from rich.progress import Progress

    from bayesmap.cli.reproduce import _StageRemaining

    column = _StageRemaining()
    progress = Progress(column)
    task_id = progress.add_task("stage 2", total=100, stage_start=(time.monotonic() - 20.0, 50))
    progress.update(task_id, completed=60)  # 10 units in 20 s since the stage began: 80 s left
    task = progress.tasks[0]
    seconds = re.fullmatch(r"stage ETA (\d+):(\d\d)", column.render(task).plain)
    assert seconds and 78 <= 60 * int(seconds[1]) + int(seconds[2]) <= 82
    progress.update(task_id, stage_start=(time.monotonic(), 60))
    assert column.render(progress.tasks[0]).plain == "stage ETA –:––"


@pytest.mark.parametrize("name", list(COMMANDS))
def test_the_root_help_line_of_each_command_is_its_own_help(name):
    command = load_command(name)
    own = " ".join((command.help or "").split("\n\n")[0].split())
    assert COMMANDS[name][1] == own
    listing = runner.invoke(app, ["--help"]).output.split("Commands:")[1]
    rows = [line.split(None, 1) for line in listing.splitlines() if line[2:3].strip()]
    first_words = " ".join(COMMANDS[name][1].split()[:3])
    assert [name, first_words] in [[row[0], " ".join(row[1].split()[:3])] for row in rows]


def test_plain_option_values_convert_and_refuse_as_typer_does(tmp_path):
    import typer

    from bayesmap.cli._values import plain_values

    seen = {}
    demo = typer.Typer()

    @demo.command()
    def run(
        count: Annotated[int, typer.Option(min=1)] = 3,
        ratio: float = 0.5,
        names: Annotated[list[str] | None, typer.Option("--name")] = None,
        where: Path | None = None,
        loud: bool = False,
    ) -> None:
        seen.update(count=count, ratio=ratio, names=names, where=where, loud=loud)

    command = plain_values(get_command(demo))
    assert all(type(p._runtime_param).__name__ == "PlainParam" for p in command.params)
    args = ["--count", "7", "--ratio", "2.5", "--name", "a", "--name", "b"]
    command.main([*args, "--where", str(tmp_path), "--loud"], standalone_mode=False)
    assert seen == {
        "count": 7,
        "ratio": 2.5,
        "names": ["a", "b"],
        "where": tmp_path,
        "loud": True,
    }
    for bad, message in (
        (["--count", "x"], "valid integer"),
        (["--count", "0"], "greater than or equal to 1"),
        (["--ratio", "many"], "valid number"),
    ):
        with pytest.raises(typer.BadParameter, match=message):
            command.main(bad, standalone_mode=False)


@pytest.mark.parametrize("args", [[], ["bn"], ["sonar"]])
def test_a_bare_command_group_shows_its_help_on_stderr(args, monkeypatch, capsys):
    from bayesmap.cli import main

    monkeypatch.setattr("sys.argv", ["bayesmap", *args])
    with pytest.raises(SystemExit) as stop:
        main()
    assert stop.value.code == 2
    err = capsys.readouterr().err
    usage = err.splitlines()[0]
    assert usage.startswith("Usage: ") and usage.endswith(
        " ".join([*args, "[OPTIONS] COMMAND [ARGS]..."])
    )
    assert "\nCommands:\n" in err and "error:" not in err


def test_no_progress_bar_is_printed_off_a_terminal() -> None:
    import io

    from rich.console import Console

    from bayesmap.cli._console import progress_bar

    sink = io.StringIO()
    with progress_bar(Console(file=sink, force_terminal=False), first="reading") as hook:
        hook("reading", 5, 10)
    assert sink.getvalue() == ""
