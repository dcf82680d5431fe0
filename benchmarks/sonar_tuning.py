"""Learn the sonar filter's thresholds and the map model's options from simulated logs.

The realistic simulator (:mod:`bayesmap.sim.sonar_log`) knows which readings are specular and
where the walls are, so the settings the ICINCO 2007 fragment leaves open can be chosen by
measurement. Tuning logs come from seeds that ``reproduce sonar`` never uses (tuning seed
``TUNE_SEED``; the experiment's is 2007), one per realistic world.

1. Filter: coordinate ascent, one setting at a time over a small grid, maximising the mean
   over worlds of min(rejection precision, rejection recall) against the specular truth.
2. Map model: with the tuned filter, coordinate ascent over the no-echo handling, clear
   distance, saturation, decay and footprint clearing, maximising the mean κ over worlds
   less 0.01 per path cell mapped occupied. The same options are scored without the filter,
   so the filter is kept only if it earns its place.

Writes the section ``sonar_tuning`` of docs/sonar.md. Run from the repository root:
``python benchmarks/sonar_tuning.py`` (a few minutes on a shared 2-core machine).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap._rng import spawn  # noqa: E402
from bayesmap.experiments.sonar import (  # noqa: E402
    Config,
    make_ring,
    map_metrics,
    path_cells,
    ring_geometry,
    truth_layers,
)
from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.sim.polygons import REALISTIC_WORLDS, world  # noqa: E402
from bayesmap.sim.sonar_log import SimulatedLog, simulate_log  # noqa: E402
from bayesmap.sonar.pipeline import PIPELINES, Pipeline, map_log  # noqa: E402

TUNE_SEED = 1
SEEDS_PER_WORLD = 1
DOC = Path(__file__).resolve().parent.parent / "docs" / "sonar.md"

FILTER_GRID: dict[str, list[Any]] = {
    "no_echo_spread": [0.0, 0.2],
    "extension": [0.3, 1.0],
    "certainty_threshold": [0.3, 0.5],
    "pass_limit": [2, 3],
    "min_length": [0.3, 0.6],
}
FILTER_START: dict[str, Any] = {
    "extension": 1.0,
    "no_echo_spread": 0.0,
    "margin": 0.3,
    "pass_limit": 3,
    "certainty_threshold": 0.5,
    "min_length": 0.3,
}
MAP_GRID: dict[str, list[Any]] = {
    "no_echo": [("ignore", 2.0), ("clear", 0.5), ("clear", 1.0), ("clear", 2.0), ("cone", 5.0)],
    "clamp": [3.0, 10.0],
    "decay": [0.0, 0.1],
    "footprint": [0.0, 0.2],
    "p_free": [0.35, 0.38, 0.4, 0.42, 0.45],
}
MAP_START: dict[str, Any] = {
    "no_echo": ("cone", 5.0),
    "clamp": 10.0,
    "decay": 0.0,
    "footprint": 0.0,
    "p_free": 0.35,
}


class _NoMap:
    """Stands in for a mapper while only the filter's verdicts are wanted."""

    def __init__(self, grid: OccupancyGrid, geometry: Any) -> None:
        self.grid = grid
        self.geometry = geometry

    def integrate(self, *args: Any, **kwargs: Any) -> None:
        return None

    def probability(self) -> np.ndarray:
        return np.full(self.grid.shape, 0.5)

    def observed(self) -> np.ndarray:
        return np.zeros(self.grid.shape, dtype=bool)

    def sync(self) -> OccupancyGrid:
        return self.grid


class _Case:
    def __init__(self, config: Config, name: str, log: SimulatedLog) -> None:
        w = world(name)
        xmin, ymin, xmax, ymax = w.bounds
        self.size = (xmax - xmin + 2.0, ymax - ymin + 2.0)
        self.origin = (xmin - 1.0, ymin - 1.0)
        template = self.grid()
        self.name, self.log = name, log
        self.truth, self.wall = truth_layers(w, template, log.poses, config.max_range)
        self.driven = path_cells(template, log.odometry, config.footprint)

    def grid(self) -> OccupancyGrid:
        return OccupancyGrid(*self.size, 0.1, origin=self.origin)


def _filter_scores(
    cases: list[_Case], geometry: Any, options: dict[str, Any]
) -> tuple[float, dict]:
    pipeline = replace(
        PIPELINES["paper"], filter_options=tuple(options.items()), merge_repeats=True
    )
    per_world: dict[str, list[float]] = {}
    verdicts = {}
    for i, case in enumerate(cases):
        filt = pipeline.make_filter(geometry)
        run = map_log(
            case.log.odometry,
            case.log.ranges,
            _NoMap(case.grid(), geometry),
            filt,
            merge_repeats=True,
        )
        rejected, spec = ~run.accepted, case.log.specular
        hits = float((rejected & spec).sum())
        precision = hits / max(float(rejected.sum()), 1.0)
        recall = hits / max(float(spec.sum()), 1.0)
        per_world.setdefault(case.name, []).append(min(precision, recall))
        verdicts[i] = (run.accepted, run.repeat, precision, recall)
    score = float(np.mean([np.mean(v) for v in per_world.values()]))
    return score, verdicts


def _map_scores(
    cases: list[_Case], geometry: Any, pipeline: Pipeline, verdicts: dict | None
) -> tuple[float, dict[str, float]]:
    kappas: dict[str, list[float]] = {}
    path_occ: list[float] = []
    for i, case in enumerate(cases):
        mapper = pipeline.make_mapper(case.grid(), geometry)
        log = case.log
        if verdicts is None:
            map_log(log.odometry, log.ranges, mapper, None, merge_repeats=pipeline.merge_repeats)
        else:
            accepted, repeat, _, _ = verdicts[i]
            for k in np.flatnonzero(~repeat):
                mapper.integrate(log.odometry[k], log.ranges[k], accepted[k])
        probability = mapper.probability()
        m = map_metrics(probability, mapper.observed(), case.truth, case.wall)
        kappas.setdefault(case.name, []).append(m["kappa"])
        path_occ.append(float((case.driven & (probability > 0.5)).sum()))
    per_world = {k: float(np.mean(v)) for k, v in kappas.items()}
    score = float(np.mean(list(per_world.values()))) - 0.01 * float(np.mean(path_occ))
    return score, per_world


def _map_pipeline(base: Pipeline, options: dict[str, Any]) -> Pipeline:
    mode, distance = options["no_echo"]
    return replace(
        base,
        no_echo=mode,
        clear_distance=distance,
        clamp=options["clamp"],
        decay=options["decay"],
        footprint=options["footprint"],
        p_free=options["p_free"],
        merge_repeats=True,
    )


def main() -> None:
    started = time.perf_counter()
    config = Config()
    geometry = ring_geometry(make_ring(config))
    streams = spawn(TUNE_SEED, len(REALISTIC_WORLDS) * SEEDS_PER_WORLD)
    cases = []
    for i, name in enumerate(REALISTIC_WORLDS):
        for k in range(SEEDS_PER_WORLD):
            rng = streams[i * SEEDS_PER_WORLD + k]
            cases.append(
                _Case(
                    config,
                    name,
                    simulate_log(world(name), make_ring(config), config.realism, rng=rng),
                )
            )
    lines = ["### Filter settings (mean over worlds of min(rejection precision, recall))", ""]
    best = dict(FILTER_START)
    best_score, best_verdicts = _filter_scores(cases, geometry, best)
    lines.append(f"- start {best}: {best_score:.3f}")
    for key, values in FILTER_GRID.items():
        for value in values:
            if value == best[key]:
                continue
            trial = {**best, key: value}
            score, verdicts = _filter_scores(cases, geometry, trial)
            lines.append(f"- {key} = {value}: {score:.3f}")
            print(key, value, round(score, 3), flush=True)
            if score > best_score + 1e-4:
                best, best_score, best_verdicts = trial, score, verdicts
        lines.append(f"  → {key} = {best[key]}")
    precision = np.mean([v[2] for v in best_verdicts.values()])
    recall = np.mean([v[3] for v in best_verdicts.values()])
    lines += ["", f"Chosen filter: {best}; precision {precision:.3f}, recall {recall:.3f}.", ""]

    lines += ["### Map options (mean κ over worlds − 0.01 × path cells occupied)", ""]
    base = replace(PIPELINES["paper"], filter_options=tuple(best.items()))
    map_best = dict(MAP_START)
    map_score, map_worlds = _map_scores(
        cases, geometry, _map_pipeline(base, map_best), best_verdicts
    )
    lines.append(f"- start {map_best}: {map_score:.3f}")
    for key, values in MAP_GRID.items():
        for value in values:
            if value == map_best[key]:
                continue
            trial = {**map_best, key: value}
            score, per_world = _map_scores(
                cases, geometry, _map_pipeline(base, trial), best_verdicts
            )
            worlds = ", ".join(f"{v:.3f}" for v in per_world.values())
            lines.append(f"- {key} = {value}: {score:.3f} (κ per world: {worlds})")
            print(key, value, round(score, 3), flush=True)
            if score > map_score + 1e-4:
                map_best, map_score, map_worlds = trial, score, per_world
        lines.append(f"  → {key} = {map_best[key]}")
    unfiltered = replace(
        _map_pipeline(base, map_best),
        acceptability=False,
        agreeability=False,
        trait_verification=False,
    )
    plain_score, plain_worlds = _map_scores(cases, geometry, unfiltered, None)
    lines += [
        "",
        f"Chosen map options: {map_best}; score {map_score:.3f} with the filter, "
        f"{plain_score:.3f} without it.",
        "",
        "| world | κ with filter | κ same map, no filter |",
        "|---|---|---|",
    ]
    for name in map_worlds:
        lines.append(f"| {name} | {map_worlds[name]:.3f} | {plain_worlds[name]:.3f} |")
    elapsed = time.perf_counter() - started
    lines += [
        "",
        f"{len(cases)} tuning logs; {elapsed / 60:.1f} min on {machine()}; load average at "
        f"the end {' / '.join(f'{v:.1f}' for v in os.getloadavg())} (shared machine).",
    ]
    text = "\n".join(lines)
    print(text)
    update_section("sonar_tuning", text, doc=DOC)


if __name__ == "__main__":
    main()
