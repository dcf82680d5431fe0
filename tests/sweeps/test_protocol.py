"""What sweeps read of an experiment when it exposes nothing but Config and run."""

from __future__ import annotations

import json
import math
import types

from bayesmap.experiments import ExperimentResult
from bayesmap.sweeps.protocol import key_figures, metric_rows, task_complete


def test_flat_metrics_files_become_rows_and_record_files_are_skipped(tmp_path):
    (tmp_path / "a").mkdir()
    flat = tmp_path / "a" / "metrics.json"
    flat.write_text(json.dumps({"x": 1.5, "n": None, "by": {"1": 0.5}, "curve": [1, 2]}))
    root = tmp_path / "metrics.json"
    root.write_text(json.dumps({"runs": [{"x": 1}], "name": "z"}))
    nested = tmp_path / "nested.json"
    nested.write_text(json.dumps({"run": {"explorer": {"x": 1}}}))
    result = ExperimentResult("bare", tmp_path, (), (flat, root, nested))
    rows = metric_rows(types.ModuleType("bare"), result)
    assert len(rows) == 1
    assert rows[0]["unit"] == "a" and rows[0]["x"] == 1.5 and rows[0]["by.1"] == 0.5
    assert math.isnan(rows[0]["n"]) and "curve" not in rows[0]


def test_key_figures_first_then_any(tmp_path):
    for name in ("b.png", "a.png", "sub/key.png", "notes.txt"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    plain = types.ModuleType("plain")
    assert [p.name for p in key_figures(plain, tmp_path, 2)] == ["a.png", "b.png"]
    keyed = types.ModuleType("keyed")
    keyed.KEY_FIGURES = ("sub/*.png", "missing.png")
    assert [p.name for p in key_figures(keyed, tmp_path, 5)] == ["key.png"]


def test_a_task_without_a_readable_record_is_not_complete(tmp_path):
    assert not task_complete(tmp_path)
    (tmp_path / "task.json").write_text('{"rows": "no"}')
    assert not task_complete(tmp_path)
    (tmp_path / "task.json").write_text('{"rows": []}')
    assert task_complete(tmp_path)
