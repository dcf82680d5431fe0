"""docs/bn-recipes.md: every Python block runs (in order, in a fresh folder) and prints the
text block that follows it, and every ``$ bayesmap`` line of its console blocks succeeds."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from bayesmap.cli import app

RECIPES = Path(__file__).resolve().parents[2] / "docs" / "bn-recipes.md"


@pytest.mark.slow
def test_recipes_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    text = RECIPES.read_text(encoding="utf-8")
    blocks = re.findall(r"```(python|console|text)\n(.*?)```", text, re.DOTALL)
    assert sum(kind == "python" for kind, _ in blocks) == 3
    runner = CliRunner()
    printed = ""
    for kind, body in blocks:
        if kind == "python":
            capsys.readouterr()
            exec(compile(body, str(RECIPES), "exec"), {})
            printed = capsys.readouterr().out
            continue
        if kind == "text":
            assert printed == body
            continue
        for line in body.splitlines():
            if line.startswith("$ bayesmap "):
                result = runner.invoke(app, shlex.split(line)[2:])
                assert result.exit_code == 0, (line, result.output)
    assert (tmp_path / "posteriors.csv").exists()
