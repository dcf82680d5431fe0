"""Benchmark: sonar ring readings per second through filter + map, and memory on a 50 MB log.

Part 1: a realistic simulated log (Pioneer 16-sonar ring, :func:`simulate_log` laps of
``sonar-lcorridor-v2`` with people, stops and drift) goes through the default pipeline
(filter, eq. 1 map with its tuned options, the forward-model sweep over the whole log and
the map's verdict), the one-pass ``streaming`` pipeline, the paper's filter alone, and,
side by side, the unfiltered map updates of the eq. 1 model, Thrun's ±0.4 model and the ROS
``range_sensor_layer`` model. Part 2: a 50 MB plain-text log (mm, decidegrees) is written
and read by ``read_sonar_log`` in a child process, then mapped whole with the default
pipeline (about 7 CPU minutes; ``--memory-rings N`` maps only its first ``N`` rings, for a
quick run); the child's peak resident memory after reading and over the whole run is
reported. Median of repeats; run from the repository root as ``python
benchmarks/sonar_filter.py``.

Rates per CPU second still drop when other jobs share the cores, so two load-independent
numbers go with them: the default pipeline's rate over the ``paper`` and the ``streaming``
pipeline's (same log, same run), and with ``--baseline TREE`` (a commit of this repository,
e.g. ``4ca13aa``, or another checkout's folder) the speed-up of this checkout's default
pipeline over that one's, each timed in its own child process, taking turns.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import NamedTuple

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks._trees import source_tree  # noqa: E402

from bayesmap.experiments.sonar import ring_geometry  # noqa: E402
from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.sim.polygons import world  # noqa: E402
from bayesmap.sim.sonar import SonarRing  # noqa: E402
from bayesmap.sim.sonar_log import Realism, simulate_log  # noqa: E402
from bayesmap.sonar.filter import SpecularFilter  # noqa: E402
from bayesmap.sonar.geometry import SonarGeometry  # noqa: E402
from bayesmap.sonar.logs import LogUnits, write_sonar_log  # noqa: E402
from bayesmap.sonar.mapping import ElfesMapper, RosRangeLayerMapper, ThrunMapper  # noqa: E402
from bayesmap.sonar.pipeline import DEFAULT_PIPELINE, PIPELINES, RingMapper, map_log  # noqa: E402

RINGS = 1_500
PEER_RINGS = 500
REPEATS = 3
RESOLUTION = 0.1
LOG_MB = 50
WORLD = "sonar-lcorridor-v2"


def _log() -> tuple[np.ndarray, np.ndarray, SonarGeometry, tuple[float, float, float, float]]:
    w = world(WORLD)
    ring = SonarRing.pioneer(16)
    log = simulate_log(w, ring, Realism(laps=2), rng=0)
    poses, ranges = log.odometry, log.ranges
    while len(poses) < RINGS:
        poses, ranges = np.vstack([poses, log.odometry]), np.vstack([ranges, log.ranges])
    return poses[:RINGS], ranges[:RINGS], ring_geometry(ring), w.bounds


_CHILD = """
import sys, time
from bayesmap.sonar.logs import LogUnits, read_sonar_log
from bayesmap.sonar.pipeline import build_map
from bayesmap.sonar.ring import preset


def peak():
    # VmHWM: the peak of this program's own memory [MB]. ru_maxrss would also count the
    # parent's pages at the moment it spawned us (Linux carries it across exec).
    return float(open("/proc/self/status").read().split("VmHWM:")[1].split()[0]) / 1024


started = time.perf_counter()
log = read_sonar_log(sys.argv[1], 16, units=LogUnits("mm", "mm", "decideg"))
read, read_peak = time.perf_counter() - started, peak()
n = len(log.timestamps) if sys.argv[2] == "all" else int(sys.argv[2])
started, cpu = time.perf_counter(), time.process_time()
build_map(log.poses[:n], log.ranges[:n], preset("pioneer16"), 0.1)
mapped, mapped_cpu = time.perf_counter() - started, time.process_time() - cpu
print(len(log.timestamps), read, read_peak, min(n, len(log.timestamps)), mapped, mapped_cpu, peak())
"""


class _Memory(NamedTuple):
    """What the child reading and mapping the 50 MB log measured."""

    size_mb: float
    rows: int
    read_s: float
    read_peak_mb: float
    mapped_rings: int
    map_s: float
    map_cpu_s: float
    peak_mb: float


def _memory(poses: np.ndarray, ranges: np.ndarray, rings: int | None) -> _Memory:
    """Write a ~50 MB log, read it and map ``rings`` of it (``None``: all) in a child process."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "big.txt"
        one = write_sonar_log(
            Path(folder) / "one.txt",
            np.arange(len(poses)) * 0.125,
            ranges,
            poses,
            units=LogUnits("mm", "mm", "decideg"),
        )
        chunk = one.read_text().splitlines()
        copies = max(int(LOG_MB * 2**20 / one.stat().st_size), 1)
        step = len(poses) * 0.125
        with path.open("w") as handle:
            for k in range(copies):
                for line in chunk:
                    t, rest = line.split(" ", 1)
                    handle.write(f"{float(t) + k * step:.3f} {rest}\n")
        size = path.stat().st_size / 2**20
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, str(path), "all" if rings is None else str(rings)],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split()
    return _Memory(
        size, int(out[0]), float(out[1]), float(out[2]), int(out[3]), *map(float, out[4:])
    )


_CHILD_SPEED = """
import sys, time
import numpy as np
from bayesmap.experiments.sonar import ring_geometry
from bayesmap.grid import OccupancyGrid
from bayesmap.sim.sonar import SonarRing
from bayesmap.sonar.pipeline import PIPELINES, map_log
data = np.load(sys.argv[1])
poses, ranges, (xmin, ymin, xmax, ymax) = data["poses"], data["ranges"], data["bounds"]
geometry = ring_geometry(SonarRing.pioneer(16))
pipeline = PIPELINES["default"]
size, origin = (xmax - xmin + 1, ymax - ymin + 1), (xmin - 0.5, ymin - 0.5)
grid = OccupancyGrid(*size, float(sys.argv[2]), origin=origin)
mapper, filt = pipeline.make_mapper(grid, geometry), pipeline.make_filter(geometry)
started = time.process_time()
map_log(
    poses,
    ranges,
    mapper,
    filt,
    merge_repeats=pipeline.merge_repeats,
    map_verdict=pipeline.map_verdict,
)
print(time.process_time() - started)
"""


def _against(
    baseline: Path, poses: np.ndarray, ranges: np.ndarray, bounds: tuple[float, ...]
) -> tuple[float, float]:
    """Median CPU seconds of the default pipeline on the log: this checkout, then ``baseline``
    (a ``src`` folder), each in a child process, taking turns ``REPEATS`` times."""
    mine = Path(__file__).resolve().parent.parent / "src"
    times: dict[Path, list[float]] = {mine: [], baseline: []}
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "log.npz"
        np.savez(log, poses=poses, ranges=ranges, bounds=np.asarray(bounds))
        for _ in range(REPEATS):
            for src in times:
                out = subprocess.run(
                    [sys.executable, "-c", _CHILD_SPEED, str(log), str(RESOLUTION)],
                    env={**os.environ, "PYTHONPATH": str(src)},
                    capture_output=True,
                    text=True,
                    check=True,
                )
                times[src].append(float(out.stdout.split()[-1]))
    return statistics.median(times[mine]), statistics.median(times[baseline])


def _time(job: Callable[[], None]) -> tuple[float, float]:
    """Wall-clock and CPU seconds of ``job`` (CPU time is what this process got of the cores)."""
    started, cpu = time.perf_counter(), time.process_time()
    job()
    return time.perf_counter() - started, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--baseline",
        help="a commit, or another checkout's folder, to time the default pipeline against",
    )
    parser.add_argument(
        "--memory-rings",
        type=int,
        help="map only this many rings of the 50 MB log (default: all of it, ~7 CPU min)",
    )
    args = parser.parse_args()
    if args.memory_rings is not None and args.memory_rings < 1:
        parser.error(f"--memory-rings must be at least 1, got {args.memory_rings}")
    with ExitStack() as stack:
        baseline = None if args.baseline is None else source_tree(args.baseline, stack)
        _run(baseline, args.memory_rings)


def _run(baseline_tree: tuple[Path, str] | None, memory_rings: int | None) -> None:
    """Measure and write the report; ``baseline_tree`` is (tree, label) of ``--baseline``,
    ``memory_rings`` the rings of the 50 MB log to map (``None``: all)."""
    poses, ranges, geometry, (xmin, ymin, xmax, ymax) = _log()
    load_start = " / ".join(f"{v:.1f}" for v in os.getloadavg())

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

    def pipeline_job(name: str, n: int) -> Callable[[], None]:
        pipeline = PIPELINES[name]

        def job() -> None:
            mapper = pipeline.make_mapper(grid(), geometry)
            filt = pipeline.make_filter(geometry)
            map_log(
                poses[:n],
                ranges[:n],
                mapper,
                filt,
                merge_repeats=pipeline.merge_repeats,
                map_verdict=pipeline.map_verdict,
            )

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
        (
            "default pipeline: filter + eq. 1 map + forward-model sweep (bayesmap)",
            RINGS,
            pipeline_job(DEFAULT_PIPELINE, RINGS),
        ),
        (
            "streaming pipeline: filter + one-pass eq. 1 map",
            RINGS,
            pipeline_job("streaming", RINGS),
        ),
        ("paper pipeline: paper filter + eq. 1 map", RINGS, pipeline_job("paper", RINGS)),
        ("paper filter only (all three stages)", PEER_RINGS, filter_only(PEER_RINGS)),
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
        runs = [_time(job) for _ in range(REPEATS)]
        seconds = statistics.median(wall for wall, _ in runs)
        cpu = statistics.median(used for _, used in runs)
        rows.append((name, n, seconds, cpu, n * geometry.n / seconds, n * geometry.n / cpu))
        print(f"{name:55s} {n:6d} rings {seconds:7.2f} s wall {cpu:7.2f} s CPU", flush=True)
    load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
    ratio, sweep = rows[0][5] / rows[2][5], rows[0][5] / rows[1][5]
    print(f"default / paper rate per CPU second: {ratio:.2f}; default / streaming: {sweep:.2f}")
    versus = ""
    if baseline_tree is not None:
        tree, label = baseline_tree
        mine, theirs = _against(tree / "src", poses, ranges, (xmin, ymin, xmax, ymax))
        print(f"default pipeline CPU s: this checkout {mine:.2f}, {label} {theirs:.2f}")
        versus = (
            f" Against {label} (`--baseline`; each in its own child process, taking "
            f"turns, median of {REPEATS}): {theirs:.2f} CPU s there, {mine:.2f} here, a "
            f"speed-up of **{theirs / mine:.2f}x** (load average "
            f"{' / '.join(f'{v:.1f}' for v in os.getloadavg())} after it)."
        )
    big = _memory(poses, ranges, memory_rings)
    print(
        f"{big.size_mb:.0f} MB log: {big.rows} rows read in {big.read_s:.1f} s (peak "
        f"{big.read_peak_mb:.0f} MB), {big.mapped_rings} rings mapped in {big.map_s:.0f} s "
        f"({big.map_cpu_s:.0f} CPU s), peak {big.peak_mb:.0f} MB"
    )
    load_end = " / ".join(f"{v:.1f}" for v in os.getloadavg())
    whole = big.mapped_rings == big.rows
    table = [
        "## sonar_filter: ring readings per second, memory on a 50 MB log",
        "",
        f"Machine: {machine()}; load average (1 / 5 / 15 min) {load_start} at the start, {load} "
        f"at the end (the cores were shared with other jobs, so these rates are lower bounds). "
        f"Log: Pioneer 16-sonar ring, realistic "
        f"simulated laps of `{WORLD}` (people, stops, drift), grid {RESOLUTION} m; median of "
        f"{REPEATS} repeats, single process. Target: 10,000 readings/s through filter + map.",
        "",
        "| pipeline | rings | median wall [s] | median CPU [s] | readings / wall s | "
        "readings / CPU s |",
        "|---|---:|---:|---:|---:|---:|",
        *(
            f"| {name} | {n} | {sec:.2f} | {cpu:.2f} | {per_wall:,.0f} | {per_cpu:,.0f} |"
            for name, n, sec, cpu, per_wall, per_cpu in rows
        ),
        "",
        f"Default over paper pipeline, readings per CPU second: **{ratio:.2f}**; default over "
        f"streaming (the cost of the forward-model sweep): **{sweep:.2f}** (pipelines of one "
        f"run share the cores alike, so the ratios do not depend on the load).{versus}",
        "",
        "Readings per CPU second is the rate the code reaches when it has a core to itself; "
        "readings per wall second is what this run saw with the cores shared. The "
        "pipelines run `map_log`, which hands the filter and the mapper 100 rings at a time: "
        "the transducer positions, Acceptability, Agreeability, the cone cells and the eq. 1 "
        "log-odds of a batch are computed at once, Trait Verification and the log-odds "
        "additions ring by ring (same verdicts and map as ring by ring). Within a ring, "
        "Trait Verification makes one ray pass (every beam's axis and cone edges against the "
        "traits of L near enough for hygiene and the extended traits the verdicts test), "
        "one distance pass from the robot to the traits of L and V, and one bounding-box "
        "screen of all pairs of traits; split-and-merge, the few pairs the screen leaves and "
        "the bookkeeping run on plain Python floats. The pipeline rows run `map_log` (the "
        "default's forward-model sweep and every pipeline's map verdict included); "
        "the other rows feed one ring at a time.",
        "",
        "The ROS layer updates one reading at a time (Bayes with cost quantisation), as the "
        "layer does; the log-odds models update a whole ring at once.",
        "",
        f"**50 MB log** ({big.size_mb:.0f} MB, {big.rows:,} rings, mm and decidegrees): read "
        f"by `read_sonar_log` in {big.read_s:.1f} s ({big.rows / big.read_s:,.0f} rows/s; "
        f"peak resident memory {big.read_peak_mb:.0f} MB), then "
        + ("**all of it**" if whole else f"its first {big.mapped_rings:,} rings (`--memory-rings`)")
        + f" mapped with the default pipeline in {big.map_s:.0f} s wall, {big.map_cpu_s:.0f} "
        f"CPU s ({big.mapped_rings * geometry.n / big.map_cpu_s:,.0f} readings per CPU "
        f"second; load average {load_end} after it); peak resident memory of the whole child "
        f"process (Python, numpy, matplotlib-free) **{big.peak_mb:.0f} MB** (target: under "
        "300 MB for the whole log).",
    ]
    update_section("sonar_filter", "\n".join(table))


if __name__ == "__main__":
    main()
