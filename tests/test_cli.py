import click
import pytest
from typer.main import get_command
from typer.testing import CliRunner

from bayesmap.cli import app

runner = CliRunner()


def _all_command_paths(command, prefix=()):
    yield prefix
    if isinstance(command, click.Group):
        for name, sub in command.commands.items():
            yield from _all_command_paths(sub, prefix + (name,))


@pytest.mark.parametrize(
    "path", list(_all_command_paths(get_command(app))), ids=lambda p: " ".join(p) or "root"
)
def test_every_command_has_help(path):
    result = runner.invoke(app, [*path, "--help"])
    assert result.exit_code == 0, result.output
    assert "Usage" in result.output


def test_reproduce_rejects_an_unknown_experiment(tmp_path):
    result = runner.invoke(app, ["reproduce", "no-such-experiment", "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "unknown experiment" in result.output
    assert not any(tmp_path.iterdir())


def test_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.startswith("bayesmap ")
