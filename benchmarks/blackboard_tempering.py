"""Benchmark: the fused mapper's existence chain with and without parallel tempering.

For each run (the shipped world ``whisker-tables-v1`` of ``reproduce blackboard`` with its own
streams, in the normal and noisy conditions, and generated stress worlds, generator seeds
``--worlds``, default 9317 and 4, normal, run seed 0, as ``bayesmap blackboard run --world``
runs them; the noisy run last, it takes minutes) the 400 steps run once; at
:meth:`~bayesmap.blackboard.fused.FusedMapper.finish` the mapper and its chain's generator are
copied, and the final pass runs twice from the same stored evidence and chain state: once
*before* (``replicas = 1, samples = 1500``: the β = 1 chain alone, as the mapper ran it
before tempering) and once with the defaults (parallel tempering). Reported per run and
variant: the CPU seconds of ``finish`` (``time.process_time``; a loaded machine inflates
them, the load average is listed), fused precision and recall, the existence probabilities
of mapped objects that match a true table (lowest and mean) and of those that match none
(highest), and the swap acceptance between each pair of neighbouring replicas. The table
goes to docs/benchmarks.md (section ``blackboard_tempering``). Run from the repository root
as ``python benchmarks/blackboard_tempering.py``.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks.blackboard_speed import stress_worlds  # noqa: E402

from bayesmap.blackboard.fused import FusedMap, FusedMapper, FusedParams  # noqa: E402
from bayesmap.blackboard.tempering import geometric_ladder  # noqa: E402
from bayesmap.experiments import blackboard, blackboard_world  # noqa: E402
from bayesmap.experiments.fused_run import fused_metrics  # noqa: E402

BEFORE = {"replicas": 1, "samples": 1500}
"""The existence chain before tempering: 1500 moves of the β = 1 chain alone."""


class _BothFinishes:
    """While alive, each ``FusedMapper.finish`` also runs, first, on a copy of the mapper and
    its generator with :data:`BEFORE`; the experiments' metrics are computed for both maps."""

    def __init__(self) -> None:
        self.maps: dict[str, FusedMap] = {}
        self.cpu: dict[str, float] = {}
        self.scores: dict[str, dict[str, Any]] = {}
        self._finish = FusedMapper.finish
        self._metrics = fused_metrics

    def __enter__(self) -> _BothFinishes:
        finish, metrics, record = self._finish, self._metrics, self

        def both(mapper: FusedMapper, *, rng: Any = None) -> FusedMap:
            alone = copy.deepcopy(mapper)
            alone.params = dataclasses.replace(mapper.params, **BEFORE)
            tic = time.process_time()
            record.maps["alone"] = finish(alone, rng=copy.deepcopy(rng))
            record.cpu["alone"] = time.process_time() - tic
            tic = time.process_time()
            record.maps["tempered"] = finish(mapper, rng=rng)
            record.cpu["tempered"] = time.process_time() - tic
            return record.maps["tempered"]

        def scored(run: dict[str, Any], world: Any, tol: Any) -> dict[str, Any]:
            for name, fused in record.maps.items():
                record.scores[name] = metrics({**run, "fused": fused}, world, tol)
            return record.scores["tempered"]

        FusedMapper.finish = both  # type: ignore[method-assign]
        blackboard.fused_metrics = scored  # type: ignore[attr-defined]
        blackboard_world.fused_metrics = scored  # type: ignore[attr-defined]
        return self

    def __exit__(self, *_: object) -> None:
        FusedMapper.finish = self._finish  # type: ignore[method-assign]
        blackboard.fused_metrics = self._metrics  # type: ignore[attr-defined]
        blackboard_world.fused_metrics = self._metrics  # type: ignore[attr-defined]


def _existence(scores: dict[str, Any]) -> tuple[float, float, float, int]:
    """Lowest and mean existence of mapped true objects, highest of false ones, their count."""
    p = np.asarray(scores["fused_existence"], dtype=float)
    true = np.asarray(scores["fused_object_true"], dtype=bool)
    low = float(p[true].min()) if true.any() else float("nan")
    mean = float(p[true].mean()) if true.any() else float("nan")
    high_false = float(p[~true].max()) if (~true).any() else float("nan")
    return low, mean, high_false, int((~true).sum())


def measure(name: str, condition: str, runner: Any) -> list[dict[str, Any]]:
    """One tour, its final pass with and without tempering."""
    load_before = os.getloadavg()[0]
    with _BothFinishes() as both:
        runner()
    load = (load_before, os.getloadavg()[0])
    rows = []
    for variant in ("alone", "tempered"):
        scores, fused = both.scores[variant], both.maps[variant]
        low, mean, high_false, n_false = _existence(scores)
        swaps = [
            fused.info.get(f"tempering_swaps_accepted_{r}", 0)
            / max(fused.info.get(f"tempering_swaps_tried_{r}", 0), 1)
            for r in range(FusedParams().replicas - 1)
            if f"tempering_swaps_tried_{r}" in fused.info
        ]
        row = {
            "world": name,
            "condition": condition,
            "variant": variant,
            "finish_cpu_s": both.cpu[variant],
            "precision": float(scores["fused_precision"]),
            "recall": float(scores["fused_recall"]),
            "objects": len(fused.tables),
            "true_min": low,
            "true_mean": mean,
            "false_max": high_false,
            "false": n_false,
            "swaps": swaps,
            "load": load,
        }
        print(
            f"{name} {condition} {variant}: finish {row['finish_cpu_s']:.1f} s CPU, "
            f"precision {row['precision']:.2f}, recall {row['recall']:.2f}, "
            f"true objects' existence min {low:.3f} mean {mean:.3f}, "
            f"false objects {n_false} (max {high_false:.3f}), "
            f"swap acceptance {', '.join(f'{s:.2f}' for s in swaps) or '–'}, "
            f"load {load[0]:.1f}→{load[1]:.1f}",
            flush=True,
        )
        rows.append(row)
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of the runs."""
    lines = [
        "| world | condition | existence chain | finish CPU s | precision / recall "
        "| true objects: min / mean existence | false objects (max existence) "
        "| swap acceptance, β pairs from 1 down | load avg (start→end) |",
        "|---|---|---|---:|---:|---:|---:|---|---:|",
    ]
    for r in rows:
        false = f"{r['false']} ({r['false_max']:.2f})" if r["false"] else "0"
        swaps = ", ".join(f"{s:.2f}" for s in r["swaps"]) or "–"
        lines.append(
            f"| {r['world']} | {r['condition']} | {r['variant']} | {r['finish_cpu_s']:.1f} "
            f"| {r['precision']:.2f} / {r['recall']:.2f} "
            f"| {r['true_min']:.3f} / {r['true_mean']:.3f} | {false} | {swaps} "
            f"| {r['load'][0]:.1f}→{r['load'][1]:.1f} |"
        )
    return "\n".join(lines)


def write(rows: list[dict[str, Any]]) -> None:
    """The runs so far into docs/benchmarks.md."""
    p = FusedParams()
    ladder = ", ".join(f"{b:.2f}" for b in geometric_ladder(p.replicas, p.beta_min))
    note = (
        f"{machine()}. Each tour runs once; its final pass (`FusedMapper.finish`) then runs "
        "twice from the same stored evidence and chain state: *alone* is the β = 1 "
        f"existence chain by itself as before tempering ({BEFORE['samples']} moves), "
        f"*tempered* the default ladder β = {ladder} "
        f"({p.samples} moves per replica, exchanges every {p.swap_every} moves). CPU seconds "
        "of this process (`time.process_time`); a loaded machine inflates them (load "
        "average listed). `python benchmarks/blackboard_tempering.py`"
    )
    update_section(
        "blackboard_tempering",
        f"### Fused mapper: parallel tempering of the existence chain (issue 9)\n\n"
        f"{note}\n\n{table(rows)}\n",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, nargs="*", default=[9317, 4])
    parser.add_argument("--conditions", nargs="*", default=["normal"])
    parser.add_argument("--shipped", nargs="*", default=["normal", "noisy"])
    args = parser.parse_args()
    runs: list[tuple[str, str, Any]] = [
        ("whisker-tables-v1", condition, lambda c=condition: blackboard.fused_condition(c))
        for condition in args.shipped
    ]
    for name, world in stress_worlds(args.worlds):
        for condition in args.conditions:
            runs.append(
                (
                    name,
                    condition,
                    lambda w=world, c=condition, n=name: blackboard_world.fused_world_run(
                        w, c, 0, name=n
                    ),
                )
            )
    runs.sort(key=lambda run: run[1] == "noisy")  # the slow noisy runs last
    rows: list[dict[str, Any]] = []
    for name, condition, runner in runs:
        rows.extend(measure(name, condition, runner))
        write(rows)  # every finished run is on record, even if a later one is stopped


if __name__ == "__main__":
    main()
