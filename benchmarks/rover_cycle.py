"""Rover cycle speed: sensing + map update + decision cycles per second, 20 m vs 200 m map.

One recorded drive (readings and estimated poses from the simulator on the 20 m field) is
replayed through :class:`bayesmap.rover.explorer.Explorer` on a 20 m x 20 m map and, shifted
into its middle, on a 200 m x 200 m map at the same 0.5 m resolution. Each cycle processes
the three IR readings (eq. 33, §5.1), updates the probability and entropy maps (eqs. 31–37),
picks the target (eqs. 38–39) and asks the decision network for the heading (eqs. 40–43).
Local updates make the cycle cost independent of the map size: the ratio should stay near 1.

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

CYCLES = 400
REPEATS = 5


def record(cycles: int, seed: int = 1) -> list[tuple[np.ndarray, np.ndarray]]:
    """Readings and estimated poses of a closed-loop drive on the obstacle field."""
    world = box_world("rover-field-obstacles-v1")
    params, sim = RoverParams(), sim_rover.RoverParams()
    rng = np.random.default_rng(seed)
    explorer = Explorer(
        OccupancyGrid(20.0, 20.0, 0.5, prior=params.prior), params, EntropyTarget(params)
    )
    state = sim_rover.initial([1.0, 1.0, 0.8], sim, rng=rng)
    log = []
    for _ in range(cycles):
        obs = sim_rover.observe(state, world, sim, rng=rng)
        log.append((obs.raw, obs.pose))
        state = sim_rover.transition(state, explorer.step(obs.raw, obs.pose).command, sim, rng=rng)
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
            f"Machine: {machine()}. {CYCLES} recorded cycles replayed {REPEATS} times per map, "
            "maps interleaved; other jobs shared the cores, so medians are reported.",
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
