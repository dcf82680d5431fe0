"""The default sonar pipeline on logs nobody tuned on (docs/sonar.md, section ``sonar_unseen``).

Fresh realistic logs (Pioneer 16-sonar ring with its offsets, stops, people walking
through, odometry drift, the no-echo code), drawn from seeds that neither the tuning
(seed 1), the diagnostics (11, 101, 103) nor the benchmark of record (2007) use:

- random buildings, halls and offices (:func:`bayesmap.sim.polygons.random_building`,
  :func:`~bayesmap.sim.polygons.random_hall`, :func:`~bayesmap.sim.polygons.random_office`;
  world seeds ``--buildings``, ``--halls``, ``--offices``), each driven once;
- the five named realistic worlds, one log each from ``--seed``.

Each log is mapped by the default pipeline (with its forward-model sweep), the one-pass
``streaming`` pipeline and the unfiltered baselines, as
``bayesmap sonar run`` / ``reproduce sonar`` do; the section gets the per-log targets and
one panel of maps per random world.
Run from the repository root: ``python benchmarks/sonar_unseen.py [--jobs N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap.experiments.sonar import BASELINES, TARGETED, Config, run  # noqa: E402
from bayesmap.sim.polygons import random_building, random_hall, random_office  # noqa: E402
from bayesmap.sim.sonar_worlds import save_world  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"
PIPELINES = (*TARGETED, *BASELINES)


def _rows(folder: Path, label: str | None = None) -> list[str]:
    """One table row per world of a finished run (named ``label``, default the world's)."""
    metrics = json.loads((folder / "metrics.json").read_text(encoding="utf-8"))
    rows = []
    for record in metrics["runs"]:
        scores = record["pipelines"]
        best = max(BASELINES, key=lambda b: scores[b]["kappa"])
        cells = [f"{label or record['world']}", f"{record['rings']:,}"]
        cells.append(f"{best} ({scores[best]['kappa']:.3f})")
        for name in TARGETED:
            mine = scores[name]
            margin = mine["kappa"] - scores[best]["kappa"]
            missed = mine["missed_wall_rate"] - scores["ros"]["missed_wall_rate"]
            cells.append(f"{mine['kappa']:.3f} / {margin:+.3f} / {missed:+.3f}")
        paths = " / ".join(f"{scores[name]['path_occupied']:.0f}" for name in TARGETED)
        cells.append(f"{paths} (ROS {scores['ros']['path_occupied']:.0f})")
        for name in TARGETED:
            mine = scores[name]
            cells.append(f"{mine['rejection_precision']:.2f} / {mine['rejection_recall']:.2f}")
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--buildings", default="31,32,33", help="world seeds of random buildings")
    parser.add_argument("--halls", default="41,42,43", help="world seeds of random halls")
    parser.add_argument("--offices", default="51,52,53", help="world seeds of random offices")
    parser.add_argument("--seed", type=int, default=4242, help="log seed (default 4242)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    rows: list[str] = []
    figures: list[str] = []
    with tempfile.TemporaryDirectory(prefix="sonar_unseen_") as scratch:
        base = Path(scratch)
        kinds = (
            ("building", random_building, args.buildings),
            ("hall", random_hall, args.halls),
            ("office", random_office, args.offices),
        )
        for kind, generate, seeds in kinds:
            for seed in (int(s) for s in filter(None, seeds.split(","))):
                drawn = generate(np.random.default_rng(seed))
                path = save_world(drawn, base / f"{kind}-{seed}.json")
                out = base / f"{kind}-{seed}"
                config = Config(world=path, runs=1, seed=args.seed, pipelines=PIPELINES)
                run(config, out, progress=lambda what, done, total: print(what, flush=True))
                rows += _rows(out, f"random {kind}, world seed {seed}")
                for png in sorted(out.glob("maps_*.png")):
                    target = DOCS / f"sonar_unseen_{kind}_{seed}.png"
                    shutil.copyfile(png, target)
                    figures.append(f"**Random {kind}, world seed {seed}**\n\n![]({target.name})\n")
        out = base / "named"
        config = Config(runs=1, seed=args.seed, pipelines=PIPELINES, jobs=args.jobs)
        run(config, out, progress=lambda what, done, total: print(what, flush=True))
        rows += _rows(out)
    minutes = (time.perf_counter() - started) / 60
    load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
    text = "\n".join(
        [
            f"Run by `python benchmarks/sonar_unseen.py --jobs {args.jobs}` (random buildings "
            f"{args.buildings}, halls {args.halls}, offices {args.offices}; log seed "
            f"{args.seed}) in {minutes:.1f} min on {machine()}; "
            f"load average at the end {load} (a shared machine).",
            "",
            "One log each; for each of the default pipeline (with its forward-model sweep) and "
            "the one-pass streaming pipeline: κ, κ margin "
            "(minus the best unfiltered baseline; target ≥ +0.10) and missed wall − ROS "
            "(target ≤ 0); path cells: cells within the robot's radius of its logged path "
            "mapped occupied (target 0); rejection precision / recall of each (the two "
            "share the filter; the default's verdict asks its map after the sweep).",
            "",
            "| log | rings | best baseline (κ) | default: κ / margin / missed − ROS "
            "| streaming: κ / margin / missed − ROS | path cells occupied (default / streaming) "
            "| rej. precision / recall, default | streaming |",
            "|---|---:|---|---|---|---|---|---|",
            *rows,
            "",
            "Panels: truth, then the default and streaming pipelines and each baseline on the "
            "same log; true "
            "walls red, logged path dotted blue.",
            "",
            *figures,
        ]
    )
    update_section("sonar_unseen", text, doc=DOCS / "sonar.md")
    print("\n".join(rows))


if __name__ == "__main__":
    main(sys.argv[1:])
