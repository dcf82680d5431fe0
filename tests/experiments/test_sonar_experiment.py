"""Tests of the sonar experiment: metrics by hand, a small deterministic run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bayesmap.experiments.sonar import VARIANTS, Config, map_metrics, run


def test_map_metrics_against_hand_counts() -> None:
    truth = np.array([[True, False, False, False]])
    probability = np.array([[0.9, 0.8, 0.1, 0.5]])
    observed = np.array([[True, True, True, False]])
    wall = np.array([[True, False, False, False]])
    m = map_metrics(probability, observed, truth, wall)
    assert m["accuracy"] == pytest.approx(2 / 3)
    # po = 2/3; p(pred occ) = 2/3, p(true occ) = 1/3: pe = 2/9 + 2/9 = 4/9.
    assert m["kappa"] == pytest.approx((2 / 3 - 4 / 9) / (1 - 4 / 9))
    assert m["false_obstacle_rate"] == pytest.approx(1 / 2)
    assert m["missed_wall_rate"] == 0.0
    assert m["observed_fraction"] == pytest.approx(3 / 4)


def test_small_run_writes_results_and_is_deterministic(tmp_path: Path) -> None:
    config = Config(
        worlds=("sonar-room-v1",), runs=1, front_arc_runs=1, laps=1, step=0.4, resolution=0.2
    )
    calls: list[tuple[str, int, int]] = []
    result = run(config, tmp_path / "a", progress=lambda d, c, t: calls.append((d, c, t)))
    again = run(config, tmp_path / "b")
    metrics = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert metrics == json.loads((tmp_path / "b" / "metrics.json").read_text())
    assert [r["ring"] for r in metrics["runs"]] == ["ring16", "front8"]
    for record in metrics["runs"]:
        assert set(record["variants"]) == set(VARIANTS)
        assert record["variants"]["no filter"]["rejected_fraction"] == 0.0
        assert 0 < record["variants"]["all stages"]["rejected_fraction"] < 1
    assert "| all stages |" in (tmp_path / "a" / "summary.md").read_text()
    assert all(path.exists() and path.suffix == ".png" for path in result.figures)
    assert result.headline == again.headline
    assert calls and calls[-1][1] == calls[-1][2]
