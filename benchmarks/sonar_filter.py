"""Benchmark: sonar ring readings per second through the specular filter and the map update.

A long simulated log (16-sonar ring driven laps around ``sonar-hall-v1``, at least 10,000
rings) goes through: the filter alone; filter + eq. 1 cone map update (the full pipeline);
and, side by side, the unfiltered map updates of the eq. 1 model, Thrun's ±0.4 log-odds
model and the ROS ``range_sensor_layer`` model. Median of repeats; run from the repository
root as ``python benchmarks/sonar_filter.py`` (or ``python -m benchmarks.sonar_filter``).
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402

from bayesmap.experiments.sonar import ring_geometry  # noqa: E402
from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.sim.polygons import path_poses, world  # noqa: E402
from bayesmap.sim.sonar import SonarRing, observe  # noqa: E402
from bayesmap.sonar.filter import SpecularFilter  # noqa: E402
from bayesmap.sonar.geometry import SonarGeometry  # noqa: E402
from bayesmap.sonar.mapping import ElfesMapper, RosRangeLayerMapper, ThrunMapper  # noqa: E402
from bayesmap.sonar.pipeline import RingMapper  # noqa: E402

RINGS = 10_000
PEER_RINGS = 2_000
REPEATS = 3
RESOLUTION = 0.1


def _log() -> tuple[np.ndarray, np.ndarray, SonarGeometry, tuple[float, float, float, float]]:
    w = world("sonar-hall-v1")
    ring = SonarRing()
    one_lap = path_poses(w.waypoints, 0.1)
    laps = -(-RINGS // len(one_lap))
    poses = path_poses(w.waypoints, 0.1, laps=laps)[:RINGS]
    scan = observe(poses, w, ring, rng=0)
    return poses, scan.ranges, ring_geometry(ring), w.bounds


def _time(job: Callable[[], None]) -> float:
    started = time.perf_counter()
    job()
    return time.perf_counter() - started


def main() -> None:
    poses, ranges, geometry, (xmin, ymin, xmax, ymax) = _log()

    def grid() -> OccupancyGrid:
        return OccupancyGrid(
            xmax - xmin + 1, ymax - ymin + 1, RESOLUTION, origin=(xmin - 0.5, ymin - 0.5)
        )

    def filter_only(n: int) -> Callable[[], None]:
        def job() -> None:
            filt = SpecularFilter(geometry)
            for p, r in zip(poses[:n], ranges[:n], strict=True):
                filt.process(p, r)

        return job

    def filter_and_map(n: int) -> Callable[[], None]:
        def job() -> None:
            filt = SpecularFilter(geometry)
            mapper = ElfesMapper(grid(), geometry)
            for p, r in zip(poses[:n], ranges[:n], strict=True):
                mapper.integrate(p, r, filt.process(p, r).accepted)

        return job

    def map_only(
        factory: Callable[[OccupancyGrid, SonarGeometry], RingMapper], n: int
    ) -> Callable[[], None]:
        def job() -> None:
            mapper = factory(grid(), geometry)
            for p, r in zip(poses[:n], ranges[:n], strict=True):
                mapper.integrate(p, r)

        return job

    cases: list[tuple[str, int, Callable[[], None]]] = [
        ("filter + eq. 1 map update (bayesmap, full pipeline)", RINGS, filter_and_map(RINGS)),
        ("filter only (all three stages)", PEER_RINGS, filter_only(PEER_RINGS)),
        ("eq. 1 cone map update only, unfiltered", PEER_RINGS, map_only(ElfesMapper, PEER_RINGS)),
        ("Thrun ±0.4 log-odds update, unfiltered", PEER_RINGS, map_only(ThrunMapper, PEER_RINGS)),
        (
            "ROS range_sensor_layer update, unfiltered",
            PEER_RINGS,
            map_only(RosRangeLayerMapper, PEER_RINGS),
        ),
    ]
    rows = []
    for name, n, job in cases:
        seconds = statistics.median(_time(job) for _ in range(REPEATS))
        rows.append((name, n, seconds, n / seconds, n * geometry.n / seconds))
        print(f"{name:55s} {n:6d} rings {seconds:7.2f} s {n / seconds:8.0f} rings/s", flush=True)
    table = [
        "## sonar_filter: ring readings per second",
        "",
        f"Machine: {machine()}. Log: 16-sonar ring on `sonar-hall-v1`, laps at 0.1 m per ring, "
        f"grid {RESOLUTION} m; median of {REPEATS} repeats, single process "
        "(other jobs shared the cores).",
        "",
        "| pipeline | rings | median time [s] | rings / s | readings / s |",
        "|---|---:|---:|---:|---:|",
        *(
            f"| {name} | {n} | {sec:.2f} | {rate:.0f} | {readings:.0f} |"
            for name, n, sec, rate, readings in rows
        ),
        "",
        "The ROS layer updates one reading at a time (Bayes with cost quantisation), as the "
        "layer does; the log-odds models update a whole ring at once.",
    ]
    update_section("sonar_filter", "\n".join(table))


if __name__ == "__main__":
    main()
