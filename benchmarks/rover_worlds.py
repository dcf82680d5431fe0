"""Rover on generated stress worlds: safety, completeness and distance, both explorers.

Worlds come from :func:`bayesmap.sim.rover_worlds.generate_world` (walls, L-shapes, corridors,
narrow passages of at least 1.2 m, random boxes, 20–60 m areas) with world seeds nobody
tuned on. Every world is run with the paper's explorer and the frontier baseline, with the
flat and the pseudo-random entropy initialisation, for each seed, through the same code
path as ``bayesmap rover run``; the paper's four runs (``bayesmap reproduce rover``) are run
too. Each run reports the issue's targets: collisions, the smallest clearance, whether
90 % coverage (of the observable cells, see docs/rover.md) was reached within the step
budget, the distance to it, stalled and off-map cycles.

Every run writes its metrics to ``OUT/<run>.json`` as soon as it ends, and a run whose file
exists is not run again, so an interrupted benchmark resumes where it stopped; a run that
fails is reported with its error and the others go on. Each run records the CPU seconds
its worker process spent on it (``cpu_s``). Runs go to ``--jobs`` worker processes, each
with one BLAS thread. Run from the repository root, e.g.::

    python benchmarks/rover_worlds.py --worlds 12 --seeds 3 --jobs 8   # the issue's grid
    python benchmarks/rover_worlds.py --world-seed 7 --out results/rover_fresh ...  # fresh worlds

(``--size 20`` fixes the side of every world; by default, or with ``--size any``, each world
draws it from 20–60 m.)
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from numpy.random import SeedSequence
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap._io import write_json  # noqa: E402
from bayesmap.experiments import rover  # noqa: E402
from bayesmap.experiments.rover import SWEEPS  # noqa: E402
from bayesmap.experiments.rover_world import (  # noqa: E402
    EXPLORER_RULES,
    run_spec,
)
from bayesmap.sim.rover_worlds import generate_world  # noqa: E402
from bayesmap.sim.world2d import box_world  # noqa: E402

WORLD_SEED = 2026
GENERATOR = "rover-generated-v2"
"""The generator version: results of another version are never reused."""
EXPLORERS = ("paper", "frontier")
INITS = ("flat", "random")

Job = tuple[str, int, int, str, str, float | None, int]
"""(kind, world index, seed, explorer, entropy init, size, world seed): kind is "generated" or
"paper"."""


def side_arg(text: str) -> float | None:
    """``--size``: a side in metres, or ``any`` (``None``: the generator draws it, 20–60 m)."""
    if text == "any":
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected metres or 'any', got {text!r}") from None


def job_name(job: Job) -> str:
    """The file stem of a run's result."""
    kind, world, seed, explorer, init, size, world_seed = job
    if kind == "paper":
        return f"paper-{list(rover.RUNS)[world]}-{explorer}"
    side = "any" if size is None else f"{size:g}m"
    fresh = "" if world_seed == WORLD_SEED else f"-w{world_seed}"
    return f"{GENERATOR}{fresh}-{world:02d}-{side}-{explorer}-{init}-seed{seed}"


def one_run(job: Job, out: Path) -> dict[str, Any]:
    """Run one configuration, write its metrics to ``out`` and return them."""
    kind, world, seed, explorer, init, size, world_seed = job
    started, cpu_started = time.perf_counter(), time.process_time()
    if kind == "paper":
        name = list(rover.RUNS)[world]
        config = rover.Config(runs=(name,))
        rule = EXPLORER_RULES[explorer]
        trace = rover.simulate(
            box_world(rover.RUNS[name][0]), config, rule, rover.RUNS[name][1], _quiet, name
        )
        metrics = rover.run_metrics(trace, box_world(rover.RUNS[name][0]), config, rule)
        metrics.update({"explorer": explorer, "entropy_init": init, "seed": config.seed})
        metrics["area_m"] = 20.0
    else:
        fresh = "" if world_seed == WORLD_SEED else f"-w{world_seed}"
        spec = generate_world(
            SeedSequence([world_seed, world]), size=size, name=f"{GENERATOR}{fresh}-{world:02d}"
        )
        metrics = run_spec(spec, None, explorer=explorer, entropy_init=init, seed=seed)
        metrics["budget"] = rover.world_budget(spec)
        metrics["boxes"] = len(spec.world.boxes)
        metrics["area_m"] = spec.world.width
    metrics.update(
        {
            "kind": kind,
            "world_index": world,
            "wall_s": time.perf_counter() - started,
            "cpu_s": time.process_time() - cpu_started,
        }
    )
    metrics.pop("coverage_curve", None)
    write_json(out / f"{job_name(job)}.json", metrics)
    return metrics


def _quiet(stage: str, done: int, total: int) -> None:
    del stage, done, total


def _one_blas_thread() -> None:
    """Worker start-up: the rover's arrays are small, and ``--jobs`` processes on as many
    cores must not each start a BLAS thread per core."""
    threadpool_limits(1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", type=int, default=12, help="generated worlds (default 12)")
    parser.add_argument("--seeds", type=int, default=3, help="seeds per world (default 3)")
    parser.add_argument(
        "--size",
        type=side_arg,
        default=None,
        help="side [m], or 'any' (the default): each world draws its side from 20-60 m",
    )
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="processes")
    parser.add_argument("--out", type=Path, default=Path("results/rover_worlds"))
    parser.add_argument(
        "--world-seed",
        type=int,
        default=WORLD_SEED,
        help=f"generator seed (default {WORLD_SEED}); another one validates on fresh worlds",
    )
    parser.add_argument("--no-paper", action="store_true", help="skip the paper's four runs")
    parser.add_argument(
        "--explorer",
        action="append",
        choices=EXPLORERS,
        help="run only this explorer (repeatable; default both)",
    )
    parser.add_argument(
        "--init",
        action="append",
        choices=INITS,
        help="run only this entropy initialisation on generated worlds (repeatable; default both)",
    )
    parser.add_argument(
        "--report-only", action="store_true", help="summarise the finished runs, run nothing"
    )
    args = parser.parse_args()
    explorers = tuple(args.explorer or EXPLORERS)
    inits = tuple(args.init or INITS)
    jobs: list[Job] = []
    if not args.no_paper:  # the paper's explorer first: its runs are the reproduction
        jobs += [
            ("paper", k, 0, e, "random" if rover.RUNS[name][1] else "flat", 20.0, WORLD_SEED)
            for e in explorers
            for k, name in enumerate(rover.RUNS)
        ]
    jobs += [
        ("generated", w, s, e, i, args.size, args.world_seed)
        for w in range(args.worlds)
        for s in range(args.seeds)
        for e in explorers
        for i in inits
    ]
    args.out.mkdir(parents=True, exist_ok=True)
    runs: list[dict[str, Any]] = []
    todo = []
    for job in jobs:
        done = args.out / f"{job_name(job)}.json"
        if done.exists():
            runs.append(json.loads(done.read_text(encoding="utf-8")))
        else:
            todo.append(job)
    if args.report_only:  # every finished run in OUT, whatever grid it came from
        runs = [json.loads(f.read_text(encoding="utf-8")) for f in sorted(args.out.glob("*.json"))]
        todo = []
    print(f"{len(runs)} runs already in {args.out}; {len(todo)} to run on {args.jobs} processes")
    started = time.perf_counter()
    failed: list[str] = []
    with ProcessPoolExecutor(max_workers=max(args.jobs, 1), initializer=_one_blas_thread) as pool:
        futures = {pool.submit(one_run, job, args.out): job for job in todo}
        for k, future in enumerate(as_completed(futures), start=1):
            try:
                m = future.result()
            except Exception as error:  # noqa: BLE001 - one failed run must not stop the grid
                failed.append(f"{job_name(futures[future])} ({type(error).__name__}: {error})")
                print(f"[{k}/{len(todo)}] FAILED {failed[-1]}", flush=True)
                continue
            runs.append(m)
            print(
                f"[{k}/{len(todo)}] {m['world']} {m['explorer']}/{m['entropy_init']} seed "
                f"{m['seed']}: collisions {m['collisions']}, clearance {m['min_clearance_m']}, "
                f"coverage {m['coverage']:.3f}, to 90 % {m['distance_to_90']}, "
                f"{m['steps']} cycles in {m['cpu_s']:.0f} s of CPU",
                flush=True,
            )
    wall = time.perf_counter() - started
    text = summary(runs, args, wall, failed)
    print(text)
    # fresh worlds (validation) and a fixed side (a part of the grid): sections of their own
    fresh = "_fresh" if args.world_seed != WORLD_SEED else ""
    side = "" if args.size is None else f"_{args.size:g}m"
    update_section(f"rover_worlds{fresh}{side}", text)


def _rows(runs: list[dict[str, Any]]) -> list[str]:
    rows = [
        "| explorer | entropy init | runs | collisions | min clearance [m] | reached 90 % | "
        "coverage (min / median) | median distance to 90 % [m] | stalled cycles (median) | "
        "off-map cycles (max) | ms per cycle (median) | CPU s per run (median) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for explorer in EXPLORERS:
        for init in INITS:
            group = [m for m in runs if m["explorer"] == explorer and m["entropy_init"] == init]
            if not group:
                continue
            reached = [m["distance_to_90"] for m in group if m["distance_to_90"] is not None]
            clearances = [m["min_clearance_m"] for m in group if m["min_clearance_m"] is not None]
            cover = [m["coverage"] for m in group]
            cpu = [m["cpu_s"] for m in group if "cpu_s" in m]
            rows.append(
                f"| {explorer} | {init} | {len(group)} | {sum(m['collisions'] for m in group)} | "
                f"{min(clearances, default=float('nan')):.3f} | {len(reached)}/{len(group)} | "
                f"{min(cover):.3f} / {statistics.median(cover):.3f} | "
                f"{statistics.median(reached) if reached else float('nan'):.1f} | "
                f"{statistics.median(m['stalled_cycles'] for m in group):.0f} | "
                f"{max(m['off_map_cycles'] for m in group)} | "
                f"{statistics.median(m['cycle_ms'] for m in group):.1f} | "
                f"{statistics.median(cpu) if cpu else float('nan'):.0f} |"
            )
    return rows


def _expected(args: argparse.Namespace) -> int:
    explorers, inits = len(args.explorer or EXPLORERS), len(args.init or INITS)
    return args.worlds * args.seeds * explorers * inits + (0 if args.no_paper else 4 * explorers)


def summary(
    runs: list[dict[str, Any]], args: argparse.Namespace, wall: float, failed: list[str]
) -> str:
    """The Markdown section: per-configuration rows and the issue's targets."""
    generated = [m for m in runs if m.get("kind") == "generated"]
    paper = [m for m in runs if m.get("kind") == "paper"]
    ratios = []
    for w in sorted({m["world_index"] for m in generated}):
        by = {
            e: [
                m["distance_to_90"]
                for m in generated
                if m["world_index"] == w and m["explorer"] == e and m["distance_to_90"] is not None
            ]
            for e in EXPLORERS
        }
        if by["paper"] and by["frontier"]:
            ratios.append(statistics.median(by["paper"]) / statistics.median(by["frontier"]))
    ratio = statistics.median(ratios) if ratios else float("nan")
    failing = [
        f"{m['world']} {m['explorer']}/{m['entropy_init']} seed {m['seed']}"
        for m in runs
        if m["collisions"]
        or (m["min_clearance_m"] is not None and m["min_clearance_m"] <= 0.05)
        or m["distance_to_90"] is None
    ]
    sizes = sorted({round(m["area_m"], 1) for m in generated})
    budgets = [m["budget"] for m in generated if "budget" in m]
    worlds = sorted({m["world"] for m in generated})
    seeds = sorted({m["seed"] for m in generated})
    load = os.getloadavg()
    command = (
        f"python benchmarks/rover_worlds.py --worlds {args.worlds} --seeds {args.seeds}"
        + (f" --size {args.size:g}" if args.size else "")
        + f" --jobs {args.jobs}"
        + (f" --world-seed {args.world_seed}" if args.world_seed != WORLD_SEED else "")
        + (" --no-paper" if args.no_paper else "")
        + "".join(f" --explorer {e}" for e in args.explorer or ())
        + "".join(f" --init {i}" for i in args.init or ())
    )
    return "\n".join(
        [
            "## rover_worlds: the rover on generated stress worlds"
            + ("" if args.world_seed == WORLD_SEED else " never tuned on (fresh seed)")
            + ("" if args.size is None else f", {args.size:g} m sides"),
            "",
            f"`{command}`. Machine: {machine()}, load average at the end "
            f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (shared; ms per cycle is wall "
            f"time and swings with the load). {len(worlds)} generated worlds "
            f"({', '.join(worlds) or 'none'}; sides "
            f"{min(sizes, default=0):g}–{max(sizes, default=0):g} m) x {len(seeds)} seed(s) x "
            f"entropy initialisations x explorers = {len(generated)} runs, world seed "
            f"{args.world_seed}; step budget {SWEEPS:g} sweeps of the observable area "
            f"({min(budgets, default=0)}–{max(budgets, default=0)} cycles; the paper's runs "
            f"5000); coverage counts the observable cells (docs/rover.md). "
            f"{len(runs)} of the {_expected(args)} runs the command asks for have finished; "
            f"wall time of this invocation {wall / 60:.0f} min (finished runs are reused).",
            "",
            *_rows(generated),
            "",
            f"Paper / frontier distance to 90 % coverage, median over the {len(ratios)} worlds "
            f"where both reach it: **{ratio:.2f}** (target <= 1.2).",
            "",
            *(
                ["The paper's four runs (`bayesmap reproduce rover`, seed 2016):", ""]
                + _rows(paper)
                if paper
                else ["The paper's four runs were not run (`--no-paper`)."]
            ),
            "",
            "Runs missing a target (collision, clearance <= 0.05 m, or 90 % not reached): "
            + (", ".join(failing) if failing else "none")
            + ".",
            *(["", "Runs that failed with an error: " + ", ".join(failed) + "."] if failed else []),
        ]
    )


if __name__ == "__main__":
    main()
