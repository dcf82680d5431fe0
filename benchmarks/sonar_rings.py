"""Other robots' sonar rings in the record's worlds: does the default pipeline, whose
thresholds were learnt on Pioneer rings, still beat the baselines?

Each ring of :data:`RINGS` (evenly spaced transducers, as on a Nomad 200, a B21, a ring
of wide beams, a sparse ring and a hobby robot's ring of narrow beams) drives the record's
five realistic worlds with the record's log streams (``reproduce sonar``'s seed 2007,
three runs a world: the logs differ from the record's only by the ring), and each log is
mapped with the default pipeline and every baseline. Per ring and world: the default's κ,
the best baseline and its κ, the margin (target +0.10), the default's missed-wall rate
minus the ROS layer's (target ≤ 0), the robot's path cells it maps occupied (target 0)
and its rejection precision / recall (target 0.85). The tables go to the section
``sonar_rings`` of docs/sonar.md.
Run from the repository root: ``python benchmarks/sonar_rings.py [--jobs N] [--rings A,B]``.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap._rng import spawn  # noqa: E402
from bayesmap.experiments.sonar import BASELINES, Config, score_world  # noqa: E402
from bayesmap.sim.polygons import world  # noqa: E402
from bayesmap.sim.sonar import SonarRing  # noqa: E402
from bayesmap.sim.sonar_log import simulate_log  # noqa: E402

DOC = Path(__file__).resolve().parent.parent / "docs" / "sonar.md"


def even_ring(n: int, radius: float, beam_deg: float, max_range: float = 5.0) -> SonarRing:
    """``n`` transducers evenly spaced on a circle of ``radius`` [m], facing out."""
    angles = tuple(2.0 * math.pi * k / n for k in range(n))
    offsets = tuple((radius * math.cos(a), radius * math.sin(a)) for a in angles)
    return SonarRing(
        angles=angles,
        offsets=offsets,
        beam_width=math.radians(beam_deg),
        max_range=max_range,
    )


RINGS: dict[str, tuple[str, SonarRing]] = {
    "nomad16": ("16 × 25°, 0.23 m out (a Nomad 200's layout)", even_ring(16, 0.23, 25.0)),
    "b21-24": ("24 × 25°, 0.26 m out (a B21's layout)", even_ring(24, 0.26, 25.0)),
    "wide16": ("16 × 35°, 0.23 m out (wide beams)", even_ring(16, 0.23, 35.0)),
    "sparse8": ("8 × 25°, 45° apart, 0.2 m out (gaps between beams)", even_ring(8, 0.2, 25.0)),
    "hobby12": (
        "12 × 15°, 30° apart, 0.12 m out, 4 m (narrow beams, HC-SR04-like)",
        even_ring(12, 0.12, 15.0, max_range=4.0),
    ),
}
"""Rings not used to learn any setting, by name: (description, ring)."""

NAMES: tuple[str, ...] = ("default", *BASELINES)


def _task(task: tuple[str, str, int, np.random.Generator]) -> tuple[str, str, dict[str, Any]]:
    """Simulate one log of a world with one ring and score every pipeline (in a worker)."""
    ring_name, world_name, _, rng = task
    config = Config()
    w = world(world_name)
    ring = RINGS[ring_name][1]
    log = simulate_log(w, ring, config.realism, rng=rng)
    metrics, *_ = score_world(config, w, log, NAMES, ring=ring)
    return ring_name, world_name, metrics


def _mean(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.mean(finite)) if finite else float("nan")


def _met(ok: bool) -> str:
    return "**met**" if ok else "missed"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument(
        "--rings", default=",".join(RINGS), help=f"comma-separated, of {', '.join(RINGS)}"
    )
    args = parser.parse_args()
    rings = [r for r in args.rings.split(",") if r]
    unknown = [r for r in rings if r not in RINGS]
    if unknown or args.jobs < 1:
        parser.error(f"unknown ring(s) {unknown} or --jobs below 1")
    config = Config()
    tasks = []
    for ring_name in rings:
        # the record's streams, fresh for each ring: one per (world, run), in the order
        # reproduce sonar draws them
        streams = spawn(config.seed, len(config.worlds) * config.runs)
        for i, name in enumerate(config.worlds):
            for k in range(config.runs):
                tasks.append((ring_name, name, k, streams[i * config.runs + k]))
    started = time.perf_counter()
    scores: dict[tuple[str, str], dict[str, dict[str, list[float]]]] = {}
    with contextlib.ExitStack() as stack:
        if args.jobs > 1:
            pool = stack.enter_context(ProcessPoolExecutor(args.jobs))
            outcomes: Iterator[tuple[str, str, dict[str, Any]]] = pool.map(_task, tasks)
        else:
            outcomes = map(_task, tasks)
        for done, (ring_name, world_name, metrics) in enumerate(outcomes, start=1):
            table = scores.setdefault((ring_name, world_name), {})
            for name, values in metrics.items():
                for key, value in values.items():
                    table.setdefault(name, {}).setdefault(key, []).append(value)
            print(f"{ring_name} {world_name} ({done}/{len(tasks)})", flush=True)
    minutes = (time.perf_counter() - started) / 60.0
    load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
    lines = [
        "## Other robots' rings (`python benchmarks/sonar_rings.py`)",
        "",
        f"Run by `python benchmarks/sonar_rings.py {' '.join(sys.argv[1:])}`".rstrip()
        + f" in {minutes:.1f} min on {machine()}; load average at the end {load}. The "
        "record's worlds and log streams (seed 2007, three runs a world), each driven with "
        "the ring named; default pipeline, thresholds as learnt on Pioneer rings; means of "
        "the three runs. *Margin*: the default's κ minus the best baseline's (target "
        "≥ +0.10); *missed − ROS*: the default's missed-wall rate minus the ROS layer's "
        "(≤ 0); *path*: path cells mapped occupied (0); rejection precision / recall "
        "(≥ 0.85).",
    ]
    for ring_name in rings:
        lines += [
            "",
            f"**{ring_name}**: {RINGS[ring_name][0]}",
            "",
            "| world | κ default | best baseline (κ) | margin | missed − ROS | path "
            "| rej. precision / recall |",
            "|---|--:|---|--:|--:|--:|---|",
        ]
        for world_name in config.worlds:
            mean = {
                p: {k: _mean(v) for k, v in m.items()}
                for p, m in scores[(ring_name, world_name)].items()
            }
            best = max(BASELINES, key=lambda b: mean[b]["kappa"])
            margin = mean["default"]["kappa"] - mean[best]["kappa"]
            missed = mean["default"]["missed_wall_rate"] - mean["ros"]["missed_wall_rate"]
            path = mean["default"]["path_occupied"]
            precision = mean["default"]["rejection_precision"]
            recall = mean["default"]["rejection_recall"]
            lines.append(
                f"| {world_name} | {mean['default']['kappa']:.3f} "
                f"| {best} ({mean[best]['kappa']:.3f}) | {margin:+.3f} {_met(margin >= 0.1)} "
                f"| {missed:+.3f} {_met(missed <= 0)} | {path:.1f} {_met(path == 0)} "
                f"| {precision:.2f} / {recall:.2f} "
                f"{_met(min(precision, recall) >= 0.85)} |"
            )
    update_section("sonar_rings", "\n".join(lines), DOC)
    print(f"wrote the section sonar_rings of {DOC}")


if __name__ == "__main__":
    main()
