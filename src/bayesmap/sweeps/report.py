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
import struct
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

__all__ = [
    "Section",
    "paired_lines",
    "render",
    "section_from_run",
    "sections_from_sweep",
    "write_report",
]

MAX_RUN_FIGURES = 8
"""Figures of one run shown per experiment (the first task's, or the run's)."""

MIN_PAIRS_FOR_EMPHASIS = 5
"""Pairs a difference needs before the report bolds an interval that excludes 0."""

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
    metric_units: dict[str, str] = field(default_factory=dict)
    paired_against: str | None = None


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
    if not any(protocol.task_complete(task_folder(sweep_dir, k)) for k in plan.tasks):
        raise FormatError(
            f"none of the sweep's {len(plan.tasks)} tasks has finished (no readable "
            f"task.json under tasks/); run the same 'bayesmap sweep' command to finish them",
            path=sweep_dir,
        )
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
            protocol.metric_units(module),
            protocol.paired_against(module),
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
        {
            **ids,
            "unit": str(r.get("unit", "")),
            "replicate": int(r.get("replicate", 0)),
            "method": str(r.get("method", "")),
            **r,
        }
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
        protocol.metric_units(module),
        protocol.paired_against(module),
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


def _is_wide(png: bytes) -> bool:
    """Whether a PNG is more than twice as wide as high (shown across the page)."""
    width, height = struct.unpack(">II", png[16:24])  # the IHDR chunk's first fields
    return bool(width > 2 * height)


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


def _summary_rows(
    section: Section, summary: pd.DataFrame, metrics: list[str], arms: list[str]
) -> list[dict[str, Any]]:
    """One row per metric, unit and arm: mean ± sd, the CI, n (the metric named once)."""
    rows = []
    units = list(dict.fromkeys(summary["unit"]))
    indexed = summary.set_index(["metric", "unit", "arm"])
    for metric in metrics:
        first = True
        for unit in units:
            for arm_name in arms:
                if (metric, unit, arm_name) not in indexed.index:
                    continue
                row = indexed.loc[(metric, unit, arm_name)]
                n = int(row["n"])
                if n == 0:
                    continue
                rows.append(
                    {
                        "metric": metric if first else "",
                        "unit": section.metric_units.get(metric, "") if first else "",
                        "part": unit,
                        "arm": arm_name,
                        "mean": _fmt(row["mean"]) + (f" ± {_fmt(row['sd'])}" if n > 1 else ""),
                        "ci": f"{_fmt(row['ci_low'])} to {_fmt(row['ci_high'])}" if n > 1 else "–",
                        "n": n,
                        "starts_group": first,
                    }
                )
                first = False
    return rows


def _paired_rows(
    section: Section, paired: pd.DataFrame, metrics: list[str]
) -> list[dict[str, Any]]:
    """Paired differences of ``metrics``, each read as ``reference − other`` where the
    experiment names a reference method (``PAIRED_AGAINST``), else as ``a − b``."""
    reference = section.paired_against
    rows = []
    for metric in metrics:
        for _, row in paired[paired["metric"] == metric].iterrows():
            if row["n"] == 0:
                continue
            a, b = str(row["arm_a"]), str(row["arm_b"])
            mean, low, high = float(row["mean"]), float(row["ci_low"]), float(row["ci_high"])
            if reference is not None:
                if b.endswith(f"/ {reference}") and not a.endswith(f"/ {reference}"):
                    a, b, mean, low, high = b, a, -mean, -high, -low
                elif not a.endswith(f"/ {reference}"):
                    continue
            rows.append(
                {
                    "a": a,
                    "b": b,
                    "part": row["unit"],
                    "metric": metric,
                    "unit": section.metric_units.get(metric, ""),
                    "n": int(row["n"]),
                    "mean": _fmt(mean),
                    "ci": f"{_fmt(low)} to {_fmt(high)}" if np.isfinite(low) else "–",
                    "p": _fmt(row["p_wilcoxon"]),
                    "excludes_zero": bool(
                        row["n"] >= MIN_PAIRS_FOR_EMPHASIS and (low > 0 or high < 0)
                    ),
                }
            )
    return rows


def _arm_labels(table: pd.DataFrame) -> dict[str, str]:
    """How the page names each arm: without the condition when the sweep has only one."""
    arms = aggregate.arm(table)
    if table["condition"].nunique() > 1:
        return {name: name for name in arms}
    methods = table["method"].astype(str)
    return dict(zip(arms, methods.where(methods != "", table["condition"]), strict=True))


def _key_metrics(section: Section) -> tuple[list[str], list[str], dict[str, Any]]:
    """The key metrics shown first, every metric that varies, and the constant ones."""
    metrics, constants = _varying_metrics(section)
    key = [m for m in (section.key_metrics or metrics[:5]) if m in metrics] or metrics[:5]
    return key, metrics, constants


def paired_lines(section: Section, limit: int = 12) -> list[str]:
    """The report's paired comparisons of the key metrics as lines of text (for a terminal)."""
    if section.table.empty:
        return []
    key, metrics, _ = _key_metrics(section)
    rows = _paired_rows(section, aggregate.paired(section.table), key or metrics[:limit])
    label = _arm_labels(section.table)
    lines = []
    for row in rows[:limit]:
        unit = f" [{row['unit']}]" if row["unit"] else ""
        part = f", {row['part']}" if row["part"] else ""
        lines.append(
            f"{row['metric']}{unit}{part}: {label[row['a']]} − {label[row['b']]} = {row['mean']} "
            f"(95 % CI {row['ci']}, {row['n']} pairs)"
        )
    return lines


def _context(section: Section) -> dict[str, Any]:
    table = section.table
    key, metrics, constants = _key_metrics(section)
    summary = aggregate.summarise(table)
    paired = aggregate.paired(table)
    arms = list(dict.fromkeys(aggregate.arm(table))) if len(table) else []
    others = [m for m in metrics if m not in key]
    summary_rows = _summary_rows(section, summary, key, arms) if len(table) else []
    other_rows = _summary_rows(section, summary, others, arms) if len(table) else []
    paired_rows = _paired_rows(section, paired, key or metrics[:MAX_PAIRED_METRICS])
    label = _arm_labels(table) if len(table) else {}
    for row in summary_rows + other_rows:
        row["arm"] = label[row["arm"]]
    for row in paired_rows:
        row["a"], row["b"] = label[row["a"]], label[row["b"]]
    per_world = []
    if len(table):
        grouped = table.assign(arm=aggregate.arm(table)).groupby(["world", "arm"], sort=False)[key]
        for (world, arm_name), means in grouped.mean().iterrows():
            per_world.append(
                {
                    "world": world,
                    "arm": label[arm_name],
                    "values": [_fmt(v) for v in means.to_numpy()],
                }
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
            unit = section.metric_units.get(metric)
            title = f"{metric} [{unit}]" if unit else metric
            panels.append(MetricPanel(title, [label[a] for a in arms], values, cis))
        png = metrics_figure(panels, title=f"{section.experiment}: key metrics, every run")
        figures.append({"label": "key metrics across arms", "src": _data_uri(png), "wide": True})
    for name, path in section.figures:
        png = Path(path).read_bytes()
        figures.append({"label": name, "src": _data_uri(png), "wide": _is_wide(png)})
    return {
        "experiment": section.experiment,
        "description": section.description,
        "n_rows": len(table),
        "n_worlds": table["world"].nunique() if len(table) else 0,
        "n_seeds": table["seed_index"].nunique() if len(table) else 0,
        "n_tasks": table["task"].nunique() if len(table) else 0,
        "arms": [label[a] for a in arms],
        "world_files": section.spec.get("worlds") is not None,
        "summary_rows": summary_rows,
        "other_rows": other_rows,
        "has_parts": bool(len(table)) and bool((table["unit"] != "").any()),
        "paired_rows": paired_rows,
        "paired_against": section.paired_against,
        "min_pairs": MIN_PAIRS_FOR_EMPHASIS,
        "key": key,
        "key_units": [section.metric_units.get(m, "") for m in key],
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
