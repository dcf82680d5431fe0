"""The rover experiment on a reduced step budget: every output, every metric, determinism."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bayesmap import bn
from bayesmap.errors import ConfigError
from bayesmap.experiments import ExperimentResult, rover
from bayesmap.grid import OccupancyGrid
from bayesmap.grid.ros import read_ros_map

KEYS = {
    "steps",
    "path_length_m",
    "collisions",
    "coverage",
    "coverage_curve",
    "distance_to_90",
    "entropy_bits",
    "roc_auc",
    "obstacle_peak_ratio",
    "world",
    "min_clearance_m",
    "stalled_cycles",
    "off_map_cycles",
}


@pytest.fixture(scope="module")
def small_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ExperimentResult]:
    out = tmp_path_factory.mktemp("rover")
    config = rover.Config(max_steps=120, runs=("obstacles-flat", "empty-random"))
    calls: list[tuple[str, int, int]] = []
    result = rover.run(config, out, progress=lambda d, c, t: calls.append((d, c, t)))
    assert calls and calls[-1][1] == calls[-1][2]
    return out, result


def test_writes_every_output(small_run: tuple[Path, ExperimentResult]) -> None:
    out, result = small_run
    for run in ("obstacles-flat", "empty-random"):
        for folder in (out / run, out / "frontier" / run):
            for name in (
                "path.png",
                "map.npz",
                "map.yaml",
                "map.pgm",
                "metrics.json",
            ):
                assert (folder / name).is_file(), folder / name
        metrics = json.loads((out / run / "metrics.json").read_text())
        assert KEYS <= set(metrics)
        assert metrics["steps"] == 120 and metrics["collisions"] == 0
        assert 0.0 < metrics["coverage"] < 1.0
        grid = OccupancyGrid.load_npz(out / run / "map.npz")
        ros = read_ros_map(out / run / "map.yaml")
        assert ros.probability.shape == grid.shape
        certain = (grid.entropy < 0.3) & ~grid.unobserved()
        assert np.all(ros.occupancy[~certain] == -1)  # uncertain cells are unknown in the file
    flat = json.loads((out / "obstacles-flat" / "metrics.json").read_text())
    assert flat["world"] == "rover-field-obstacles-v1"
    empty = json.loads((out / "empty-random" / "metrics.json").read_text())
    assert empty["roc_auc"] is None and empty["obstacle_peak_ratio"] is None
    summary = (out / "summary.md").read_text()
    assert "obstacles-flat" in summary and "frontier" in summary
    net = bn.read(out / "decision_network.xmlbif")
    assert "ProbabilityMap" in net.variables
    assert result.headline["collisions"] == 0


def test_same_seed_same_run(tmp_path: Path, small_run: tuple[Path, ExperimentResult]) -> None:
    out, _ = small_run
    config = rover.Config(max_steps=120, runs=("obstacles-flat",), baseline=False)
    rover.run(config, tmp_path)
    a = json.loads((out / "obstacles-flat" / "metrics.json").read_text())
    b = json.loads((tmp_path / "obstacles-flat" / "metrics.json").read_text())
    assert a["coverage_curve"] == b["coverage_curve"] and a["path_length_m"] == b["path_length_m"]


def test_roc_auc_matches_pair_counting() -> None:
    rng = np.random.default_rng(0)
    scores = np.round(rng.uniform(size=50), 1)
    labels = rng.uniform(size=50) < 0.3
    pos, neg = scores[labels], scores[~labels]
    pairs = (pos[:, None] > neg[None, :]).sum() + 0.5 * (pos[:, None] == neg[None, :]).sum()
    assert rover.roc_auc(scores, labels) == pytest.approx(pairs / (pos.size * neg.size))
    assert rover.roc_auc(scores, np.zeros(50, dtype=bool)) is None


def test_unknown_run_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError):
        rover.run(rover.Config(runs=("nowhere",)), tmp_path)
