"""Rover cycle speed over complete runs: cycles per second on a 20 m and a 200 m map.

A complete closed-loop run on the 20 m obstacle field (to the stop rule or the 5000-cycle
budget, so it holds every phase: local exploration, the global fallback once the local area
is done, the clean-up) is recorded, and its readings and estimated poses are replayed
through :class:`bayesmap.rover.explorer.Explorer` on a 20 m x 20 m map and, shifted into its
middle, on a 200 m x 200 m map at the same 0.5 m resolution. Each cycle processes the three
IR readings (eq. 33, §5.1), updates the maps (eqs. 31–37), plans path costs over the local
area, picks or keeps the target (eqs. 38–39, with the block-indexed fallback), checks the
footprint and asks the decision network for the heading (eqs. 40–43). On the 200 m map
the fallback finds uncertain cells everywhere, so a cost growing with the map would show.
A 200 m run to its own stop rule would take hundreds of thousands of cycles; the replay
times the same cycles on both maps instead.

Run from the repository root: ``python benchmarks/rover_cycle.py``.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.rover.explorer import Explorer  # noqa: E402
from bayesmap.rover.params import RoverParams  # noqa: E402
from bayesmap.rover.targets import EntropyTarget  # noqa: E402
from bayesmap.sim import rover as sim_rover  # noqa: E402
from bayesmap.sim.world2d import box_world  # noqa: E402

CYCLES = 5000


def record(cycles: int, seed: int = 1) -> list[tuple[np.ndarray, np.ndarray]]:
    """Readings and estimated poses of a complete closed-loop run on the obstacle field."""
    world = box_world("rover-field-obstacles-v1")
    params, sim = RoverParams(), sim_rover.SimulatedRoverParams()
    rng = np.random.default_rng(seed)
    explorer = Explorer(
        OccupancyGrid(20.0, 20.0, 0.5, prior=params.prior), params, EntropyTarget(params)
    )
    state = sim_rover.initial([1.0, 1.0, 0.8], sim, rng=rng)
    log = []
    for _ in range(cycles):
        obs = sim_rover.observe(world, state, sim, rng=rng)
        log.append((obs.raw, obs.pose))
        decision = explorer.step(obs.raw, obs.pose)
        if explorer.done or decision.target is None:
            break
        state = sim_rover.transition(state, decision.command, sim, rng=rng)
    return log


def replay(sizes: tuple[float, ...], log: list[tuple[np.ndarray, np.ndarray]]) -> list[float]:
    """CPU seconds each map's explorer spends on ``log``, replayed in lockstep.

    The explorers take turns cycle by cycle (the order alternating), so a change in the
    machine's load between two moments falls on every map alike; CPU time
    (:func:`time.process_time`) leaves out the time the process waited for a core.
    """
    params = RoverParams()
    explorers = [
        Explorer(OccupancyGrid(size, size, 0.5, prior=params.prior), params, EntropyTarget(params))
        for size in sizes
    ]
    shifts = [np.array([(size - 20.0) / 2, (size - 20.0) / 2, 0.0]) for size in sizes]
    spent = [0.0] * len(sizes)
    for k, (raw, pose) in enumerate(log):
        order = range(len(sizes)) if k % 2 == 0 else reversed(range(len(sizes)))
        for m in order:
            started = time.process_time()
            explorers[m].step(raw, pose + shifts[m])
            spent[m] += time.process_time() - started
    return spent


def main() -> None:
    log = record(CYCLES)
    sizes = (20.0, 200.0)
    replay(sizes, log[:50])  # warm-up: imports, caches, plans
    load_before = os.getloadavg()[0]
    spent = replay(sizes, log)
    load = os.getloadavg()
    small, large = len(log) / spent[0], len(log) / spent[1]
    rows = [
        "| map | cells | cycles/s | ms of CPU per cycle |",
        "|---|---|---|---|",
        f"| 20 m x 20 m | {40 * 40:,} | {small:.0f} | {1000 / small:.2f} |",
        f"| 200 m x 200 m | {400 * 400:,} | {large:.0f} | {1000 / large:.2f} |",
    ]
    markdown = "\n".join(
        [
            "## rover_cycle: micro-rover sense + map + decide cycle",
            "",
            f"`python benchmarks/rover_cycle.py`. Machine: {machine()}, shared with other "
            f"jobs: load average {load_before:.1f} at the start, {load[0]:.1f} / {load[1]:.1f} "
            f"/ {load[2]:.1f} at the end (CPU time, which the load inflates less than wall "
            "time but still does; the ratio is not, see below). A complete recorded run on "
            "the 20 m obstacle field "
            f"({len(log)} cycles, to the stop rule or the {CYCLES}-cycle budget) replayed on "
            "both maps in lockstep, the two explorers taking turns cycle by cycle.",
            "",
            *rows,
            "",
            f"Ratio 200 m / 20 m cycle rate: **{large / small:.2f}** "
            "(1 = cost independent of map size; target >= 0.90).",
        ]
    )
    print(markdown)
    update_section("rover_cycle", markdown)


if __name__ == "__main__":
    main()
