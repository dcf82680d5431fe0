"""Diagnostics behind docs/sonar.md's open-hall and truth-label notes (prints; only
``transient`` writes a figure).

``python benchmarks/sonar_diagnose.py variants WORLDS SEEDS [NAME:OPTION=VALUE,...;...]``
maps one simulated log per world and seed (``numpy.random.default_rng(seed)``, seeds the
benchmark of record does not use) with the best unfiltered baseline, the ROS layer (whose
missed-wall rate is the target's bound) and variants of the
one-pass ``streaming`` pipeline (``nofilt=1`` switches its filter off; ``filter.NAME=VALUE`` sets a
:class:`~bayesmap.sonar.filter.SpecularFilter` option; other options are
:class:`~bayesmap.sonar.pipeline.Pipeline` fields), and prints κ, false obstacles (also
as cells near and far from solid: thick walls versus traces of people), missed walls, path
cells occupied and rejection precision/recall.

``python benchmarks/sonar_diagnose.py labels WORLDS SEED`` compares the simulator's truth
labels (a reading is specular when its echo bounced or was lost while a wall stood in its
cone) with an axis-only label (specular when the first echo is not from the nearest surface
on the beam axis: an echo more than 0.1 m beyond it, or no echo with a surface on the axis
within range; echoes from people are good), and prints the default filter's rejection
precision and recall under both, with Wilson 95 % intervals and counts by echo kind.
``python benchmarks/sonar_diagnose.py ceiling WORLDS SEEDS`` bounds what any filter can
give a world: it maps each log with the streaming pipeline's map and with the best baseline's
map, fed by an oracle that rejects exactly the readings the simulator labels specular (and,
in a second pair, the echoes from people too), and prints κ beside the streaming pipeline's
and the baseline's own.

``python benchmarks/sonar_diagnose.py verdict WORLDS SEEDS [PIPELINE]`` learns the
thresholds of the map's verdict (:class:`~bayesmap.sonar.map_verdict.MapVerdict`) of a
pipeline (default ``streaming``; ``default`` judges by its map after the forward-model
sweep): it maps one log per
world and seed with the pipeline's filter and map, then judges the rings again by that map
under each setting, by coordinate ascent from the shipped settings over a small
grid (two rounds), maximising the worst log's min(rejection precision, recall) — the target
holds in every world —, ties broken by the mean over logs; it prints every step.

``python benchmarks/sonar_diagnose.py wrong WORLDS SEEDS`` maps one log per world and seed
with the streaming pipeline (the map's verdict included) and prints the good readings it
rejects, by the stage that rejected them and the simulator's kind of reading, and the
specular readings it keeps, by kind.

``python benchmarks/sonar_diagnose.py speed WORLDS SEED`` times the streaming and the
default pipeline (filter and map, CPU seconds) on one log per world and prints readings per
CPU second with the load average (a loaded machine inflates CPU time too).

``python benchmarks/sonar_diagnose.py transient WORLDS SEED [FOLDER]`` maps one log per
world with the default pipeline and draws the map with the cells its verdict set aside as
surfaces that moved on (:func:`~bayesmap.sonar.map_verdict.transient_cells`) beside the
people's true paths, as ``FOLDER/sonar_transient_<world>.png`` (default ``docs``); it
prints how many of those cells lie within 0.3 m of where a person stood (a person's radius
and a cell) and how many on a true obstacle.

WORLDS is a comma-separated list of registered world names.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
from scipy.ndimage import distance_transform_edt  # noqa: E402
from scipy.stats import binomtest  # noqa: E402

from bayesmap.experiments.sonar import (  # noqa: E402
    Config,
    make_ring,
    map_metrics,
    path_cells,
    ring_geometry,
    score_world,
    truth_layers,
)
from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.sim.polygons import world  # noqa: E402
from bayesmap.sim.sonar import EchoKind, cast_rays  # noqa: E402
from bayesmap.sim.sonar_log import simulate_log  # noqa: E402
from bayesmap.sonar.filter import RingVerdict, Stage  # noqa: E402
from bayesmap.sonar.map_verdict import (  # noqa: E402
    MapVerdict,
    clearance,
    judge_by_map,
    transient_cells,
)
from bayesmap.sonar.pipeline import PIPELINES, build_map, grid_for_poses, map_log  # noqa: E402
from bayesmap.viz.sonar import transient_png  # noqa: E402

BASELINE = "elfes-ignore-no-echo"


def _variants(spec: str) -> dict[str, object]:
    out: dict[str, object] = {}
    for item in filter(None, spec.split(";")):
        name, _, options = item.partition(":")
        kw: dict[str, object] = {}
        for pair in filter(None, options.split(",")):
            key, value = pair.split("=")
            kw[key] = value if key == "no_echo" else float(value)
        if kw.pop("nofilt", 0):
            kw.update(acceptability=False, agreeability=False, trait_verification=False)
        # ``verdict=0`` drops the map's verdict; ``verdict.NAME=VALUE`` sets one threshold.
        verdict = {k.removeprefix("verdict."): v for k, v in kw.items() if k.startswith("verdict")}
        kw = {k: v for k, v in kw.items() if not k.startswith("verdict")}
        base_verdict = PIPELINES["streaming"].map_verdict
        if verdict.pop("verdict", 1) == 0:
            kw["map_verdict"] = None
        elif verdict and base_verdict is not None:
            kw["map_verdict"] = dataclasses.replace(base_verdict, **verdict)  # type: ignore[arg-type]
        # ``filter.NAME=VALUE`` sets a SpecularFilter option on top of the streaming pipeline's.
        base = PIPELINES["streaming"]
        extra = {k.removeprefix("filter."): v for k, v in kw.items() if k.startswith("filter.")}
        if extra:
            kw = {k: v for k, v in kw.items() if not k.startswith("filter.")}
            kw["filter_options"] = tuple({**dict(base.filter_options), **extra}.items())
        out[name] = dataclasses.replace(base, **kw)  # type: ignore[arg-type]
    return out


def variants(worlds: str, seeds: str, spec: str) -> None:
    """Print the baseline's and each variant's scores on one log per world and seed."""
    extra = _variants(spec or "streaming:")
    PIPELINES.update(extra)  # type: ignore[arg-type]
    names = (BASELINE, "ros", *extra)
    config = Config()
    for name in worlds.split(","):
        w = world(name)
        for seed in (int(s) for s in seeds.split(",")):
            log = simulate_log(
                w, make_ring(config), config.realism, rng=np.random.default_rng(seed)
            )
            metrics, maps, grid, truth = score_world(config, w, log, names)
            solid = truth.astype(bool)
            clearance = distance_transform_edt(~solid) * grid.resolution
            for pipeline in names:
                m = metrics[pipeline]
                wrong = (maps[pipeline] > 0.5) & ~solid
                far = int((wrong & (clearance > 1.0)).sum())
                near = int((wrong & (clearance <= 0.35)).sum())
                print(
                    f"{name} seed {seed} {pipeline}: κ {m['kappa']:.3f}, false obstacle "
                    f"{m['false_obstacle_rate']:.3f}, missed wall {m['missed_wall_rate']:.3f}, "
                    f"path cells {m['path_occupied']:.0f}; false obstacle cells within 0.35 m "
                    f"of solid {near}, over 1 m from it {far}; rejection precision "
                    f"{m['rejection_precision']:.2f}, recall {m['rejection_recall']:.2f}",
                    flush=True,
                )


def _share(k: int, n: int) -> str:
    if n == 0:
        return "– (n=0)"
    ci = binomtest(k, n).proportion_ci(0.95, method="wilson")
    return f"{k / n:.3f} [{ci.low:.3f}, {ci.high:.3f}] (n={n})"


def _ring_setup() -> tuple[Config, Any, Any]:
    """The experiment's configuration, its ring and the ring's geometry."""
    config = Config()
    ring = make_ring(config)
    return config, ring, ring_geometry(ring)


def _mapped(log: Any, ring: Any, config: Config, geometry: Any, pipeline: Any) -> tuple[Any, Any]:
    """Map a simulated log's odometry with ``pipeline``: the mapper and the run's verdicts."""
    grid = grid_for_poses(log.odometry, ring.max_range + 1.0, config.resolution)
    mapper = pipeline.make_mapper(grid, geometry)
    run = map_log(
        log.odometry,
        log.ranges,
        mapper,
        pipeline.make_filter(geometry),
        merge_repeats=pipeline.merge_repeats,
        map_verdict=pipeline.map_verdict,
    )
    return mapper, run


def labels(worlds: str, seed: str) -> None:
    """Print the default filter's precision/recall under the simulator's and the axis label."""
    config, ring, geometry = _ring_setup()
    pipeline = dataclasses.replace(PIPELINES["streaming"], map_verdict=None)  # the filter alone
    for name in worlds.split(","):
        w = world(name)
        log = simulate_log(w, ring, config.realism, rng=np.random.default_rng(int(seed)))
        centres, axis = ring.positions(log.poses)
        rays = np.stack([np.cos(axis), np.sin(axis)], axis=-1).reshape(-1, 2)
        surface, _ = cast_rays(centres.reshape(-1, 2), rays, w.segments)
        surface = surface.reshape(log.ranges.shape)
        echo = log.ranges < ring.max_range
        person = log.kind == EchoKind.PERSON
        on_axis = np.where(echo, (log.ranges > surface + 0.1) & ~person, surface < ring.max_range)
        _, run = _mapped(log, ring, config, geometry, pipeline)
        rejected = ~run.accepted
        for label, specular in (("simulator (cone)", log.specular), ("axis only", on_axis)):
            hits = int((rejected & specular).sum())
            print(
                f"{name} seed {seed}, {label} label: {int(specular.sum())} specular of "
                f"{specular.size}; precision {_share(hits, int(rejected.sum()))}, "
                f"recall {_share(hits, int(specular.sum()))}",
                flush=True,
            )
        kinds = ", ".join(
            f"{kind.name.lower()} {int((rejected & (log.kind == kind)).sum())} of "
            f"{int((log.kind == kind).sum())}"
            for kind in EchoKind
        )
        lost = log.kind == EchoKind.LOST
        print(
            f"{name}: rejected by kind: {kinds}; lost echoes with a surface on the axis within "
            f"range: {int((lost & (surface < ring.max_range)).sum())} of {int(lost.sum())}",
            flush=True,
        )


class _Oracle:
    """A stand-in filter that rejects the readings whose truth label says so."""

    def __init__(self, poses: np.ndarray, reject: np.ndarray) -> None:
        self.row = {pose.tobytes(): i for i, pose in reversed(list(enumerate(poses)))}
        self.reject = reject

    def process_many(self, poses: np.ndarray, ranges: np.ndarray) -> RingVerdict:
        rows = [self.row[pose.tobytes()] for pose in poses]
        rejected = self.reject[rows]
        stage = np.where(rejected, int(Stage.TRAIT_VERIFICATION), int(Stage.ACCEPTED))
        return RingVerdict(
            ~rejected, np.zeros_like(rejected), stage, np.full(rejected.shape, np.inf)
        )


def ceiling(worlds: str, seeds: str) -> None:
    """Print κ of the streaming and baseline maps fed by a truth-label oracle filter."""
    config, ring, geometry = _ring_setup()
    for name in worlds.split(","):
        w = world(name)
        for seed in (int(s) for s in seeds.split(",")):
            log = simulate_log(w, ring, config.realism, rng=np.random.default_rng(seed))
            metrics, _, grid, _ = score_world(config, w, log, ("streaming", BASELINE))
            truth, wall = truth_layers(w, grid, log.poses, config.max_range)
            driven = path_cells(grid, log.odometry, config.footprint)
            person = log.kind == EchoKind.PERSON
            line = [f"{p} {metrics[p]['kappa']:.3f}" for p in ("streaming", BASELINE)]
            for label, reject in (
                ("specular", log.specular),
                ("specular+people", log.specular | person),
            ):
                for p in ("streaming", BASELINE):
                    pipeline = PIPELINES[p]
                    x0, x1, y0, y1 = grid.extent
                    mapper = pipeline.make_mapper(
                        OccupancyGrid(x1 - x0, y1 - y0, grid.resolution, origin=grid.origin),
                        geometry,
                    )
                    oracle = _Oracle(log.odometry, reject)
                    map_log(
                        log.odometry,
                        log.ranges,
                        mapper,
                        oracle,  # type: ignore[arg-type]
                        merge_repeats=pipeline.merge_repeats,
                    )
                    probability = mapper.probability()
                    scores = map_metrics(probability, mapper.observed(), truth, wall)
                    occupied = int((driven & (probability > 0.5)).sum())
                    line.append(
                        f"{p} map, oracle rejects {label} {scores['kappa']:.3f} "
                        f"(path cells {occupied})"
                    )
            print(f"{name} seed {seed}: κ " + "; ".join(line), flush=True)


VERDICT_GRID: dict[str, list[float]] = {
    "silence_confidence": [0.9, 0.95, 0.97, 0.99, 0.999],
    "silence_width": [0.25, 0.5, 1.0],
    "silence_margin": [0.0, 0.3, 0.5],
    "open_confidence": [0.5, 0.6, 0.7, 0.9, 0.95, 0.99, 0.999],
    "echo_confidence": [0.5, 0.7, 0.9],
    "echo_margin": [0.4, 0.8, 1.2],
}


def verdict(worlds: str, seeds: str, pipeline_name: str = "streaming") -> None:
    """Learn a pipeline's map verdict by coordinate ascent on one log per world and seed."""
    config, ring, geometry = _ring_setup()
    pipeline = dataclasses.replace(PIPELINES[pipeline_name], map_verdict=None)
    cases = []
    for name in worlds.split(","):
        for seed in (int(s) for s in seeds.split(",")):
            log = simulate_log(world(name), ring, config.realism, rng=np.random.default_rng(seed))
            mapper, run = _mapped(log, ring, config, geometry, pipeline)
            mapper.sync()  # the map the pipeline ends with (refined, where it refines)
            fresh = ~run.repeat
            last = np.maximum.accumulate(np.where(fresh, np.arange(len(fresh)), 0))
            cases.append((f"{name} {seed}", mapper, log, run, fresh, last))

    def score(setting: dict[str, float]) -> tuple[float, float, list[str]]:
        judged = MapVerdict(**setting)  # type: ignore[arg-type]
        mins, shown = [], []
        for label, mapper, log, run, fresh, last in cases:
            accepted = run.accepted.copy()
            accepted[fresh], _ = judge_by_map(
                mapper.probability(),
                mapper.grid,
                geometry,
                log.odometry[fresh],
                log.ranges[fresh],
                run.accepted[fresh],
                run.stage[fresh],
                judged,
            )
            rejected = ~accepted[last]
            hits = int((rejected & log.specular).sum())
            precision = hits / max(int(rejected.sum()), 1)
            recall = hits / max(int(log.specular.sum()), 1)
            mins.append(min(precision, recall))
            shown.append(f"{label} {precision:.2f}/{recall:.2f}")
        return min(mins), float(np.mean(mins)), shown

    base = MapVerdict()
    setting = {key: float(getattr(base, key)) for key in VERDICT_GRID}
    best = score(setting)
    print(f"start {setting}: worst {best[0]:.3f}, mean {best[1]:.3f}", flush=True)
    for round_ in (1, 2):
        for key, values in VERDICT_GRID.items():
            for value in values:
                if value == setting[key]:
                    continue
                trial = score({**setting, key: value})
                print(f"round {round_} {key} = {value}: worst {trial[0]:.3f}, mean {trial[1]:.3f}")
                if trial[:2] > best[:2]:
                    best, setting = trial, {**setting, key: value}
            print(f"  -> {key} = {setting[key]}", flush=True)
    print(f"chosen {setting}: worst {best[0]:.3f}, mean {best[1]:.3f}")
    print("; ".join(best[2]))
    print("filter alone: " + "; ".join(_filter_alone(cases)))


def _filter_alone(cases: list) -> list[str]:
    shown = []
    for label, _, log, run, _, _ in cases:
        rejected = ~run.accepted
        hits = int((rejected & log.specular).sum())
        shown.append(
            f"{label} {hits / max(int(rejected.sum()), 1):.2f}/"
            f"{hits / max(int(log.specular.sum()), 1):.2f}"
        )
    return shown


def wrong(worlds: str, seeds: str) -> None:
    """Print the streaming pipeline's wrong rejections by stage and kind, and specular kept."""
    config, ring, geometry = _ring_setup()
    pipeline = PIPELINES["streaming"]
    for name in worlds.split(","):
        for seed in (int(s) for s in seeds.split(",")):
            log = simulate_log(world(name), ring, config.realism, rng=np.random.default_rng(seed))
            _, run = _mapped(log, ring, config, geometry, pipeline)
            rejected, specular = ~run.accepted, log.specular
            hits = int((rejected & specular).sum())
            print(
                f"{name} seed {seed}: precision {_share(hits, int(rejected.sum()))}, "
                f"recall {_share(hits, int(specular.sum()))}",
                flush=True,
            )
            for stage in Stage:
                wrongly = rejected & ~specular & (run.stage == stage)
                if wrongly.any():
                    kinds = _by_kind(wrongly, log.kind)
                    print(f"  good readings rejected by {stage.name.lower()}: {kinds}")
            print(
                f"  specular readings kept: {_by_kind(run.accepted & specular, log.kind)}",
                flush=True,
            )


def _by_kind(chosen: np.ndarray, kinds: np.ndarray) -> str:
    """``kind count, ...`` of the chosen readings, by the simulator's kind."""
    return ", ".join(
        f"{kind.name.lower()} {int((chosen & (kinds == kind)).sum())}"
        for kind in EchoKind
        if (chosen & (kinds == kind)).any()
    )


def speed(worlds: str, seed: str) -> None:
    """Print readings per CPU second of the streaming and the default pipeline, and the load."""
    config = Config()
    geometry = ring_geometry(make_ring(config))
    for name in worlds.split(","):
        log = simulate_log(
            world(name), make_ring(config), config.realism, rng=np.random.default_rng(int(seed))
        )
        for pipeline in ("streaming", "default"):
            started = time.process_time()
            build_map(
                log.odometry, log.ranges, geometry, config.resolution, pipeline=PIPELINES[pipeline]
            )
            cpu = time.process_time() - started
            load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
            print(
                f"{name} seed {seed} {pipeline}: {log.ranges.size:,} readings in {cpu:.2f} CPU s, "
                f"{log.ranges.size / cpu:,.0f} readings per CPU second (load average {load})",
                flush=True,
            )


def transient(worlds: str, seed: str, folder: str = "docs") -> None:
    """Draw each world's default map with its transient cells and the people's paths."""
    config, ring, geometry = _ring_setup()
    pipeline = PIPELINES["default"]
    assert pipeline.map_verdict is not None
    for name in worlds.split(","):
        w = world(name)
        log = simulate_log(w, ring, config.realism, rng=np.random.default_rng(int(seed)))
        mapper, run = _mapped(log, ring, config, geometry, pipeline)
        grid, probability = mapper.grid, mapper.probability()
        moved = transient_cells(
            probability,
            grid,
            geometry,
            log.odometry,
            log.ranges,
            pipeline.map_verdict,
            np.flatnonzero(~run.repeat),
        )
        stood = log.people.reshape(-1, 2)
        stood = stood[np.all(np.isfinite(stood), axis=1)]
        rows, cols = grid.world_to_cell(stood[:, 0], stood[:, 1])
        inside = grid.in_bounds(rows, cols)
        where_people = np.zeros(grid.shape, dtype=bool)
        where_people[rows[inside], cols[inside]] = True
        near_people = clearance(where_people, grid) <= config.realism.person_radius + 0.1
        solid, _ = truth_layers(w, grid, log.poses, ring.max_range)
        leaning = probability > 0.5
        print(
            f"{name} seed {seed}: {int(moved.sum())} transient cells of {int(leaning.sum())} "
            f"the map leans occupied; within 0.3 m of a person "
            f"{int((moved & near_people).sum())}, on a true obstacle "
            f"{int((moved & (solid > 0.5)).sum())}; cells leaning occupied within 0.3 m of a "
            f"person and not on an obstacle: {int((leaning & near_people & (solid <= 0.5)).sum())}",
            flush=True,
        )
        tracks = [t[np.all(np.isfinite(t), axis=1)] for t in log.people.transpose(1, 0, 2)]
        out = Path(folder) / f"sonar_transient_{name}.png"
        out.write_bytes(
            transient_png(
                probability,
                moved,
                grid.extent,
                walls=w.segments,
                tracks=tracks,
                title=f"{name}, seed {seed}: default map, surfaces that moved on in orange",
            )
        )
        print(f"wrote {out}", flush=True)


def main(argv: list[str]) -> None:
    if len(argv) >= 3 and argv[0] == "variants":
        variants(argv[1], argv[2], argv[3] if len(argv) > 3 else "")
    elif len(argv) == 3 and argv[0] == "ceiling":
        ceiling(argv[1], argv[2])
    elif len(argv) == 3 and argv[0] == "labels":
        labels(argv[1], argv[2])
    elif len(argv) in (3, 4) and argv[0] == "verdict":
        verdict(*argv[1:])
    elif len(argv) == 3 and argv[0] == "wrong":
        wrong(argv[1], argv[2])
    elif len(argv) == 3 and argv[0] == "speed":
        speed(argv[1], argv[2])
    elif len(argv) in (3, 4) and argv[0] == "transient":
        transient(*argv[1:])
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
