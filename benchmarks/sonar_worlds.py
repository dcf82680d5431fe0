"""Per-world results of ``reproduce sonar`` into docs/sonar.md, with the maps side by side.

Runs the sonar experiment at its default size (realistic worlds × 3 seeds, every pipeline
and baseline), or takes the output folder of a finished ``bayesmap reproduce sonar`` run
(``--from results/sonar``), copies each world's panel of maps to ``docs/sonar_maps_<world>.png``
and rewrites the section ``sonar_worlds`` of docs/sonar.md with the tables of summary.md.
It also maps the example log of ``tests/sonar/data`` with ``bayesmap sonar map`` (default
pipeline) into ``docs/sonar_cli_example.png``.
Run from the repository root: ``python benchmarks/sonar_worlds.py [--jobs N] [--from DIR]``
(``--jobs``: worker processes for the world × seed runs; the numbers do not depend on it).
``--ring 8`` runs the same experiment with the Pioneer's 8-sonar front ring instead and
writes the section ``sonar_worlds_ring8`` (tables and the L corridor's panel of maps).
``--firing-cycle S`` simulates transducers that fire one after another, a bank of 8 in
``S`` seconds, so that a logged ring repeats the last value of every transducer that has not
fired since (``Realism.firing_cycle``), and writes the section ``sonar_worlds_firing``
(``sonar_worlds_ring8_firing`` with ``--ring 8``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402
from scipy.stats import binomtest  # noqa: E402

from bayesmap.experiments.sonar import BASELINES, TARGETED, Config, run  # noqa: E402
from bayesmap.sim.sonar_log import Realism  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"


def cli_example() -> str:
    """Run ``bayesmap sonar map`` on the example log; copy its map.png into docs/."""
    from typer.testing import CliRunner

    from bayesmap.cli import app

    data = Path(__file__).resolve().parent.parent / "tests" / "sonar" / "data"
    with tempfile.TemporaryDirectory() as folder:
        args = [
            "sonar", "map", str(data / "example_log.txt"),
            "--angles-deg", ",".join(str(22.5 * k) for k in range(16)),
            "--range-unit", "mm", "--position-unit", "mm", "--heading-unit", "deg",
            "--max-range", "5000", "--resolution", "0.1", "--out", folder,
        ]  # fmt: skip
        result = CliRunner().invoke(app, args)
        if result.exit_code != 0:
            raise SystemExit(result.output)
        shutil.copyfile(Path(folder) / "map.png", DOCS / "sonar_cli_example.png")
    return result.output.strip().splitlines()[-1].split("; wrote")[0]


def _mean(values: list[float | None]) -> float:
    # A score a run could not define (no rejection to judge) is stored as null.
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return sum(finite) / len(finite) if finite else float("nan")


def pooled_ci(hits: float, total: float) -> str:
    """Pooled proportion ``hits / total`` over the runs with its Wilson 95 % interval."""
    if total <= 0:
        return "–"
    interval = binomtest(int(hits), int(total)).proportion_ci(0.95, method="wilson")
    return f"{hits / total:.2f} [{interval.low:.2f}, {interval.high:.2f}]"


def targets_table(metrics: dict, pipeline: str) -> str:
    """The issue's targets per world for ``pipeline``, each marked met or missed."""
    by_world: dict[str, dict[str, dict[str, list[float]]]] = {}
    for record in metrics["runs"]:
        table = by_world.setdefault(record["world"], {})
        for name, scores in record["pipelines"].items():
            for key, value in scores.items():
                table.setdefault(name, {}).setdefault(key, []).append(value)
    default = pipeline
    lines = [
        f"| world | κ {pipeline} | best baseline (κ) | κ margin (≥ +0.10) "
        "| missed wall − ROS (≤ 0) | path cells occupied (0) | rej. precision / recall (≥ 0.85) "
        "| specular readings | pooled precision [95 % CI] | pooled recall [95 % CI] |",
        "|---|---|---|---|---|---|---|---:|---|---|",
    ]

    def mark(ok: bool) -> str:
        return "**met**" if ok else "missed"

    for name, table in by_world.items():
        mean = {p: {k: _mean(v) for k, v in m.items()} for p, m in table.items()}
        best = max((b for b in BASELINES if b in mean), key=lambda b: mean[b]["kappa"])
        kappa = mean[default]["kappa"]
        margin = kappa - mean[best]["kappa"]
        missed = mean[default]["missed_wall_rate"] - mean["ros"]["missed_wall_rate"]
        path = mean[default]["path_occupied"]
        precision = mean[default]["rejection_precision"]
        recall = mean[default]["rejection_recall"]
        counts = table[default]
        lines.append(
            f"| {name} | {kappa:.3f} | {best} ({mean[best]['kappa']:.3f}) | {margin:+.3f} "
            f"{mark(margin >= 0.1)} | {missed:+.3f} {mark(missed <= 0)} | {path:.1f} "
            f"{mark(path == 0)} | {precision:.2f} / {recall:.2f} "
            f"{mark(min(precision, recall) >= 0.85)} | {int(sum(counts['specular_readings'])):,} "
            f"| {pooled_ci(sum(counts['rejected_specular']), sum(counts['rejected_readings']))} "
            f"| {pooled_ci(sum(counts['rejected_specular']), sum(counts['specular_readings']))} |"
        )
    runs = len(metrics["runs"]) // max(len(by_world), 1)
    return (
        f"### The issue's targets, world by world ({pipeline} pipeline, {runs} runs each)\n\n"
        + "\n".join(lines)
        + "\n\nPrecision and recall are means over runs; the pooled columns count every "
        "reading of the world's runs together (Wilson 95 % interval, `scipy.stats.binomtest`).\n"
    )


def variant(ring: int, firing_cycle: float) -> str:
    """The name of a run other than the record's (``ring8``, ``firing``, ``ring8_firing``)."""
    parts = ([f"ring{ring}"] if ring != 16 else []) + (["firing"] if firing_cycle > 0 else [])
    return "_".join(parts)


def variant_section(folder: Path, note: str, body: str, targets: str, metrics: dict) -> None:
    """The section ``sonar_worlds_<variant>``: the run's tables and its L corridor's maps."""
    ring = metrics["config"]["ring"]
    cycle = metrics["config"]["realism"].get("firing_cycle", 0.0)
    name = variant(ring, cycle)
    label = f"{ring}-sonar ring" + (f", banks firing in {cycle:g} s" if cycle > 0 else "")
    panel = folder / "maps_sonar-lcorridor-v2.png"
    target = DOCS / f"sonar_{name}_maps_sonar-lcorridor-v2.png"
    shutil.copyfile(panel, target)
    whole = body.split("\n### ", 2)  # the run's note, then "All worlds", then per world
    text = "\n".join(
        [
            note,
            "",
            whole[0].strip(),
            "",
            "### " + whole[1].strip(),
            "",
            targets,
            f"**sonar-lcorridor-v2** (run 0, {label})",
            "",
            f"![sonar-lcorridor-v2, {label}]({target.name})",
            "",
        ]
    )
    update_section(f"sonar_worlds_{name}", text, doc=DOCS / "sonar.md")
    print(f"wrote the section sonar_worlds_{name} and {target.name}")


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument("--from", dest="source", type=Path, help="a finished run's folder")
    parser.add_argument(
        "--ring", type=int, choices=(8, 16), default=16, help="Pioneer ring (default 16)"
    )
    parser.add_argument(
        "--firing-cycle",
        type=float,
        default=0.0,
        help="seconds a bank of 8 transducers takes to fire in turn (default 0: all at once)",
    )
    args = parser.parse_args(argv)
    started = time.perf_counter()
    if args.source is not None:
        folder = args.source
        note = "Taken from one finished `bayesmap reproduce sonar` run."
    else:
        folder = Path(tempfile.mkdtemp(prefix="sonar_worlds_"))
        run(
            Config(jobs=args.jobs, ring=args.ring, realism=Realism(firing_cycle=args.firing_cycle)),
            folder,
            progress=lambda what, done, total: print(f"{what} ({done}/{total})", flush=True),
        )
        minutes = (time.perf_counter() - started) / 60
        load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
        ring = "" if args.ring == 16 else f" --ring {args.ring}"
        ring += f" --firing-cycle {args.firing_cycle:g}" if args.firing_cycle > 0 else ""
        note = (
            f"Run by `python benchmarks/sonar_worlds.py --jobs {args.jobs}{ring}` in "
            f"{minutes:.1f} min on {machine()}; load average at the end {load} (a shared "
            "machine: wall time is inflated by other jobs)."
        )
    summary = (folder / "summary.md").read_text(encoding="utf-8")
    metrics = json.loads((folder / "metrics.json").read_text(encoding="utf-8"))
    targets = "\n".join(
        targets_table(metrics, name) for name in TARGETED if name in metrics["pipelines"]
    )
    body = summary.split("\n", 1)[1].replace("\n## ", "\n### ")
    if variant(metrics["config"]["ring"], metrics["config"]["realism"].get("firing_cycle", 0.0)):
        variant_section(folder, note, body, targets, metrics)
        return
    figures = []
    for png in sorted(folder.glob("maps_*.png")):
        target = DOCS / f"sonar_{png.name}"
        shutil.copyfile(png, target)
        name = png.stem.removeprefix("maps_")
        figures.append(f"**{name}** (run 0)\n\n![{name}]({target.name})\n")
    said = cli_example()
    text = "\n".join(
        [
            note,
            "",
            body.strip(),
            "",
            targets,
            "### Maps",
            "",
            "Panels: truth (black = solid), then every pipeline on the same log; true walls in "
            "red, the logged (drifting) path dotted blue.",
            "",
            *figures,
            "### `bayesmap sonar map` on the example log",
            "",
            "`tests/sonar/data/example_log.txt` (16 transducers at the centre, mm and degrees, "
            f"untidy rows), default pipeline. The command said: `{said}`",
            "",
            "![CLI example](sonar_cli_example.png)",
            "",
        ]
    )
    update_section("sonar_worlds", text, doc=DOCS / "sonar.md")
    print(f"wrote {len(figures)} figures and the tables into docs/sonar.md")


if __name__ == "__main__":
    main(sys.argv[1:])
