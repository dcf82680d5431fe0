"""A sweep's results as tables: every task's metrics (tidy), per-arm summaries, paired tests.

The tidy table has one row per grid point and metric row of its task, with the columns
``experiment, condition, world, world_index, seed_index, seed, task, unit, replicate,
method`` and one column per metric. An *arm* is what a sweep compares: a condition, or a
condition and a method of the experiment (e.g. ``default / frontier``). A *replicate* is one
of several repeats a run makes itself (the sonar experiment's seeded runs of a world).

The summary gives, per experiment, arm and unit, every numeric metric's mean, standard
deviation and a 95 % percentile-bootstrap interval of the mean (Efron & Tibshirani 1993,
ch. 13) from a seeded generator, pooling seeds, worlds and replicates. Paired comparisons
take two arms measured on the same world, seed, unit and replicate, and summarise the
differences the same way, with the Wilcoxon signed-rank test's p-value.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.stats import wilcoxon

from bayesmap._io import atomic_open
from bayesmap._rng import RNGLike, as_generator
from bayesmap.errors import FormatError
from bayesmap.sweeps import protocol
from bayesmap.sweeps.grid import SweepPlan
from bayesmap.sweeps.protocol import BUILT_IN
from bayesmap.sweeps.runner import task_folder

__all__ = [
    "ID_COLUMNS",
    "bootstrap_ci",
    "metric_columns",
    "paired",
    "summarise",
    "tidy",
    "write_tables",
]

ID_COLUMNS = (
    "experiment",
    "condition",
    "world",
    "world_index",
    "seed_index",
    "seed",
    "task",
    "unit",
    "replicate",
    "method",
)
"""Columns that identify a row of the tidy table; every other numeric column is a metric."""

BOOTSTRAP_RESAMPLES = 2000
"""Resamples of each bootstrap interval."""


def tidy(plan: SweepPlan, out_dir: Path) -> pd.DataFrame:
    """Every finished grid point's metric rows as one table (unfinished points are left out)."""
    records: list[dict[str, Any]] = []
    rows_of: dict[str, list[dict[str, Any]]] = {}
    for key in plan.tasks:
        folder = task_folder(out_dir, key)
        if protocol.task_complete(folder):
            rows_of[key] = protocol.read_task_record(folder)["rows"]
    for point in plan.points:
        for row in rows_of.get(point.task, []):
            # a run on its built-in world may name it (the rover's runs use two)
            world = row.get("world", point.world) if point.world == BUILT_IN else point.world
            ids = {
                "experiment": plan.experiment,
                "condition": point.condition,
                "world": str(world),
                "world_index": point.world_index,
                "seed_index": point.seed_index,
                "seed": point.seed,
                "task": point.task,
                "unit": str(row.get("unit", "")),
                "replicate": int(row.get("replicate", 0)),
                "method": str(row.get("method", "")),
            }
            records.append({**ids, **{k: v for k, v in row.items() if k not in ids}})
    table = pd.DataFrame.from_records(records, columns=_columns(records))
    return table.astype({"seed": "uint64"}) if len(table) else table


def _columns(records: list[dict[str, Any]]) -> list[str]:
    seen = dict.fromkeys(ID_COLUMNS)
    for record in records:
        seen.update(dict.fromkeys(record))
    return list(seen)


def metric_columns(table: pd.DataFrame) -> list[str]:
    """The numeric metric columns of a tidy table (booleans count as 0/1)."""
    return [
        column
        for column in table.columns
        if column not in ID_COLUMNS
        and (
            pd.api.types.is_numeric_dtype(table[column])
            or pd.api.types.is_bool_dtype(table[column])
        )
    ]


def arm(table: pd.DataFrame) -> pd.Series:
    """Each row's arm: its condition, and its method where the experiment names one."""
    method = table["method"].astype(str)
    return table["condition"].astype(str).where(method == "", table["condition"] + " / " + method)


def bootstrap_ci(
    values: np.ndarray, rng: np.random.Generator, level: float = 0.95
) -> tuple[float, float]:
    """Percentile-bootstrap interval of the mean of ``values`` (NaN below two values).

    Examples
    --------
    >>> low, high = bootstrap_ci(np.array([1.0, 2.0, 3.0, 4.0]), np.random.default_rng(0))
    >>> bool(1.0 <= low < 2.5 < high <= 4.0)
    True
    """
    values = np.asarray(values, dtype=np.float64)
    if values.size < 2:
        return math.nan, math.nan
    means = rng.choice(values, size=(BOOTSTRAP_RESAMPLES, values.size), replace=True).mean(axis=1)
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(means, [tail, 100 - tail])
    return float(low), float(high)


def _describe(values: np.ndarray, rng: np.random.Generator) -> dict[str, float]:
    low, high = bootstrap_ci(values, rng)
    return {
        "n": int(values.size),
        "mean": float(values.mean()) if values.size else math.nan,
        "sd": float(values.std(ddof=1)) if values.size > 1 else math.nan,
        "ci_low": low,
        "ci_high": high,
    }


def summarise(table: pd.DataFrame, *, rng: RNGLike = 0) -> pd.DataFrame:
    """Mean, sd and bootstrap 95 % CI of every metric, per experiment, arm and unit.

    Non-finite values (a metric undefined for a run) are left out of their metric's
    statistics; ``n`` counts the values used.
    """
    generator = as_generator(rng)
    columns = ["experiment", "arm", "unit", "metric", "n", "mean", "sd", "ci_low", "ci_high"]
    if table.empty:
        return pd.DataFrame(columns=columns)
    arms = table.assign(arm=arm(table))
    out = []
    for (experiment, arm_name, unit), group in arms.groupby(
        ["experiment", "arm", "unit"], sort=False
    ):
        for metric in metric_columns(table):
            values = group[metric].to_numpy(dtype=np.float64)
            values = values[np.isfinite(values)]
            out.append(
                {
                    "experiment": experiment,
                    "arm": arm_name,
                    "unit": unit,
                    "metric": metric,
                    **_describe(values, generator),
                }
            )
    return pd.DataFrame(out, columns=columns)


def paired(table: pd.DataFrame, *, rng: RNGLike = 0) -> pd.DataFrame:
    """Differences ``a − b`` between two arms on the same world, seed and unit, per metric.

    Pairs are formed for every two arms of an experiment that share a condition or a
    method (so a sweep of conditions × methods compares methods within each condition and
    conditions within each method). Rows: ``n`` pairs, mean and sd of the differences,
    bootstrap 95 % CI, Wilcoxon signed-rank p (NaN with fewer than two non-zero pairs).
    """
    generator = as_generator(rng)
    columns = [
        "experiment",
        "arm_a",
        "arm_b",
        "unit",
        "metric",
        "n",
        "mean",
        "sd",
        "ci_low",
        "ci_high",
        "p_wilcoxon",
    ]
    if table.empty:
        return pd.DataFrame(columns=columns)
    data = table.assign(arm=arm(table))
    keys = ["world_index", "world", "seed_index", "unit", "replicate"]
    out = []
    for experiment, rows in data.groupby("experiment", sort=False):
        arms = rows.drop_duplicates("arm")[["arm", "condition", "method"]].to_numpy()
        for (a, cond_a, meth_a), (b, cond_b, meth_b) in itertools.combinations(arms, 2):
            if cond_a != cond_b and meth_a != meth_b:
                continue
            joined = rows[rows["arm"] == a].merge(
                rows[rows["arm"] == b], on=keys, suffixes=("_a", "_b")
            )
            for unit, group in joined.groupby("unit", sort=False):
                for metric in metric_columns(table):
                    diff = group[f"{metric}_a"].to_numpy(dtype=np.float64) - group[
                        f"{metric}_b"
                    ].to_numpy(dtype=np.float64)
                    diff = diff[np.isfinite(diff)]
                    out.append(
                        {
                            "experiment": experiment,
                            "arm_a": a,
                            "arm_b": b,
                            "unit": unit,
                            "metric": metric,
                            **_describe(diff, generator),
                            "p_wilcoxon": _wilcoxon(diff),
                        }
                    )
    return pd.DataFrame(out, columns=columns)


def _wilcoxon(diff: np.ndarray) -> float:
    if np.count_nonzero(diff) < 2:
        return math.nan
    return float(wilcoxon(diff, zero_method="wilcox").pvalue)


def write_tables(table: pd.DataFrame, out_dir: Path, *, rng: RNGLike = 0) -> dict[str, Path]:
    """Write ``tidy``, ``summary`` and ``paired`` as Parquet and CSV into ``out_dir``."""
    generator = as_generator(rng)
    frames = {
        "tidy": table,
        "summary": summarise(table, rng=generator),
        "paired": paired(table, rng=generator),
    }
    written: dict[str, Path] = {}
    for name, frame in frames.items():
        with atomic_open(Path(out_dir) / f"{name}.parquet", "wb") as handle:
            frame.to_parquet(handle, index=False)
        with atomic_open(Path(out_dir) / f"{name}.csv", "w", newline="") as handle:
            frame.to_csv(handle, index=False)
        written[name] = Path(out_dir) / f"{name}.parquet"
    return written


def read_table(path: Path) -> pd.DataFrame:
    """A table written by :func:`write_tables`; :class:`FormatError` if unreadable."""
    try:
        return pd.read_parquet(path)
    except FileNotFoundError:
        raise FormatError("table missing; run the sweep first", path=path) from None
    except Exception as error:  # pyarrow raises several unrelated types for a bad file
        raise FormatError(f"unreadable Parquet table: {error}", path=path) from None
