"""run_in_folder: an experiment's folder appears complete, with its manifest, or not at all."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import BaseModel

from bayesmap._io import verify_run_folder, write_text
from bayesmap.experiments import ExperimentResult, run_in_folder


class _Config(BaseModel, frozen=True):
    seed: int = 5
    size: float = 0.5


def _body(folder: Path) -> ExperimentResult:
    figure = write_text(folder / "a" / "figure.png", "png")
    metrics = write_text(folder / "metrics.json", "{}")
    return ExperimentResult("toy", folder, (figure,), (metrics,), {"x": 1})


def test_results_point_into_the_completed_folder(tmp_path: Path) -> None:
    result = run_in_folder("toy", _Config(), tmp_path / "toy", _body, command="bayesmap toy")
    assert result.out_dir == tmp_path / "toy"
    assert result.figures == (tmp_path / "toy" / "a" / "figure.png",)
    assert all(path.is_file() for path in (*result.figures, *result.metrics))
    manifest = verify_run_folder(tmp_path / "toy")
    assert manifest["command"] == "bayesmap toy" and manifest["seed"] == 5
    assert manifest["configuration"] == {"experiment": "toy", "seed": 5, "size": 0.5}
    assert {f["path"] for f in manifest["files"]} == {"a/figure.png", "metrics.json"}


def test_a_failing_experiment_leaves_the_previous_results(tmp_path: Path) -> None:
    run_in_folder("toy", _Config(), tmp_path / "toy", _body)

    def failing(folder: Path) -> ExperimentResult:
        write_text(folder / "metrics.json", "half")
        raise RuntimeError("the experiment broke")

    with pytest.raises(RuntimeError):
        run_in_folder("toy", _Config(seed=6), tmp_path / "toy", failing)
    assert verify_run_folder(tmp_path / "toy")["seed"] == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["toy"]
