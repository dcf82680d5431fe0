"""Summaries: bootstrap intervals that cover, undefined metrics left out, seeded."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bayesmap.sweeps.aggregate import bootstrap_ci, paired, summarise


def test_bootstrap_interval_covers_the_mean_about_95_percent_of_the_time():
    rng = np.random.default_rng(11)
    reps, n = 300, 30
    covered = 0
    for _ in range(reps):
        low, high = bootstrap_ci(rng.normal(2.0, 1.5, size=n), rng)
        covered += low <= 2.0 <= high
    # the percentile bootstrap undercovers a little at n = 30; 3 binomial sd around 0.95
    assert 0.88 <= covered / reps <= 0.99


def test_bootstrap_is_seeded_and_needs_two_values():
    values = np.arange(10.0)
    assert bootstrap_ci(values, np.random.default_rng(3)) == bootstrap_ci(
        values, np.random.default_rng(3)
    )
    assert all(math.isnan(v) for v in bootstrap_ci(np.array([1.0]), np.random.default_rng(0)))


def _table(values_a, values_b):
    rows = []
    for method, values in (("a", values_a), ("b", values_b)):
        for k, value in enumerate(values):
            rows.append(
                {
                    "experiment": "e",
                    "condition": "c",
                    "world": "w",
                    "world_index": 0,
                    "seed_index": k,
                    "seed": k,
                    "task": f"t{k}",
                    "unit": "",
                    "replicate": 0,
                    "method": method,
                    "m": value,
                }
            )
    return pd.DataFrame(rows)


def test_summary_leaves_undefined_values_out():
    table = _table([1.0, 2.0, np.nan, 3.0], [5.0, 5.0, 5.0, 5.0])
    summary = summarise(table).set_index("arm")
    assert summary.loc["c / a", "n"] == 3 and summary.loc["c / a", "mean"] == 2.0
    assert summary.loc["c / a", "sd"] == 1.0
    assert summary.loc["c / b", "ci_low"] == summary.loc["c / b", "ci_high"] == 5.0


def test_paired_matches_on_world_seed_and_unit():
    table = _table([1.0, 2.0, 3.0, 4.0], [2.0, 2.5, 4.0, 4.0])
    row = paired(table).iloc[0]
    assert row["n"] == 4 and row["mean"] == (-1.0 - 0.5 - 1.0 + 0.0) / 4
    assert row["ci_low"] <= row["mean"] <= row["ci_high"]
    assert 0 < row["p_wilcoxon"] <= 1
