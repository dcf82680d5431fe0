"""One self-contained HTML page of a sweep's (or ``reproduce``'s) results.

Per experiment: the grid and the configuration that produced it with bayesmap's version,
a summary table (mean ± sd and bootstrap 95 % CI per arm), paired comparisons, a table per
world, a dot plot of the key metrics and the experiment's own figures. Figures are embedded
as base64 ``data:`` URIs, so the file opens anywhere without network access. The page is a
Jinja2 template shipped with the package (``templates/report.html.j2``).
"""

from __future__ import annotations

import base64
import json
import math
import platform
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from types import ModuleType
from typing import Any

import jinja2
import numpy as np
import pandas as pd

from bayesmap import __version__
from bayesmap._io import write_text
from bayesmap.errors import FormatError
from bayesmap.experiments import ExperimentResult, load
from bayesmap.sweeps import aggregate, protocol
from bayesmap.sweeps.grid import SweepPlan
from bayesmap.sweeps.runner import FAILURES, SWEEP_RECORD, task_folder
from bayesmap.viz.sweeps import MetricPanel, metrics_figure

__all__ = ["Section", "render", "section_from_run", "sections_from_sweep", "write_report"]

MAX_RUN_FIGURES = 8
"""Figures of one run shown per experiment (the first task's, or the run's)."""

MAX_PAIRED_METRICS = 8
"""Metrics shown in the paired-comparison table when the experiment names no key metrics."""


@dataclass
class Section:
    """What the report shows of one experiment."""

    experiment: str
    description: str
    table: pd.DataFrame
    config: dict[str, Any]
    spec: dict[str, Any]
    figures: list[tuple[str, Path]] = field(default_factory=list)
    failures: dict[str, str] = field(default_factory=dict)
    key_metrics: tuple[str, ...] | None = None


def sections_from_sweep(sweep_dir: Path) -> list[Section]:
    """The section of the sweep in ``sweep_dir`` (its ``sweep.json`` and task records)."""
    sweep_dir = Path(sweep_dir)
    record = sweep_dir / SWEEP_RECORD
    try:
        plan = SweepPlan.from_json(json.loads(record.read_text(encoding="utf-8")))
    except FileNotFoundError:
        raise FormatError("no sweep here (sweep.json missing)", path=record) from None
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise FormatError(f"unreadable sweep record: {error}", path=record) from None
    module = load(plan.experiment)
    table = aggregate.tidy(plan, sweep_dir)
    failures_path = sweep_dir / FAILURES
    failures = json.loads(failures_path.read_text()) if failures_path.exists() else {}
    first = next((k for k in plan.tasks if protocol.task_complete(task_folder(sweep_dir, k))), None)
    figures = _run_figures(module, task_folder(sweep_dir, first)) if first else []
    base = module.Config().model_dump(mode="json")
    return [
        Section(
            plan.experiment,
            _first_line(module.__doc__),
            table,
            base,
            plan.spec,
            figures,
            failures,
            protocol.key_metrics(module),
        )
    ]


def section_from_run(name: str, result: ExperimentResult, config: dict[str, Any]) -> Section:
    """The section of one experiment run outside a sweep (``bayesmap reproduce``)."""
    module = load(name)
    rows = protocol.metric_rows(module, result)
    ids = {
        "experiment": name,
        "condition": "reproduce",
        "world": "built-in",
        "world_index": 0,
        "seed_index": 0,
        "seed": config.get("seed", 0),
        "task": name,
    }
    records = [
        {**ids, "unit": str(r.get("unit", "")), "method": str(r.get("method", "")), **r}
        for r in rows
    ]
    table = pd.DataFrame.from_records(records)
    return Section(
        name,
        _first_line(module.__doc__),
        table,
        config,
        {"seeds": 1, "worlds": None},
        _run_figures(module, result.out_dir),
        {},
        protocol.key_metrics(module),
    )


def _first_line(doc: str | None) -> str:
    return (doc or "").strip().splitlines()[0] if doc else ""


def _run_figures(module: ModuleType, folder: Path) -> list[tuple[str, Path]]:
    paths = protocol.key_figures(module, folder, MAX_RUN_FIGURES)
    return [(p.relative_to(folder).as_posix(), p) for p in paths]


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _fmt(value: Any) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, float | np.floating):
        value = float(value)
        if value != 0 and (abs(value) >= 1e4 or abs(value) < 1e-3):
            return f"{value:.3e}"
        return f"{value:.4g}"
    return str(value)


def _varying_metrics(section: Section) -> tuple[list[str], dict[str, Any]]:
    """Metrics that vary somewhere, and the constants (settings echoed into the metrics)."""
    varying, constants = [], {}
    for metric in aggregate.metric_columns(section.table):
        values = section.table[metric].to_numpy(dtype=np.float64)
        finite = values[np.isfinite(values)]
        if not finite.size:
            constants[metric] = "undefined"
        elif np.all(finite == finite[0]) and finite.size == values.size:
            constants[metric] = _fmt(float(finite[0]))
        else:
            varying.append(metric)
    keys = [m for m in (section.key_metrics or ()) if m in varying]
    return keys + [m for m in varying if m not in keys], constants


def _context(section: Section) -> dict[str, Any]:
    table = section.table
    metrics, constants = _varying_metrics(section)
    key = [m for m in (section.key_metrics or metrics[:5]) if m in metrics] or metrics[:5]
    summary = aggregate.summarise(table)
    paired = aggregate.paired(table)
    arms = list(dict.fromkeys(aggregate.arm(table))) if len(table) else []
    units = list(dict.fromkeys(table["unit"])) if len(table) else []
    summary_rows = []
    for metric in metrics:
        for unit in units:
            cells: list[dict[str, Any] | None] = []
            for arm_name in arms:
                hit = summary[
                    (summary["metric"] == metric)
                    & (summary["arm"] == arm_name)
                    & (summary["unit"] == unit)
                ]
                if hit.empty:
                    cells.append(None)
                    continue
                row = hit.iloc[0]
                cells.append(
                    {
                        "mean": _fmt(row["mean"]),
                        "sd": _fmt(row["sd"]),
                        "ci": f"[{_fmt(row['ci_low'])}, {_fmt(row['ci_high'])}]",
                        "n": int(row["n"]),
                    }
                )
            if any(cells):
                summary_rows.append({"metric": metric, "unit": unit, "cells": cells})
    paired_metrics = key or metrics[:MAX_PAIRED_METRICS]
    paired_rows = [
        {
            "a": row["arm_a"],
            "b": row["arm_b"],
            "unit": row["unit"],
            "metric": row["metric"],
            "n": int(row["n"]),
            "mean": _fmt(row["mean"]),
            "ci": f"[{_fmt(row['ci_low'])}, {_fmt(row['ci_high'])}]",
            "p": _fmt(row["p_wilcoxon"]),
        }
        for _, row in paired[paired["metric"].isin(paired_metrics)].iterrows()
        if row["n"] > 0
    ]
    per_world = []
    if len(table):
        grouped = table.assign(arm=aggregate.arm(table)).groupby(["world", "arm"], sort=False)[key]
        for (world, arm_name), means in grouped.mean().iterrows():
            per_world.append(
                {"world": world, "arm": arm_name, "values": [_fmt(v) for v in means.to_numpy()]}
            )
    figures = []
    if len(table) and key:
        panels = []
        labelled = table.assign(arm=aggregate.arm(table))
        for metric in key:
            values, cis = [], []
            for arm_name in arms:
                series = labelled.loc[labelled["arm"] == arm_name, metric].to_numpy(float)
                series = series[np.isfinite(series)]
                values.append(series)
                cis.append(aggregate.bootstrap_ci(series, np.random.default_rng(0)))
            panels.append(MetricPanel(metric, arms, values, cis))
        png = metrics_figure(panels, title=f"{section.experiment}: key metrics, every run")
        figures.append({"label": "key metrics across arms", "src": _data_uri(png), "wide": True})
    for label, path in section.figures:
        figures.append({"label": label, "src": _data_uri(Path(path).read_bytes()), "wide": False})
    return {
        "experiment": section.experiment,
        "description": section.description,
        "n_rows": len(table),
        "n_worlds": table["world"].nunique() if len(table) else 0,
        "n_seeds": table["seed_index"].nunique() if len(table) else 0,
        "n_tasks": table["task"].nunique() if len(table) else 0,
        "arms": arms,
        "summary_rows": summary_rows,
        "paired_rows": paired_rows,
        "key": key,
        "per_world": per_world,
        "figures": figures,
        "constants": constants,
        "config": json.dumps(section.config, indent=2, sort_keys=True),
        "spec": json.dumps(section.spec, indent=2, sort_keys=True),
        "failures": section.failures,
    }


def render(sections: list[Section], *, title: str) -> str:
    """The report's HTML for ``sections``."""
    environment = jinja2.Environment(
        loader=jinja2.PackageLoader("bayesmap.sweeps", "templates"),
        autoescape=jinja2.select_autoescape(["html", "j2"]),
        undefined=jinja2.StrictUndefined,
    )
    template = environment.get_template("report.html.j2")
    return template.render(
        title=title,
        version=__version__,
        python=platform.python_version(),
        generated=datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
        sections=[_context(section) for section in sections],
    )


def write_report(sections: list[Section], out: Path, *, title: str) -> Path:
    """Render ``sections`` and write the page to ``out`` atomically."""
    return write_text(out, render(sections, title=title))
