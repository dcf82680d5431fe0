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

import statistics
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
REPEATS = 1


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


def replay(size: float, log: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """Cycles per second of the explorer replaying ``log`` on a ``size`` x ``size`` map."""
    params = RoverParams()
    shift = np.array([(size - 20.0) / 2, (size - 20.0) / 2, 0.0])
    explorer = Explorer(
        OccupancyGrid(size, size, 0.5, prior=params.prior), params, EntropyTarget(params)
    )
    started = time.perf_counter()
    for raw, pose in log:
        explorer.step(raw, pose + shift)
    return len(log) / (time.perf_counter() - started)


def main() -> None:
    log = record(CYCLES)
    rates: dict[float, list[float]] = {20.0: [], 200.0: []}
    replay(20.0, log[:50])  # warm-up: imports, caches, plans
    for _ in range(REPEATS):
        for size in rates:
            rates[size].append(replay(size, log))
    small, large = statistics.median(rates[20.0]), statistics.median(rates[200.0])
    rows = [
        f"| map | cells | cycles/s (median of {REPEATS}) | ms per cycle |",
        "|---|---|---|---|",
        f"| 20 m x 20 m | {40 * 40:,} | {small:.0f} | {1000 / small:.2f} |",
        f"| 200 m x 200 m | {400 * 400:,} | {large:.0f} | {1000 / large:.2f} |",
    ]
    markdown = "\n".join(
        [
            "## rover_cycle: micro-rover sense + map + decide cycle",
            "",
            f"Machine: {machine()}. A complete recorded run ({len(log)} cycles, to the stop "
            f"rule or the {CYCLES}-cycle budget) replayed {REPEATS} times per map, maps "
            "interleaved; other jobs shared the cores, so medians are reported.",
            "",
            *rows,
            "",
            f"Ratio 20 m / 200 m cycle rate: **{small / large:.2f}** "
            "(1 = cost independent of map size).",
        ]
    )
    print(markdown)
    update_section("rover_cycle", markdown)


if __name__ == "__main__":
    main()
