"""Safety stress: many short rover runs on fresh worlds, every near miss explained.

Issue 10's target is 0 collisions and a clearance above 0.05 m in *every* run, on layouts
nobody has tuned for. Long exploration runs test that only where a clever explorer happens
to go, so this harness drives many SHORT runs (``--steps``, default 2000 cycles) on worlds
drawn fresh by :func:`bayesmap.sim.rover_worlds.generate_world` (walls, L-shapes,
corridors, passages down to ``--passage`` metres, boxes, tilted obstacles, on 20 m areas),
with

- both explorers (``paper``, ``frontier``) and adversarial ones (``random``: targets
  drawn uniformly from the local area, :class:`RandomTarget`; ``forgetful``: the paper's
  rule without the explorer's memory of where it was hemmed in, so it is led back into
  tight spots), so that safety is measured apart from how well the explorer avoids
  trouble;
- both entropy initialisations;
- several run seeds;
- the GPS error (a Gauss-Markov process, ``gps_sigma``, ``gps_tau``) at the experiment's
  value and at ``--gps`` multiples of it. The rover's own model of its GPS stays at the
  nominal value, so the multiples test a GPS worse than the rover believes.

Each run writes ``OUT/<run>.json`` (its metrics, near misses and the 1-minute load average
it ended at) when it ends, and a rerun skips finished runs; ``--seed N`` runs one seed.
For every cycle whose true clearance falls below ``--near`` (0.1 m) it records what the
rover did and why: the command, whether the footprint check passed the heading and the
clearance it predicted, the GPS error then, whether the map (in the current GPS frame)
and the remembered readings knew the obstacle point nearest the body.
The table goes into its own section of docs/benchmarks.md. Run from the repository root::

    python benchmarks/rover_safety.py --worlds 6 --seeds 1 --jobs 2
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import shapely
from numpy.random import SeedSequence

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap._io import write_json  # noqa: E402
from bayesmap._rng import RNGLike, as_generator  # noqa: E402
from bayesmap.experiments import rover  # noqa: E402
from bayesmap.geometry import wrap_angle  # noqa: E402
from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.rover import explorer as explorer_module  # noqa: E402
from bayesmap.rover.explorer import Decision  # noqa: E402
from bayesmap.rover.mapping import UncertainBlocks  # noqa: E402
from bayesmap.rover.params import RoverParams  # noqa: E402
from bayesmap.rover.planning import LocalPlan  # noqa: E402
from bayesmap.rover.targets import EntropyTarget, FrontierTarget, TargetRule  # noqa: E402
from bayesmap.sim.rover_worlds import generate_world  # noqa: E402
from bayesmap.sim.world2d import BoxWorld, box_world, world_distance  # noqa: E402

WORLD_SEED = 4242
"""Generator seed of the stress worlds (not the 2026 of ``rover_worlds.py``'s grid)."""

PAPER_RUNS = list(rover.RUNS)
"""The paper's four runs (``--paper``), as ``bayesmap reproduce rover`` runs them."""

EXPLORERS = {
    "paper": "entropy",
    "frontier": "frontier",
    "random": "entropy",
    "forgetful": "entropy",
}
"""Harness explorer → the experiment's rule name (``random`` replaces the rule;
``forgetful`` is the paper's rule with the explorer's memory of where it was hemmed in
switched off, the ablation that once hit a wall on generated world 2026/01)."""


class RandomTarget:
    """Adversarial target rule: a uniformly random cell of the local area, kept until the
    rover stands within ``view_range`` of it or ``patience`` cycles have passed.

    It knows nothing of entropy, so it sends the rover past walls, into corners and
    corridors for no reason; the footprint check alone must keep it safe. It never ends a
    run (it always has a target).
    """

    def __init__(self, params: RoverParams, rng: RNGLike = None, patience: int = 150) -> None:
        self.params = params
        self.rng = as_generator(rng)
        self.patience = patience
        self._target: tuple[float, float] | None = None
        self._age = 0

    def select(
        self,
        grid: OccupancyGrid,
        pose: npt.ArrayLike,
        plan: LocalPlan,
        uncertain: UncertainBlocks,
    ) -> tuple[float, float] | None:
        """Keep the current target, or draw a new one (a map cell within ``d_max``)."""
        x, y = (float(v) for v in np.asarray(pose, dtype=np.float64)[:2])
        self._age += 1
        target = self._target
        if (
            target is None
            or self._age > self.patience
            or math.hypot(target[0] - x, target[1] - y) <= self.params.view_range
        ):
            xmin, xmax, ymin, ymax = grid.extent
            d = self.params.d_max
            tx = float(self.rng.uniform(max(xmin, x - d), min(xmax, x + d)))
            ty = float(self.rng.uniform(max(ymin, y - d), min(ymax, y + d)))
            row, col = (int(v) for v in grid.world_to_cell(tx, ty))
            cx, cy = grid.cell_centers(row, col)
            target = (float(cx), float(cy))
            self._target, self._age = target, 0
        return target

    def reject(self, target: tuple[float, float]) -> None:
        """Draw another target next cycle."""
        if target == self._target:
            self._target = None


class Watched:
    """A target rule passed through, keeping the map it was last shown: the harness reads the
    map as it stood at each cycle, where a near miss happened, not as it ended."""

    def __init__(self, rule: TargetRule) -> None:
        self.rule = rule
        self.grid: OccupancyGrid | None = None

    def select(
        self,
        grid: OccupancyGrid,
        pose: npt.ArrayLike,
        plan: LocalPlan,
        uncertain: UncertainBlocks,
    ) -> tuple[float, float] | None:
        self.grid = grid
        return self.rule.select(grid, pose, plan, uncertain)

    def reject(self, target: tuple[float, float]) -> None:
        self.rule.reject(target)


PATCH = 4
"""Cells on each side of the rover's cell whose probability the harness keeps every cycle
(2 m at 0.5 m cells: beyond the footprint check's reach of 1.6 m)."""


def _map_class(p: float, prior: float, params: RoverParams) -> str:
    """Which kind of cell ``p`` is, as the footprint check's hazards are defined."""
    if p == prior:
        return "unknown"
    if p >= params.p_block:
        return "likely"
    return "below the prior" if p < prior else "suspect (above the prior)"


class Job(NamedTuple):
    world: int
    explorer: str
    init: str
    seed: int
    gps: float


def job_name(job: Job) -> str:
    where = PAPER_RUNS[-1 - job.world] if job.world < 0 else f"w{job.world:02d}"
    return f"{where}-{job.explorer}-{job.init}-gps{job.gps:g}-seed{job.seed}"


def _nearest_obstacle_point(world: BoxWorld, x: float, y: float) -> tuple[float, float]:
    """The point of the true obstacles nearest ``(x, y)``."""
    parts = [shapely.box(*b) for b in world.boxes] + [shapely.Polygon(p) for p in world.polygons]
    solid = shapely.union_all(parts)
    line = shapely.shortest_line(solid, shapely.Point(x, y))
    (px, py), _ = shapely.get_coordinates(line)
    return float(px), float(py)


def one_run(job: Job, args: argparse.Namespace) -> dict[str, Any]:
    """Drive one short run; return its metrics and the near misses with their causes."""
    gps_sigma = job.gps * rover.Config().gps_sigma
    if job.world < 0:  # the paper's field, as `bayesmap reproduce rover` runs it
        name = PAPER_RUNS[-1 - job.world]
        world = box_world(rover.RUNS[name][0])
        config = rover.Config.model_validate({"runs": (name,), "gps_sigma": gps_sigma})
    else:
        spec = generate_world(
            SeedSequence([args.world_seed, job.world]),
            size=args.size,
            passage=args.passage,
            name=f"rover-safety-w{args.world_seed}-{job.world:02d}",
        )
        world = spec.world
        config = rover.Config.model_validate(
            {
                "seed": job.seed,
                "resolution": spec.resolution,
                "max_steps": args.steps or rover.world_budget(spec),
                "start": spec.start,
                "gps_sigma": gps_sigma,
            }
        )
    params = config.rover_params()
    rule = Watched(
        RandomTarget(params, SeedSequence([job.seed, 7]))
        if job.explorer == "random"
        else FrontierTarget(params)
        if job.explorer == "frontier"
        else EntropyTarget(params)
    )
    headings = np.asarray(params.headings)
    cycles: list[dict[str, Any]] = []
    patches: list[tuple[int, int, np.ndarray]] = []  # per cycle: first row, first col, p

    def observe(step: int, pose: np.ndarray, decision: Decision, stalled: bool) -> None:
        index = int(np.argmin(np.abs(wrap_angle(headings - decision.heading))))
        safety = decision.safety
        grid = rule.grid
        assert grid is not None  # the rule is asked before the observer
        row, col = (int(v) for v in grid.world_to_cell(pose[0], pose[1]))
        r0, c0 = max(row - PATCH, 0), max(col - PATCH, 0)
        patch = grid.probability[r0 : row + PATCH + 1, c0 : col + PATCH + 1]
        patches.append((r0, c0, patch.copy()))
        cycles.append(
            {
                "estimate": [float(v) for v in pose],
                "command": [float(v) for v in decision.command],
                "safe": bool(safety.safe[index]),
                "any_safe": bool(safety.safe.any()),
                "retreat": bool(safety.retreat),
                "predicted": float(safety.clearance[index]),
                "here": float(safety.here),
                "back_clear": bool(safety.back_clear),
            }
        )

    remembered = explorer_module._HEMMED_TURNS
    if job.explorer == "forgetful":
        explorer_module._HEMMED_TURNS = 0  # this worker process only, restored below
    try:
        trace = rover.simulate(
            world,
            config,
            EXPLORERS[job.explorer],
            job.init == "random",
            rover.no_progress,
            "",
            observe,
            target_rule=rule,
        )
    finally:
        explorer_module._HEMMED_TURNS = remembered
    metrics = rover.run_metrics(trace, world, config, EXPLORERS[job.explorer])
    path = np.asarray(trace.path)
    radius = config.sim_params().radius
    clearance = np.array([world_distance(world, p[0], p[1]) - radius for p in path])
    grid = trace.explorer.grid
    near = []
    # path[k + 1] is where the decision of cycle k took the rover
    closest = np.argsort(clearance[1:], kind="stable")[: args.max_near]
    for k in closest[clearance[1:][closest] < args.near]:
        cycle = cycles[int(k)]
        true = path[k]
        estimate = np.asarray(cycle["estimate"])
        error = estimate[:2] - true[:2]
        after = path[k + 1]
        ox, oy = _nearest_obstacle_point(world, float(after[0]), float(after[1]))
        mx, my = ox + error[0], oy + error[1]  # the obstacle point in the rover's frame now
        inside = grid.extent[0] <= mx < grid.extent[1] and grid.extent[2] <= my < grid.extent[3]
        p_map = p_then = None
        then = "off the map"
        if inside:
            row, col = (int(v) for v in grid.world_to_cell(mx, my))
            p_map = round(float(grid.probability[row, col]), 3)
            r0, c0, patch = patches[int(k)]
            then = "beyond the check's reach"
            if 0 <= row - r0 < patch.shape[0] and 0 <= col - c0 < patch.shape[1]:
                p_then = float(patch[row - r0, col - c0])
                then = _map_class(p_then, params.prior, params)
                p_then = round(p_then, 3)
        action = (
            "back off"
            if cycle["command"][0] < 0
            else "retreat"
            if cycle["retreat"]
            else "pivot"
            if cycle["command"][0] == 0
            else "drive"
        )
        near.append(
            {
                "cycle": int(k),
                "clearance_m": round(float(clearance[k + 1]), 4),
                "action": action,
                "heading_passed": cycle["back_clear"] if action == "back off" else cycle["safe"],
                "predicted_m": round(cycle["predicted"], 4),
                "gps_error_m": round(float(np.hypot(*error)), 3),
                "obstacle": [round(ox, 2), round(oy, 2)],
                "map_p_at_obstacle": p_map,
                "map_p_then": p_then,
                "map_then": then,
            }
        )
    summary = {k: v for k, v in metrics.items() if k != "coverage_curve"}
    summary.update(job._asdict())
    summary["near_cycles"] = int((clearance[1:] < args.near).sum())
    summary["near_misses"] = near
    summary["load_1min"] = round(os.getloadavg()[0], 2)  # when the run ended
    return summary


def _metres(value: float | None) -> str:
    """A distance for the table; JSON writes an infinite one (nothing near) as null."""
    return "∞" if value is None else f"{value:.3f}"


def _quantiles(values: list[float]) -> str:
    q = np.quantile(values, [0.0, 0.1, 0.5])
    return " / ".join(f"{v:.3f}" for v in q)


def _run_loads(runs: list[dict[str, Any]]) -> str:
    """The 1-minute load averages the runs ended at (runs written before they were kept
    have none), so a summary made later with ``--report-only`` still states the load."""
    loads = [r["load_1min"] for r in runs if r.get("load_1min") is not None]
    if not loads:
        return ""
    return f"1-minute load average as the runs ended {min(loads):.1f}–{max(loads):.1f}; "


def summary(runs: list[dict[str, Any]], args: argparse.Namespace, wall: float) -> str:
    load = os.getloadavg()
    lines = [
        "## Rover safety stress (`benchmarks/rover_safety.py`)",
        "",
        f"`python benchmarks/rover_safety.py --worlds {args.worlds} "
        + (f"--seed {args.seed} " if args.seed is not None else f"--seeds {args.seeds} ")
        + f"--steps {args.steps} --gps {','.join(f'{g:g}' for g in args.gps)} "
        f"--explorers {','.join(args.explorers)} --inits {','.join(args.inits)} "
        f"--world-seed {args.world_seed} --size {args.size:g} --passage {args.passage:g}"
        + (f" --paper {','.join(args.paper)}" if args.paper else "")
        + "`. "
        f"{len(runs)} runs: at most {args.steps or 'the full budget of'} cycles on each "
        "generated world, the paper's runs at their full length; "
        "`random` is the adversarial explorer (uniformly random local targets). The rover "
        "believes the nominal GPS (σ = 0.1 m, τ = 20 s) at every multiple.",
        "",
        f"Machine: {machine()}; "
        + (
            "runs made earlier, summarised with `--report-only`; "
            if args.report_only
            else f"load average at the end {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f}; "
            f"{wall / 60:.1f} min wall time for the runs this invocation made; "
        )
        + _run_loads(runs)
        + f"median {np.median([r['cycle_ms'] for r in runs]):.0f} ms of wall time per cycle "
        "(inflated by the shared machine's load).",
        "",
        "| worlds | GPS × | explorer | runs | collisions | runs with clearance ≤ 0.05 m | "
        "min clearance (min / 10 % / median) [m] | cycles < "
        f"{args.near:g} m | coverage (median) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for paper, gps, explorer in itertools.product((False, True), args.gps, args.explorers):
        group = [
            r
            for r in runs
            if r["gps"] == gps and r["explorer"] == explorer and (r["world"] < 0) == paper
        ]
        if not group:
            continue
        clear = [r["min_clearance_m"] for r in group if r["min_clearance_m"] is not None]
        lines.append(
            f"| {'paper' if paper else 'generated'} | {gps:g} | {explorer} | {len(group)} | "
            f"{sum(r['collisions'] for r in group)} | "
            f"{sum(c <= 0.05 for c in clear)} | {_quantiles(clear) if clear else '—'} | "
            f"{sum(r['near_cycles'] for r in group)} | "
            f"{np.median([r['coverage'] for r in group]):.3f} |"
        )
    misses = sorted(
        ((r, m) for r in runs for m in r["near_misses"]), key=lambda rm: rm[1]["clearance_m"]
    )
    if misses:
        lines += [
            "",
            f"The {min(len(misses), args.table_misses)} closest cycles (true clearance after "
            "the cycle; *passed*: the footprint check judged the chosen heading safe, with "
            "the clearance it predicted (for a back-off: the recent track allowed it); "
            "GPS error then; the map's p, at that cycle and at the end, at the obstacle "
            "point nearest the body, moved into the rover's frame of that cycle, and what "
            "the cell was then: likely (p ≥ 0.5), suspect (above the prior), unknown (at "
            "the prior) or below the prior):",
            "",
            "| run | cycle | clearance [m] | action | passed | predicted [m] | "
            "GPS error [m] | obstacle point | map p then (end) | map then |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r, m in misses[: args.table_misses]:
            lines.append(
                f"| {job_name(Job(r['world'], r['explorer'], r['init'], r['seed'], r['gps']))} "
                f"| {m['cycle']} | {m['clearance_m']:.3f} | {m['action']} | "
                f"{'yes' if m['heading_passed'] else 'no'} | {_metres(m['predicted_m'])} | "
                f"{m['gps_error_m']:.3f} | ({m['obstacle'][0]}, {m['obstacle'][1]}) | "
                f"{m.get('map_p_then')} ({m['map_p_at_obstacle']}) | {m.get('map_then', '—')} |"
            )
    else:
        lines += ["", f"No cycle came closer than {args.near:g} m."]
    return "\n".join(lines)


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def _names(text: str) -> list[str]:
    return [v for v in text.split(",") if v]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", type=int, default=6)
    parser.add_argument("--world-seed", type=int, default=WORLD_SEED)
    parser.add_argument("--size", type=float, default=20.0, help="world side [m]")
    parser.add_argument("--passage", type=float, default=1.2, help="narrowest gap [m]")
    parser.add_argument("--seeds", type=int, default=1, help="run seeds 0 .. N-1")
    parser.add_argument("--seed", type=int, default=None, help="run this seed only")
    parser.add_argument(
        "--steps", type=int, default=2000, help="cycles per run; 0: the world's full budget"
    )
    parser.add_argument("--gps", type=_floats, default=[1.0, 2.0], help="GPS σ multiples")
    parser.add_argument("--explorers", type=_names, default=list(EXPLORERS))
    parser.add_argument("--inits", type=_names, default=["flat", "random"])
    parser.add_argument(
        "--paper",
        type=_names,
        default=[],
        help=f"also the paper's runs (full length, seed 2016), any of {','.join(PAPER_RUNS)}",
    )
    parser.add_argument("--near", type=float, default=0.1, help="near-miss clearance [m]")
    parser.add_argument("--max-near", type=int, default=20, help="closest cycles kept per run")
    parser.add_argument("--table-misses", type=int, default=12)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("results/rover_safety"))
    parser.add_argument("--report-only", action="store_true")
    parser.add_argument("--no-report", action="store_true", help="do not touch the docs")
    args = parser.parse_args()
    unknown = set(args.explorers) - set(EXPLORERS)
    if unknown:
        parser.error(f"unknown explorer(s) {sorted(unknown)}; choose from {list(EXPLORERS)}")
    if set(args.paper) - set(PAPER_RUNS):
        parser.error(f"unknown paper run(s) {args.paper}; choose from {PAPER_RUNS}")
    if args.seed is not None and args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")
    seeds = range(args.seeds) if args.seed is None else [args.seed]
    args.out.mkdir(parents=True, exist_ok=True)
    jobs = [
        Job(w, e, i, s, g)
        for g, w, e, i, s in itertools.product(
            args.gps, range(args.worlds), args.explorers, args.inits, seeds
        )
    ] + [  # the paper's runs: their own entropy initialisation and seed
        Job(-1 - PAPER_RUNS.index(name), e, "random" if rover.RUNS[name][1] else "flat", 0, g)
        for g, name, e in itertools.product(args.gps, args.paper, args.explorers)
    ]
    todo = (
        []
        if args.report_only
        else [j for j in jobs if not (args.out / f"{job_name(j)}.json").exists()]
    )
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(args.jobs, 1)) as pool:
        futures = {pool.submit(one_run, job, args): job for job in todo}
        for n, future in enumerate(as_completed(futures), 1):
            job = futures[future]
            result = future.result()
            write_json(args.out / f"{job_name(job)}.json", result)
            print(
                f"[{n}/{len(todo)}] {job_name(job)}: collisions {result['collisions']}, "
                f"min clearance {result['min_clearance_m']}, near cycles {result['near_cycles']}",
                flush=True,
            )
    wall = time.perf_counter() - started
    runs = [
        json.loads((args.out / f"{job_name(j)}.json").read_text(encoding="utf-8"))
        for j in jobs
        if (args.out / f"{job_name(j)}.json").exists()
    ]
    text = summary(runs, args, wall)
    print(text)
    if not args.no_report:
        update_section("rover_safety", text)


if __name__ == "__main__":
    main()
