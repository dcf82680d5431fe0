"""Tests of the stateful filter, the mappers and the pipeline."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from tests.sonar.helpers import DATA, recorder

from bayesmap.errors import ConfigError, InputError
from bayesmap.experiments.sonar import ring_geometry
from bayesmap.grid import OccupancyGrid
from bayesmap.sim.polygons import path_poses, world
from bayesmap.sim.sonar import SonarRing, SonarScan, observe
from bayesmap.sim.sonar_log import Realism, simulate_log
from bayesmap.sonar.filter import SpecularFilter, Stage
from bayesmap.sonar.geometry import SonarGeometry, cone_cells
from bayesmap.sonar.logs import LogUnits, read_sonar_log
from bayesmap.sonar.mapping import ElfesMapper, RosRangeLayerMapper, ThrunMapper
from bayesmap.sonar.pipeline import PIPELINES, build_map, grid_for_poses, map_log, repeats_last

Corridor = tuple[np.ndarray, SonarScan, SonarGeometry]


@pytest.fixture(scope="module")
def corridor() -> Corridor:
    w = world("sonar-corridor-v1")
    ring = SonarRing()
    poses = path_poses(w.waypoints, 0.15)
    scan = observe(w, poses, ring, rng=11)
    return poses, scan, ring_geometry(ring)


def test_all_stages_off_accepts_everything(corridor: Corridor) -> None:
    poses, scan, geometry = corridor
    filt = SpecularFilter(
        geometry, acceptability=False, agreeability=False, trait_verification=False
    )
    accepted = np.array(
        [filt.process(p, r).accepted for p, r in zip(poses, scan.ranges, strict=True)]
    )
    assert accepted.all() and filt.rejections_ == []


def test_rejections_are_recorded_with_stage_and_reason_and_beat_chance(corridor: Corridor) -> None:
    poses, scan, geometry = corridor
    filt = SpecularFilter(geometry)
    verdicts = [filt.process(p, r) for p, r in zip(poses, scan.ranges, strict=True)]
    stage = np.array([v.stage for v in verdicts])
    rejected = stage != Stage.ACCEPTED
    assert len(filt.rejections_) == rejected.sum()
    assert sum(filt.counts_.values()) == rejected.sum()
    for rej in filt.rejections_:
        assert stage[rej.ring, rej.sensor] == rej.stage and rej.reason
    precision = scan.specular[rejected].mean()
    recall = rejected[scan.specular].mean()
    assert precision > scan.specular.mean() + 0.2  # rejects specular readings far above chance
    assert recall > 0.5


def test_the_rejection_log_holds_one_byte_a_reading_and_builds_the_records(
    corridor: Corridor,
) -> None:
    poses, scan, geometry = corridor
    filt = SpecularFilter(geometry)
    half = len(poses) // 2
    stage = np.vstack(
        [filt.process_many(poses[:half], scan.ranges[:half]).stage]
        + [
            filt.process(p, r).stage[None]
            for p, r in zip(poses[half:], scan.ranges[half:], strict=True)
        ]
    )
    codes = filt.rejection_codes_
    assert codes.dtype == np.int8 and codes.shape == scan.ranges.shape
    assert np.array_equal(codes != 0, stage != Stage.ACCEPTED) and (codes != 0).any()
    records = filt.rejections_
    assert [(r.ring, r.sensor) for r in records] == list(zip(*codes.nonzero(), strict=True))
    assert {r.stage for r in records} <= set(Stage) and all(r.reason for r in records)
    assert sum(filt.counts_.values()) == len(records)
    assert filt.enough_state  # the corridor path is longer than four perceptual lengths


def test_filter_is_deterministic(corridor: Corridor) -> None:
    poses, scan, geometry = corridor
    runs = []
    for _ in range(2):
        filt = SpecularFilter(geometry)
        runs.append(
            np.array([filt.process(p, r).stage for p, r in zip(poses, scan.ranges, strict=True)])
        )
    assert np.array_equal(runs[0], runs[1])


def test_filter_rejects_bad_parameters_and_input() -> None:
    geometry = SonarGeometry(angles=(0.0, 1.0, 2.0))
    with pytest.raises(ConfigError):
        SpecularFilter(geometry, certainty_threshold=2.0)
    with pytest.raises(ConfigError, match="max_gap"):
        SpecularFilter(geometry, max_gap=0.0)
    with pytest.raises(ConfigError, match="tilts"):
        SpecularFilter(geometry, tilts=1)
    SpecularFilter(geometry, extension=0.0, margin=0.0)  # zero is allowed for these two
    for span in (-0.5, math.nan):
        with pytest.raises(ConfigError, match="static_span"):
            SpecularFilter(geometry, keep_supported_echoes=True, static_span=span)
    with pytest.raises(InputError):
        SpecularFilter(geometry).process(np.zeros(3), np.array([1.0, np.nan, 2.0]))
    with pytest.raises(InputError, match="non-negative"):
        SpecularFilter(geometry).process(np.zeros(3), np.array([1.0, -0.5, 2.0]))


def test_cone_cells_are_inside_the_cone() -> None:
    grid = OccupancyGrid(10, 10, 0.1, origin=(-5, -5))
    centres = np.array([[0.0, 0.0], [1.0, 1.0]])
    axis = np.array([0.3, -2.0])
    cells = cone_cells(grid, centres, axis, np.array([3.0, 2.0]), 0.2)
    x, y = grid.cell_centers(cells.rows, cells.cols)
    c = centres[cells.reading]
    rho = np.hypot(x - c[:, 0], y - c[:, 1])
    assert np.allclose(rho, cells.rho) and np.all(rho <= np.array([3.0, 2.0])[cells.reading])
    bearing = (np.arctan2(y - c[:, 1], x - c[:, 0]) - axis[cells.reading] + math.pi) % (
        2 * math.pi
    ) - math.pi
    assert np.all(np.abs(bearing) <= 0.2)
    # Brute force: every grid cell inside cone 0 is found.
    rows, cols = np.mgrid[0:100, 0:100]
    gx, gy = grid.cell_centers(rows, cols)
    inside = (np.hypot(gx, gy) <= 3.0) & (
        np.abs((np.arctan2(gy, gx) - 0.3 + math.pi) % (2 * math.pi) - math.pi) <= 0.2
    )
    assert inside.sum() == (cells.reading == 0).sum()


@pytest.mark.parametrize("half_width", [0.8, 1.2, 1.55])
def test_wide_cones_on_a_fine_grid_miss_no_cell(half_width: float) -> None:
    """The search box must hold the whole arc, also where it bulges between the edges."""
    grid = OccupancyGrid(12, 12, 0.02, origin=(-6, -6))
    rng = np.random.default_rng(5)
    centres = rng.uniform(-1, 1, (6, 2))
    axis = rng.uniform(-math.pi, math.pi, 6)
    reach = rng.uniform(1, 5, 6)
    cells = cone_cells(grid, centres, axis, reach, half_width)
    rows, cols = np.mgrid[0 : grid.shape[0], 0 : grid.shape[1]]
    gx, gy = grid.cell_centers(rows, cols)
    for k in range(6):
        dx, dy = gx - centres[k, 0], gy - centres[k, 1]
        along = dx * math.cos(axis[k]) + dy * math.sin(axis[k])
        across = dy * math.cos(axis[k]) - dx * math.sin(axis[k])
        inside = (np.abs(across) <= along * math.tan(half_width)) & (
            along**2 + across**2 <= reach[k] ** 2
        )
        assert inside.sum() == (cells.reading == k).sum()


@pytest.mark.parametrize("half_width", [math.radians(12.5), 0.8, 1.55])
def test_cone_cells_are_the_whole_grids_test_value_for_value(half_width: float) -> None:
    """Each row's run of candidates finds, in reading, row, column order, exactly the cells
    (and the same ``rho``, ``theta`` bits) as testing every cell of the grid; axes along a
    grid line put cone edges on rows and columns of cell centres."""
    grid = OccupancyGrid(8, 6, 0.1, origin=(-4.03, -3.0))
    rng = np.random.default_rng(11)
    centres = np.vstack([rng.uniform(-5, 5, (30, 2)), [[0.02, 0.05], [-0.03, 0.0]]])
    axis = np.r_[rng.uniform(-4, 4, 30), 0.0, math.pi / 2 - half_width]
    reach = np.r_[rng.uniform(-1, 5, 30), 3.0, 2.5]
    cells = cone_cells(grid, centres, axis, reach, half_width)
    ny, nx = grid.shape
    rows, cols = (g.ravel() for g in np.mgrid[0:ny, 0:nx])
    x0, y0 = grid.origin
    want = []
    for k in np.flatnonzero(reach > 0):
        ux, uy = np.cos(axis[k : k + 1]), np.sin(axis[k : k + 1])
        dx = x0 + (cols + 0.5) * grid.resolution - centres[k, 0]
        dy = y0 + (rows + 0.5) * grid.resolution - centres[k, 1]
        along, across = dx * ux + dy * uy, dy * ux - dx * uy
        inside = (np.abs(across) <= along * math.tan(half_width)) & (
            along * along + across * across <= reach[k] * reach[k]
        )
        a, b = along[inside], across[inside]
        reading = np.full(len(a), k)
        want.append((rows[inside], cols[inside], np.hypot(a, b), np.arctan2(b, a), reading))
    assert len(want) > 20 and len(cells.rows) > 1000
    for got, expected in zip(cells, zip(*want, strict=True), strict=True):
        assert np.array_equal(got, np.concatenate(expected))


def test_elfes_mapper_marks_the_echo_and_frees_the_cone() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), sigma=0.05, max_range=5.0)
    grid = OccupancyGrid(10, 10, 0.1, origin=(-5, -5))
    mapper = ElfesMapper(grid, geometry)
    mapper.integrate([0.05, 0.05, 0.0], [2.0, 5.0], use=[True, True])
    p = mapper.probability()
    r, c = grid.world_to_cell([2.05, 1.0, -2.0, 3.0], [0.05, 0.05, 0.05, 0.05])
    assert (
        p[r[0], c[0]] > 0.6 and p[r[1], c[1]] < 0.4 and p[r[2], c[2]] < 0.4 and p[r[3], c[3]] == 0.5
    )
    before = mapper.log_odds_.copy()
    mapper.integrate([0.05, 0.05, 0.0], [2.0, 5.0], use=[False, False])
    assert np.array_equal(before, mapper.log_odds_)
    mapper.sync()
    assert np.allclose(grid.probability, mapper.probability())


def test_thrun_mapper_adds_exactly_plus_minus_0_4() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    grid = OccupancyGrid(10, 10, 0.1, origin=(-5, -5))
    mapper = ThrunMapper(grid, geometry)
    mapper.integrate([0.05, 0.05, 0.0], [2.0, 5.0])
    values = set(np.round(np.unique(mapper.log_odds_), 9).tolist())
    assert values <= {-0.4, 0.0, 0.4} and {-0.4, 0.4} <= values


def test_ros_mapper_stays_quantised_and_marks_near_echoes() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    grid = OccupancyGrid(6, 6, 0.05, origin=(-3, -3))
    mapper = RosRangeLayerMapper(grid, geometry)
    for _ in range(3):
        mapper.integrate([0.0, 0.0, 0.0], [1.0, 0.8])
    p = mapper.probability()
    assert np.allclose(p * 254, np.round(p * 254))
    r, c = grid.world_to_cell([1.0, 0.5], [0.01, 0.01])
    assert p[r[0], c[0]] > 0.8 and p[r[1], c[1]] < 0.2


def test_pipeline_filtered_map_is_deterministic_and_covers_the_path(corridor: Corridor) -> None:
    poses, scan, geometry = corridor
    a = build_map(poses, scan.ranges, geometry, 0.2)
    b = build_map(poses, scan.ranges, geometry, 0.2)
    assert np.array_equal(a.mapper.probability(), b.mapper.probability())
    assert np.array_equal(a.run.stage, b.run.stage)
    grid = a.mapper.grid
    rows, cols = grid.world_to_cell(poses[:, 0], poses[:, 1])
    assert grid.in_bounds(rows, cols).all()
    unfiltered = build_map(poses, scan.ranges, geometry, 0.2, pipeline=PIPELINES["elfes"])
    assert unfiltered.run.accepted.all() and unfiltered.filt is None
    with pytest.raises(InputError):
        map_log(poses, scan.ranges[:-1], ElfesMapper(grid_for_poses(poses, 5, 0.2), geometry))


@pytest.mark.parametrize("name", ["default", "elfes", "ros"])
def test_readings_that_measured_nothing_are_never_mapped(corridor: Corridor, name: str) -> None:
    """A 0, a negative code or a reading below the min range is left out of the map: the
    map is the one made from the log without them, and their stage says why."""
    poses, scan, geometry = corridor
    geometry = replace(geometry, min_range=0.1)
    codes = scan.ranges.copy()
    rng = np.random.default_rng(5)
    hit = rng.random(codes.shape) < 0.2
    codes[hit] = rng.choice([0.0, -1.0, 0.05], size=int(hit.sum()))
    built = build_map(poses, codes, geometry, 0.2, pipeline=PIPELINES[name])
    assert (built.run.stage[hit] == Stage.TOO_CLOSE).all() and not built.run.accepted[hit].any()
    assert not (built.run.stage[~hit] == Stage.TOO_CLOSE).any()
    if name != "default":  # no filter: the same map as without those readings
        grid = grid_for_poses(poses, geometry.max_range + geometry.reach, 0.2)
        mapper = PIPELINES[name].make_mapper(grid, geometry)
        mapper.integrate_many(poses, np.where(hit, np.inf, scan.ranges), ~hit)
        mapper.sync()
        assert np.array_equal(mapper.probability(), built.mapper.probability())


def _row_probability(mapper: ElfesMapper | RosRangeLayerMapper, y: float = 0.0) -> np.ndarray:
    grid = mapper.grid
    row = grid.world_to_cell(0.0, y)[0]
    return np.asarray(mapper.probability()[row])


def test_no_echo_handling_ignore_clear_and_cone() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    far = [6.0, 6.0]  # a no-echo code above the max range
    seen = {}
    for mode in ("ignore", "clear", "cone"):
        grid = OccupancyGrid(12.0, 2.0, 0.1, origin=(-6.0, -1.0))
        mapper = ElfesMapper(grid, geometry, no_echo=mode, clear_distance=1.5)
        mapper.integrate([0.0, 0.0, 0.0], far)
        x = np.asarray(grid.cell_centers(0, np.arange(grid.shape[1]))[0])
        free = _row_probability(mapper) < 0.5
        seen[mode] = float(np.abs(x[free]).max()) if free.any() else 0.0
    assert seen["ignore"] == 0.0
    assert 1.3 <= seen["clear"] <= 1.5
    assert seen["cone"] > 4.5


def test_saturation_and_decay_let_a_passer_by_fade() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)

    def rings_to_clear(clamp: float, decay: float) -> int:
        grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
        mapper = ElfesMapper(grid, geometry, clamp=clamp, decay=decay)
        for _ in range(47):  # a person stands 1 m ahead while the robot waits
            mapper.integrate([0.0, 0.0, 0.0], [1.0, 6.0])
        cell = grid.world_to_cell(1.0, 0.0)
        for n in range(1, 500):  # they leave: the wall is 3 m ahead
            mapper.integrate([0.0, 0.0, 0.0], [3.0, 6.0])
            if mapper.probability()[cell] < 0.5:
                return n
        return 500

    assert rings_to_clear(10.0, 0.0) > rings_to_clear(3.0, 0.0) > rings_to_clear(3.0, 0.2)


def test_footprint_clearing_frees_the_robots_cells() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
    mapper = ElfesMapper(grid, geometry, footprint=0.2)
    mapper.integrate([0.0, 0.0, 0.0], [1.0, 6.0])
    assert mapper.probability()[grid.world_to_cell(1.0, 0.0)] > 0.5
    mapper.integrate([1.0, 0.0, 0.0], [6.0, 6.0])
    assert mapper.probability()[grid.world_to_cell(1.0, 0.0)] < 0.5


def test_cells_the_robot_stood_on_stay_free_when_a_person_passes_later() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
    mapper = ElfesMapper(grid, geometry, footprint=0.2, no_echo="ignore")
    mapper.integrate([1.0, 0.0, 0.0], [6.0, 6.0])  # the robot stands at x = 1
    for _ in range(30):  # back at the start, it sees a person standing where it stood
        mapper.integrate([0.0, 0.0, 0.0], [1.0, 6.0])
    assert mapper.swept_[grid.world_to_cell(1.0, 0.0)]
    assert mapper.probability()[grid.world_to_cell(1.0, 0.0)] < 0.5
    assert mapper.probability()[grid.world_to_cell(1.4, 0.0)] == 0.5  # beyond: untouched


def test_free_lock_keeps_well_seen_free_space_free_when_a_person_steps_in() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)

    def after_person(free_lock: float) -> tuple[float, float]:
        grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
        mapper = ElfesMapper(grid, geometry, free_lock=free_lock, no_echo="ignore")
        for _ in range(20):  # the wall 3 m ahead, the space before it seen free
            mapper.integrate([0.0, 0.0, 0.0], [3.0, 6.0])
        for _ in range(20):  # a person stops 1 m ahead
            mapper.integrate([0.0, 0.0, 0.0], [1.0, 6.0])
        p = mapper.probability()
        return float(p[grid.world_to_cell(1.0, 0.0)]), float(p[grid.world_to_cell(3.0, 0.0)])

    person, wall = after_person(3.0)
    assert person < 0.5 and wall > 0.5  # the person is not written; the wall stays
    assert after_person(0.0)[0] > 0.5  # without the lock the person is mapped
    grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
    fresh = ElfesMapper(grid, geometry, free_lock=3.0)
    fresh.integrate([0.0, 0.0, 0.0], [1.0, 6.0])  # an unseen cell takes the echo
    assert fresh.probability()[grid.world_to_cell(1.0, 0.0)] > 0.5
    with pytest.raises(ConfigError, match="free_lock"):
        ElfesMapper(grid, geometry, free_lock=-1.0)


def test_explaining_away_moves_an_echos_weight_off_arc_cells_seen_free() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)  # the rear one stays silent
    side = (2.97, 0.42)  # on the 3 m arc, 8° off the axis
    unseen = (2.97, -0.42)  # on the arc's other side, outside the other beam

    def after_echo(explain_away: float, explain_beyond: float = 0.0) -> tuple[float, float]:
        grid = OccupancyGrid(8.0, 4.0, 0.1, origin=(-1.0, -2.0))
        mapper = ElfesMapper(
            grid,
            geometry,
            no_echo="ignore",
            explain_away=explain_away,
            explain_beyond=explain_beyond,
        )
        for _ in range(10):  # another beam runs through the side cell to a wall 4.5 m on
            mapper.integrate([0.0, side[1], 0.0], [4.5, 6.0])
        before = mapper.log_odds_.copy()
        mapper.integrate([0.0, 0.0, 0.0], [3.0, 6.0])  # the echo whose arc holds both cells
        gain = mapper.log_odds_ - before
        return float(gain[grid.world_to_cell(*side)]), float(gain[grid.world_to_cell(*unseen)])

    plain_side, plain_unseen = after_echo(0.0)
    side_gain, unseen_gain = after_echo(1.0)
    assert plain_side > 0.1 and plain_unseen > 0.1
    # The cell seen free is explained away; the unseen cell takes the echo's full weight.
    assert side_gain < 0.1 * plain_side and unseen_gain == pytest.approx(plain_unseen)
    # Arcs nearer than explain_beyond are written as the cone model says.
    assert after_echo(1.0, explain_beyond=3.5) == pytest.approx((plain_side, plain_unseen))
    grid = OccupancyGrid(8.0, 4.0, 0.1)
    for bad in ({"explain_away": -1.0}, {"explain_beyond": -0.5}):
        with pytest.raises(ConfigError, match="explain"):
            ElfesMapper(grid, geometry, **bad)  # type: ignore[arg-type]


def test_ros_layer_drops_readings_above_max_range_and_marks_at_it() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    grid = OccupancyGrid(12.0, 2.0, 0.1, origin=(-6.0, -1.0))
    mapper = RosRangeLayerMapper(grid, geometry)
    mapper.integrate([0.0, 0.0, 0.0], [5.25, math.inf])
    assert not mapper.observed().any()
    mapper.integrate([0.0, 0.0, 0.0], [5.0, math.inf])  # exactly at max: marked, as ROS does
    assert mapper.probability()[grid.world_to_cell(5.0, 0.0)] > 0.5


def test_identical_stationary_rings_count_once() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    poses = np.array([[0.0, 0.0, 0.0]] * 47 + [[0.5, 0.0, 0.0]])
    ranges = np.array([[1.0, 6.0]] * 47 + [[0.5, 6.0]])
    ranges[10, 0] += 0.5 * geometry.sigma  # within the noise: still the same ring

    def run(merge: bool) -> tuple[np.ndarray, int]:
        grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
        mapper = ElfesMapper(grid, geometry)
        outcome = map_log(poses, ranges, mapper, merge_repeats=merge)
        return outcome.repeat, mapper.rings_

    repeat, rings = run(True)
    assert repeat.sum() == 46 and rings == 2
    assert run(False)[1] == 48


def test_grid_too_large_is_refused_with_the_unit_hint() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [12_000.0, 3_000.0, 0.0]])  # mm read as metres
    with pytest.raises(InputError, match="millimetres"):
        grid_for_poses(poses, 5.0, 0.05)


def _plant_l(
    filt: SpecularFilter, segments: np.ndarray, *, seen: float, first: float | None = None
) -> None:
    """Give ``filt`` the local view ``segments``, each last seen at path position ``seen``
    (and first at ``first``, default the same) and seen through by no reading."""
    k = len(segments)
    filt.l_segments_ = np.asarray(segments, dtype=np.float64)
    filt.l_first_ = np.full(k, seen if first is None else first)
    filt.l_seen_ = np.full(k, seen)
    filt.l_passes_ = np.zeros(k, dtype=np.int64)


def test_traits_the_robot_drives_through_leave_l() -> None:
    geometry = SonarGeometry(angles=tuple(2 * math.pi * k / 8 for k in range(8)), max_range=5.0)
    filt = SpecularFilter(geometry, footprint=0.25)
    _plant_l(filt, np.array([[1.0, -1.0, 1.0, 1.0], [3.0, -1.0, 3.0, 1.0]]), seen=0.0)
    filt.process([1.1, 0.0, 0.0], np.full(8, 6.0))  # the robot stands on the first "wall"
    assert filt.l_segments_.tolist() == [[3.0, -1.0, 3.0, 1.0]]


def test_traits_echoes_see_through_leave_l() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi / 2, math.pi, -math.pi / 2), max_range=5.0)
    filt = SpecularFilter(geometry, acceptability=False, agreeability=False, pass_limit=3)
    _plant_l(filt, np.array([[1.0, -0.5, 1.0, 0.5]]), seen=0.0)  # a phantom 1 m ahead
    for _ in range(3):  # echoes keep coming from a wall 3 m ahead, through the phantom
        filt.process([0.0, 0.0, 0.0], [3.0, 2.0, 2.0, 2.0])
    assert not np.any(np.all(np.isclose(filt.l_segments_, [1.0, -0.5, 1.0, 0.5]), axis=1))


def test_silent_head_on_readings_remove_a_trait_and_are_not_rejected_by_it() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi / 2, math.pi, -math.pi / 2), max_range=5.0)
    filt = SpecularFilter(geometry, acceptability=False, agreeability=False, pass_limit=3)
    filt.path_ = 100.0  # enough state: case B
    _plant_l(filt, np.array([[1.0, -0.5, 1.0, 0.5]]), seen=100.0)  # a person who has walked on
    verdict = filt.process([0.0, 0.0, 0.0], [6.0, 2.0, 2.0, 2.0])  # faces it head-on: silence
    assert verdict.accepted[0]
    for _ in range(2):
        filt.process([0.0, 0.0, 0.0], [6.0, 2.0, 2.0, 2.0])
    assert len(filt.l_segments_) == 0


def test_silent_glancing_reading_through_a_known_wall_is_rejected() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi / 2, math.pi, -math.pi / 2), max_range=5.0)
    filt = SpecularFilter(geometry, acceptability=False, agreeability=False)
    filt.path_ = 100.0
    _plant_l(filt, np.array([[-1.0, -3.0, 4.0, 2.0]]), seen=100.0)  # a wall met at 45°: echo lost
    verdict = filt.process([0.0, 0.0, 0.0], [6.0, 1.0, 1.0, 1.0])
    assert not verdict.accepted[0] and verdict.stage[0] == Stage.TRAIT_VERIFICATION


def test_a_pipelines_free_probability_reaches_its_mapper() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    cleared = {}
    for p_free in (0.35, 0.45):
        grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
        mapper = replace(PIPELINES["elfes"], p_free=p_free).make_mapper(grid, geometry)
        mapper.integrate([0.0, 0.0, 0.0], [3.0, 6.0])
        cleared[p_free] = mapper.probability()[grid.world_to_cell(1.0, 0.0)]
    assert cleared[0.35] == pytest.approx(0.35, abs=0.01) and cleared[0.45] > cleared[0.35]


def test_a_pipelines_one_sided_arc_reaches_its_mapper_and_frees_the_cell_in_front() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    marked = {}
    for sigma_front in (None, 0.03):
        grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
        pipeline = replace(PIPELINES["elfes"], sigma_front=sigma_front)
        mapper = pipeline.make_mapper(grid, geometry)
        mapper.integrate([0.0, 0.0, 0.0], [3.05, 6.0])
        p = mapper.probability()
        marked[sigma_front] = (p[grid.world_to_cell(2.95, 0.0)], p[grid.world_to_cell(3.05, 0.0)])
    assert marked[None][0] > 0.5 > marked[0.03][0]  # the cell 0.1 m in front of the echo
    assert marked[None][1] > 0.5 and marked[0.03][1] > 0.5  # the echo's own cell
    assert PIPELINES["default"].sigma_front == PIPELINES["streaming"].sigma_front == 0.03


@pytest.fixture(scope="module")
def realistic_log() -> tuple[np.ndarray, np.ndarray, SonarGeometry]:
    """A Pioneer 16-ring log with stops, people and drift (the ring has true offsets)."""
    ring = SonarRing.pioneer(16)
    log = simulate_log(world("sonar-office-v2"), ring, Realism(laps=1), rng=5)
    return log.odometry[:260], log.ranges[:260], ring_geometry(ring)


def test_sensors_many_places_every_ring_as_sensors_does(
    realistic_log: tuple[np.ndarray, np.ndarray, SonarGeometry],
) -> None:
    poses, _, geometry = realistic_log
    for g in (geometry, replace(geometry, offsets=None, radius=0.2)):
        centres, axis = g.sensors_many(poses[:7])
        assert centres.shape == (7, g.n, 2) and axis.shape == (7, g.n)
        for i in range(7):
            one_c, one_a = g.sensors(poses[i])
            assert np.array_equal(centres[i], one_c) and np.array_equal(axis[i], one_a)
    with pytest.raises(InputError, match="finite"):
        geometry.sensors_many(np.array([[0.0, np.nan, 0.0]]))


def test_batched_filter_gives_the_ring_by_ring_verdicts_rejections_and_l(
    realistic_log: tuple[np.ndarray, np.ndarray, SonarGeometry],
) -> None:
    poses, ranges, geometry = realistic_log
    options = dict(PIPELINES["default"].filter_options)
    one, many = SpecularFilter(geometry, **options), SpecularFilter(geometry, **options)
    stages = np.array([one.process(p, r).stage for p, r in zip(poses, ranges, strict=True)])
    # Uneven batches, so batch edges fall anywhere (the filter's state carries across them).
    batched = np.vstack(
        [many.process_many(poses[a:b], ranges[a:b]).stage for a, b in ((0, 1), (1, 90), (90, 260))]
    )
    assert np.count_nonzero(stages) > 0  # the log has something to reject
    assert np.array_equal(stages, batched)
    assert one.rejections_ == many.rejections_ and one.counts_ == many.counts_
    assert np.array_equal(one.l_segments_, many.l_segments_) and one.path_ == many.path_
    with pytest.raises(InputError, match="non-negative"):
        many.process_many(poses[:2], np.where(np.arange(16) == 3, -1.0, ranges[:2]))


@pytest.mark.parametrize("name", ["default", "thrun", "ros", "paper"])
def test_batched_mapping_gives_the_ring_by_ring_map(
    name: str, realistic_log: tuple[np.ndarray, np.ndarray, SonarGeometry]
) -> None:
    poses, ranges, geometry = realistic_log
    pipeline = replace(PIPELINES[name], decay=0.05) if name != "ros" else PIPELINES[name]
    use = np.random.default_rng(0).random(ranges.shape) < 0.8

    def mapper() -> object:
        return pipeline.make_mapper(grid_for_poses(poses, geometry.max_range, 0.1), geometry)

    one, many = mapper(), mapper()
    for p, r, u in zip(poses, ranges, use, strict=True):
        one.integrate(p, r, u)  # type: ignore[attr-defined]
    many.integrate_many(poses[:100], ranges[:100], use[:100])  # type: ignore[attr-defined]
    many.integrate_many(poses[100:], ranges[100:], use[100:])  # type: ignore[attr-defined]
    assert np.array_equal(one.probability(), many.probability())  # type: ignore[attr-defined]
    assert one.rings_ == many.rings_ == len(poses)  # type: ignore[attr-defined]


def test_map_log_matches_a_ring_by_ring_run_of_the_fixture_log() -> None:
    log = read_sonar_log(DATA / "example_log.txt", 16, units=LogUnits("mm", "mm", "deg"))
    geometry = SonarGeometry(tuple(math.radians(22.5 * k) for k in range(16)), max_range=5.0)
    pipeline = PIPELINES["default"]
    grid = grid_for_poses(log.poses, geometry.max_range, 0.1)
    mapper, filt = pipeline.make_mapper(grid, geometry), pipeline.make_filter(geometry)
    assert filt is not None
    run = map_log(log.poses, log.ranges, mapper, filt, merge_repeats=True)
    # The same by hand, one ring at a time.
    ref_mapper = pipeline.make_mapper(grid_for_poses(log.poses, geometry.max_range, 0.1), geometry)
    ref_filter = pipeline.make_filter(geometry)
    assert ref_filter is not None
    stages, last = [], -1
    for i, (p, r) in enumerate(zip(log.poses, log.ranges, strict=True)):
        if last >= 0 and repeats_last(log.poses[last], log.ranges[last], p, r, geometry):
            stages.append(stages[-1])
            continue
        last = i
        verdict = ref_filter.process(p, r)
        ref_mapper.integrate(p, r, verdict.accepted, verdict.free_limit)
        stages.append(verdict.stage)
    assert np.array_equal(run.stage, np.array(stages))
    assert filt.rejections_ == ref_filter.rejections_
    ref_mapper.sync()  # the default's forward-model sweep runs when the map is synced
    assert np.array_equal(mapper.probability(), ref_mapper.probability())


def test_map_log_reports_progress_every_100_rings_and_at_the_end() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    poses = np.column_stack([np.linspace(0.0, 2.0, 250), np.zeros(250), np.zeros(250)])
    ranges = np.tile([1.0, 6.0], (250, 1))
    calls: list[tuple[str, int, int]] = []
    grid = OccupancyGrid(8.0, 2.0, 0.1, origin=(-4.0, -1.0))
    map_log(poses, ranges, ElfesMapper(grid, geometry), progress=lambda *call: calls.append(call))
    assert calls == [("mapping", 100, 250), ("mapping", 200, 250), ("mapping", 250, 250)]


class _RingByRingMapper:
    """A user's own mapper: only the methods :class:`RingMapper` requires, no batch method."""

    def __init__(self, inner: ElfesMapper) -> None:
        self.inner, self.grid, self.rings = inner, inner.grid, 0

    def integrate(
        self, pose: object, ranges: object, use: object = None, free_limit: object = None
    ) -> None:
        self.rings += 1
        self.inner.integrate(pose, ranges, use, free_limit)  # type: ignore[arg-type]

    def probability(self) -> np.ndarray:
        return self.inner.probability()

    def observed(self) -> np.ndarray:
        return self.inner.observed()

    def sync(self) -> OccupancyGrid:
        return self.inner.sync()


def test_map_log_feeds_a_mapper_without_integrate_many_ring_by_ring() -> None:
    log = read_sonar_log(DATA / "example_log.txt", 16, units=LogUnits("mm", "mm", "deg"))
    geometry = SonarGeometry(tuple(math.radians(22.5 * k) for k in range(16)), max_range=5.0)
    pipeline = PIPELINES["default"]

    def run(wrap: bool) -> tuple[np.ndarray, np.ndarray, int]:
        grid = grid_for_poses(log.poses, geometry.max_range, 0.1)
        inner = pipeline.make_mapper(grid, geometry)
        assert isinstance(inner, ElfesMapper)
        mapper = _RingByRingMapper(inner) if wrap else inner
        out = map_log(
            log.poses, log.ranges, mapper, pipeline.make_filter(geometry), merge_repeats=False
        )
        rings = mapper.rings if isinstance(mapper, _RingByRingMapper) else -1
        return out.stage, mapper.probability(), rings

    stage, prob, rings = run(wrap=True)
    ref_stage, ref_prob, _ = run(wrap=False)
    assert rings > 0
    assert np.array_equal(stage, ref_stage)
    assert np.array_equal(prob, ref_prob)


def test_filter_keeps_the_recorded_verdicts_of_a_realistic_log() -> None:
    # tests/sonar/data/make_golden_verdicts.py wrote these (see there when): a rewrite for
    # speed must not change one verdict.
    recorded: dict[str, list[list[int]]] = {}
    for line in (DATA / "golden_verdicts.txt").read_text().splitlines():
        name, _, codes = line.split()
        recorded.setdefault(name, []).append([int(c) for c in codes])
    ring = SonarRing.pioneer(16)
    log = simulate_log(world("sonar-lcorridor-v2"), ring, Realism(laps=1), rng=3)
    for name, stages in recorded.items():
        filt = PIPELINES[name].make_filter(ring_geometry(ring))
        assert filt is not None
        n = len(stages)
        got = np.vstack(
            [
                filt.process_many(log.odometry[a:b], log.ranges[a:b]).stage
                for a, b in ((0, 333), (333, n))
            ]
        )
        assert np.count_nonzero(got == Stage.TRAIT_VERIFICATION) > 100  # L is in play
        assert np.array_equal(got, np.array(stages)), name


def test_filter_keeps_the_recorded_rejections_free_space_and_l_of_a_second_world() -> None:
    # tests/sonar/data/make_golden_rejections.py recorded a log of sonar-office-v2 and the
    # filter's whole outcome on it (see there when): a rewrite for speed must keep every
    # rejection with its reason, every free-space limit and every trait of L, value for value.
    maker = recorder("make_golden_rejections")
    recorded = np.load(DATA / "golden_rejections.npz")
    ring = SonarRing.pioneer(16)
    for name, options in maker.OPTIONS.items():
        filt = SpecularFilter(ring_geometry(ring), **options)
        got = maker.outcome(filt, recorded["poses"], recorded["ranges"])
        rejected = recorded[f"{name}/rejections"]
        assert np.count_nonzero(rejected[:, 2] == Stage.TRAIT_VERIFICATION) > 100  # L is in play
        for key, value in got.items():
            assert np.array_equal(value, recorded[f"{name}/{key}"]), (name, key)
    assert np.isfinite(recorded["keeping/free_limit"]).any()  # free space is stopped


def test_free_limit_stops_a_cones_free_space_but_not_its_echo() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), sigma=0.05, max_range=5.0)
    cells = OccupancyGrid(10, 10, 0.1, origin=(-5, -5)).world_to_cell([0.5, 1.5, 2.05], [0.05] * 3)

    def probabilities(free_limit: list[float] | None) -> np.ndarray:
        mapper = ElfesMapper(OccupancyGrid(10, 10, 0.1, origin=(-5, -5)), geometry)
        mapper.integrate([0.05, 0.05, 0.0], [2.0, 5.0], free_limit=free_limit)
        return np.asarray(mapper.probability()[cells])

    free, limited = probabilities(None), probabilities([1.0, math.inf])
    assert free[1] < 0.4 and limited[1] == 0.5  # beyond the limit: no free evidence
    assert limited[0] == free[0] < 0.4 and limited[2] == free[2] > 0.6
    ros = RosRangeLayerMapper(OccupancyGrid(10, 10, 0.1, origin=(-5, -5)), geometry)
    with pytest.raises(ConfigError, match="free-space limit"):
        ros.integrate([0.05, 0.05, 0.0], [2.0, 5.0], free_limit=[1.0, math.inf])


def test_an_echo_kept_behind_a_known_trait_stops_its_free_space_in_front_of_it() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi / 2, math.pi, -math.pi / 2), max_range=5.0)

    def judge(keep: bool) -> tuple[bool, float]:
        filt = SpecularFilter(
            geometry, acceptability=False, agreeability=False, keep_supported_echoes=keep
        )
        filt.path_ = 100.0  # enough state: case B
        # A wall 3 m ahead, and a trait of L 1.5 m ahead crossing the beam in front of it.
        _plant_l(filt, np.array([[3.0, -1.0, 3.0, 1.0], [1.5, -0.5, 1.5, 0.5]]), seen=100.0)
        verdict = filt.process([0.0, 0.0, 0.0], [3.0, 6.0, 6.0, 6.0])
        return bool(verdict.accepted[0]), float(verdict.free_limit[0])

    assert judge(False) == (False, math.inf)  # contradicted by the trait in front
    kept, limit = judge(True)
    assert kept and limit == pytest.approx(1.5 - 0.2)  # free space ends before that trait


def test_only_a_trait_seen_from_along_the_path_stops_a_kept_echoes_free_space() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi / 2, math.pi, -math.pi / 2), max_range=5.0)
    wall, person = [3.0, -1.0, 3.0, 1.0], [1.5, -0.5, 1.5, 0.5]

    def limit(person_first: float) -> float:
        filt = SpecularFilter(
            geometry,
            acceptability=False,
            agreeability=False,
            keep_supported_echoes=True,
            static_span=1.0,
        )
        filt.path_ = 100.0  # enough state: case B
        _plant_l(filt, np.array([wall, person]), seen=100.0, first=90.0)
        filt.l_first_[1] = person_first
        verdict = filt.process([0.0, 0.0, 0.0], [3.0, 6.0, 6.0, 6.0])
        assert verdict.accepted[0]  # the echo on the wall is kept either way
        return float(verdict.free_limit[0])

    assert limit(person_first=99.5) == math.inf  # seen over 0.5 m of path only: no stop
    assert limit(person_first=98.0) == pytest.approx(1.5 - 0.2)  # static: free space stops


def test_traits_of_l_remember_the_path_position_they_were_first_seen_at(
    corridor: Corridor,
) -> None:
    poses, scan, geometry = corridor
    filt = SpecularFilter(geometry)
    for a in range(0, len(poses), 25):
        filt.process_many(poses[a : a + 25], scan.ranges[a : a + 25])
        k = len(filt.l_segments_)
        assert len(filt.l_first_) == len(filt.l_seen_) == len(filt.l_passes_) == k
        assert np.all(filt.l_first_ <= filt.l_seen_) and np.all(filt.l_seen_ <= filt.path_)
    assert np.any(filt.l_seen_ - filt.l_first_ > 1.0)  # walls are re-seen along the path


def test_l_in_case_a_stops_free_space_and_judges_silence_before_enough_state() -> None:
    # Case A (the robot has barely moved): by the fragment, L is consulted only for flagged
    # or uncertain readings. With l_in_case_a a static trait of L within range stops a kept
    # echo's free space, and a silent reading whose axis crosses an oblique trait is a lost
    # echo.
    geometry = SonarGeometry(angles=(0.0, math.pi / 2, math.pi, -math.pi / 2), max_range=5.0)
    wall, front = [3.0, -1.0, 3.0, 1.0], [1.5, -0.5, 1.5, 0.5]
    oblique = [-1.0, 0.5, 1.0, 2.5]  # 45° across the axis of the reading facing +y

    def judge(l_in_case_a: bool) -> tuple[bool, float, bool]:
        filt = SpecularFilter(
            geometry,
            acceptability=False,
            agreeability=False,
            keep_supported_echoes=True,
            static_span=0.5,
            l_in_case_a=l_in_case_a,
        )
        filt.path_ = 2.0  # far less than four perceptual lengths: case A
        _plant_l(filt, np.array([wall, front, oblique]), seen=2.0, first=0.0)
        verdict = filt.process([0.0, 0.0, 0.0], [3.0, 6.0, 6.0, 6.0])
        assert not filt.enough_state
        return bool(verdict.accepted[0]), float(verdict.free_limit[0]), bool(verdict.accepted[1])

    assert judge(False) == (True, math.inf, True)
    kept, limit, silent_kept = judge(True)
    assert kept and limit == pytest.approx(1.5 - 0.2)
    assert not silent_kept


def test_no_echo_spread_none_means_the_cones_edges() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), beam_width=math.radians(30), max_range=5.0)
    assert SpecularFilter(geometry, no_echo_spread=None).no_echo_spread == pytest.approx(
        math.radians(15)
    )
    assert SpecularFilter(geometry, no_echo_spread=0.1).no_echo_spread == 0.1
