"""The README's Python example runs and gives what its comments say."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parent.parent / "README.md"


def test_readme_python_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.DOTALL)
    assert blocks, "README has no Python example"
    namespace: dict[str, object] = {}
    exec(compile(blocks[0], str(README), "exec"), namespace)
    assert len(capsys.readouterr().out.splitlines()) == 3
    net = namespace["net"]
    assert net.posterior("Rain", {"Wet": "yes"})["yes"] == pytest.approx(0.18 / 0.26)
    assert net.map({"Wet": "yes"}) == ({"Rain": "yes"}, pytest.approx(0.18 / 0.26))
    tables = namespace["mapper"].board_.table_array()
    assert len(tables) == 1
    np.testing.assert_allclose(tables[0, :2], [0.5, 0.3], atol=0.03)
