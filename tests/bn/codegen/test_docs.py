"""docs/bn-codegen.md: its command and C program run and print what the page says."""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest
from tests.bn.codegen.conftest import MODELS, bnlearn
from typer.testing import CliRunner

from bayesmap.bn.codegen.native import STRICT_FLAGS
from bayesmap.cli import app

PAGE = Path(__file__).resolve().parents[3] / "docs" / "bn-codegen.md"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="no gcc on PATH")
def test_the_documented_example_builds_runs_and_prints_the_engines_answer(tmp_path):
    text = PAGE.read_text(encoding="utf-8")
    command = re.search(r"```console\n\$ (.*?)\n(.*?)\n```", text, re.DOTALL)
    assert command is not None
    args = shlex.split(command.group(1))[1:]
    args = [str(MODELS / a) if a == "asia.bif.gz" else a for a in args]
    args = [str(tmp_path / "firmware") if a == "firmware/" else a for a in args]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert result.output.strip() == command.group(2).replace("firmware/", f"{tmp_path}/firmware/")

    header = (tmp_path / "firmware" / "asia.h").read_text()
    documented = re.search(r"```c\n(typedef.*?)```", text, re.DOTALL)
    assert documented is not None
    for line in documented.group(1).splitlines():
        if line.startswith("#define"):
            name, value = line.split()[1:3]
            assert f"#define {name} {value}" in header

    program = re.search(r"```c\n(#include <stdio.h>.*?)```", text, re.DOTALL)
    assert program is not None
    main = tmp_path / "firmware" / "main.c"
    main.write_text(program.group(1))
    binary = tmp_path / "example"
    subprocess.run(
        [
            "gcc",
            *STRICT_FLAGS,
            "-I",
            str(tmp_path / "firmware"),
            str(main),
            str(tmp_path / "firmware" / "asia.c"),
            "-o",
            str(binary),
        ],
        check=True,
    )
    printed = subprocess.run([str(binary)], capture_output=True, text=True, check=True).stdout
    claimed = re.search(r"It prints `(.*?)`", text)
    assert claimed is not None and printed.strip() == claimed.group(1)
    raw = bnlearn("asia").posterior_fixed("lung", {"xray": "yes"}, "Q16.16").raw[0]
    assert printed.strip() == f"P(lung = yes | xray = yes) = {raw} / 65536"
