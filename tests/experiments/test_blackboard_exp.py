"""A reduced blackboard experiment: its files, the sanity of its metrics, determinism."""

from __future__ import annotations

import json
import math

import numpy as np
import pydantic
import pytest

from bayesmap.errors import ConfigError
from bayesmap.experiments import blackboard

POSES = 12
QUICK = {"burn_in": 50, "explore": 100, "anneal": 50, "samples": 100}
TIMINGS = (
    "per_pose_ms_median",
    "per_pose_ms_p95",
    "wall_s",
    "fused_per_pose_ms_median",
    "fused_per_pose_ms_p95",
    "fused_wall_s",
)


def _scores(out_dir, condition):
    metrics = json.loads((out_dir / condition / "metrics.json").read_text())
    # as JSON text, so that NaN scores (no pairs of a kind) compare equal
    return json.dumps({k: v for k, v in metrics.items() if k not in TIMINGS}, sort_keys=True)


@pytest.fixture(scope="module")
def reduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("blackboard")
    calls = []
    config = blackboard.Config(poses=POSES, fused_mapper=QUICK)
    result = blackboard.run(config, out, progress=lambda *a: calls.append(a))
    return out, result, calls


# The fixture runs the whole experiment (three conditions, each with the fused mapper); the
# fused mapper's closing sweep over the arena on the noisy readings takes minutes, not the
# 13 s of CPU it took when this fixture joined the default suite, so its tests are slow.
@pytest.mark.slow
def test_writes_every_file(reduced):
    out, result, _ = reduced
    for name in ("ground_truth.png", "snapshot_high.png", "snapshot_low.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "annealing.gif").read_bytes()[:6] == b"GIF89a"
    for condition in ("normal", "noiseless", "noisy"):
        assert (out / condition / "montage.png").stat().st_size > 1000
        assert (out / condition / "fused_map.png").stat().st_size > 1000
        assert (out / condition / "metrics.json") in result.metrics
    summary = (out / "summary.md").read_text()
    assert "| precision |" in summary and "4.2 ± 1.7" in summary
    assert result.headline["scenario"] == "whisker-tables-v1"


@pytest.mark.slow
def test_metrics_are_sane(reduced):
    out, _, calls = reduced
    assert ("noisy", POSES, POSES) in calls
    assert calls[-1] == ("noisy fused", POSES + 1, POSES + 1)
    assert [c[1] for c in calls if c[0] == "normal"] == list(range(1, POSES + 1))
    contacts = None
    for condition in ("normal", "noiseless", "noisy"):
        m = json.loads((out / condition / "metrics.json").read_text())
        assert m["scenario"] == "whisker-tables-v1" and m["poses"] == POSES
        for key in ("precision", "recall"):
            assert m[key] is None or 0.0 <= m[key] <= 1.0  # None: undefined (JSON null)
        assert 0 <= m["matched"] <= m["map_tables"]
        by_legs = m["recall_by_legs_in_memory"]
        assert all(by_legs[k] is None or 0.0 <= by_legs[k] <= 1.0 for k in "1234")
        assert sum(by_legs[f"pairs_{k}"] for k in "1234") > 0
        assert m["phantoms"] == m["map_tables"] - m["matched"]
        assert 0 <= m["phantom_near_walls"] <= m["phantoms"]
        assert 0.0 <= m["gospa_mean"] <= m["gospa_c"] * math.sqrt(7)
        assert 1 <= m["contacts_mean"] <= 6
        assert m["per_pose_ms_median"] > 0 and m["wall_s"] > 0
        # the same world and poses: contacts do not depend on the noise
        contacts = contacts or (m["contacts_mean"], m["contacts_std"])
        assert (m["contacts_mean"], m["contacts_std"]) == contacts
    noisy = json.loads((out / "noisy" / "metrics.json").read_text())
    assert noisy["sigma_r"] == 0.5 and noisy["sigma_theta"] == pytest.approx(np.pi / 8)


@pytest.mark.slow  # a second run of the experiment: 13 s of CPU
def test_same_seed_same_result_and_independent_streams(reduced, tmp_path):
    out, _, _ = reduced
    config = blackboard.Config(poses=POSES, conditions=("noisy",), fused_mapper=QUICK)
    blackboard.run(config, tmp_path)
    # a condition's streams do not depend on which other conditions run
    assert _scores(tmp_path, "noisy") == _scores(out, "noisy")


@pytest.mark.slow
def test_fused_condition_is_the_experiments_fused_run(reduced):
    out, _, _ = reduced
    config = blackboard.Config(poses=POSES, fused_mapper=QUICK)
    run, scores = blackboard.fused_condition("normal", config)
    kept = json.loads((out / "normal" / "metrics.json").read_text())
    assert len(run["step_ms"]) == POSES
    assert json.dumps(scores, sort_keys=True) == json.dumps(
        {k: kept[k] for k in scores}, sort_keys=True
    )


def test_bad_config():
    with pytest.raises(ConfigError, match="conditions"):
        blackboard.Config(conditions=("foggy",))
    with pytest.raises(ConfigError, match="poses"):
        blackboard.Config(poses=0)
    with pytest.raises(pydantic.ValidationError):
        blackboard.Config().seed = 3  # frozen
    with pytest.raises(ConfigError, match="snapshot_pose"):
        blackboard.run(blackboard.Config(poses=3, snapshot_pose=5, conditions=()), "unused")


def test_unknown_mapper_overrides_stop_the_config_not_the_run() -> None:
    with pytest.raises(ConfigError, match="mapper: bogus not a field of BlackboardParams"):
        blackboard.Config(mapper={"bogus": 1})
    with pytest.raises(ConfigError, match="fused_mapper: nope not a field of FusedParams"):
        blackboard.Config(fused_mapper={"nope": 1.0})
