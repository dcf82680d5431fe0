"""Tests of the forward-model refinement of the eq. 1 map and of judging silences by the map."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bayesmap.errors import ConfigError
from bayesmap.grid import OccupancyGrid
from bayesmap.sonar.filter import RingVerdict, Stage
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.mapping import ElfesMapper, surface_in_cone
from bayesmap.sonar.pipeline import PIPELINES, map_log

FRONT_AND_BACK = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)


def _grid() -> OccupancyGrid:
    return OccupancyGrid(10.0, 4.0, 0.1, origin=(-3.0, -2.0))


def test_a_sweep_explains_away_an_early_echo_with_the_whole_logs_map() -> None:
    side = (2.97, 0.42)  # on the 3 m arc, 8° off the axis
    unseen = (2.97, -0.42)  # on the arc's other side, outside the later beams

    def mapped(sweeps: int) -> tuple[float, float]:
        grid = _grid()
        mapper = ElfesMapper(
            grid,
            FRONT_AND_BACK,
            no_echo="ignore",
            explain_away=1.0,
            forward_sweeps=sweeps,
            forward_beyond=0.0,
        )
        mapper.integrate([0.0, 0.0, 0.0], [3.0, 6.0])  # the echo comes first: nothing known yet
        for _ in range(3):  # then a beam runs through the side cell to a wall 4.5 m on
            mapper.integrate([0.0, side[1], 0.0], [4.5, 6.0])
        mapper.sync()
        odds = mapper.log_odds_
        return float(odds[grid.world_to_cell(*side)]), float(odds[grid.world_to_cell(*unseen)])

    streaming_side, streaming_unseen = mapped(0)
    refined_side, refined_unseen = mapped(1)
    # Streaming, the side cell took the echo's full weight (the map was empty then); the
    # sweep sees the later beams and moves the echo's weight off it, not off the unseen cell.
    assert refined_side < streaming_side - 0.2
    assert refined_unseen > 0.85 * streaming_unseen


def test_a_sweep_stops_free_space_at_the_first_surface_the_map_holds() -> None:
    behind = (3.0, 0.0)  # between a wall at 2 m and a phantom echo at 4 m

    def mapped(**options: float | bool) -> float:
        grid = _grid()
        mapper = ElfesMapper(grid, FRONT_AND_BACK, no_echo="ignore", **options)  # type: ignore[arg-type]
        for _ in range(8):
            mapper.integrate([0.0, 0.0, 0.0], [2.0, 6.0])  # the wall, head-on
        for _ in range(2):
            mapper.integrate([0.0, 0.0, 0.0], [4.0, 6.0])  # a bounce that claims to see through
        mapper.sync()
        return float(mapper.log_odds_[grid.world_to_cell(*behind)])

    assert mapped() < -0.5  # the inverse model clears behind the wall
    assert mapped(forward_sweeps=1) < -0.5
    assert mapped(forward_sweeps=1, forward_free_stop=True) == 0.0  # the beam stopped at it


def test_a_sweep_clears_silent_cones_up_to_the_first_held_surface() -> None:
    geometry = SonarGeometry(angles=(0.0, math.pi), max_range=5.0)
    near, far, beyond_wall = (0.8, 0.0), (2.5, 0.0), (-3.5, 0.0)
    grid = OccupancyGrid(12.0, 4.0, 0.1, origin=(-6.0, -2.0))
    mapper = ElfesMapper(
        grid,
        geometry,
        no_echo="clear",
        clear_distance=1.0,
        forward_sweeps=1,
        forward_free_stop=True,
        forward_no_echo=4.5,
    )
    for _ in range(5):  # the rear beam sees a wall 3 m behind; the front one is silent
        mapper.integrate([0.0, 0.0, 0.0], [6.0, 3.0])
    streaming = mapper.log_odds_.copy()
    mapper.sync()
    odds = mapper.log_odds_
    at = grid.world_to_cell
    assert streaming[at(*near)] < 0 and streaming[at(*far)] == 0.0  # streaming clears 1 m
    assert odds[at(*near)] < 0 and odds[at(*far)] < 0  # the sweep clears the silent cone on
    # The wall the map holds stays, and nothing behind it hears the front silence.
    assert odds[at(-3.0, 0.0)] > 0 and odds[at(*beyond_wall)] == streaming[at(*beyond_wall)]


def test_refinement_is_the_same_however_the_rings_were_batched_and_runs_once() -> None:
    rng = np.random.default_rng(4)
    poses = np.column_stack([np.linspace(0, 3, 30), np.zeros(30), np.linspace(0, 1, 30)])
    ranges = rng.uniform(0.5, 6.0, (30, 2))
    pipeline = replace(PIPELINES["elfes"], forward_sweeps=2, forward_free_stop=True)
    mappers = [pipeline.make_mapper(_grid(), FRONT_AND_BACK) for _ in range(2)]
    mappers[0].integrate_many(poses, ranges)  # type: ignore[attr-defined]
    for pose, r in zip(poses, ranges, strict=True):
        mappers[1].integrate(pose, r)
    first = mappers[0].sync().probability.copy()
    assert np.array_equal(first, mappers[1].sync().probability)
    assert np.array_equal(first, mappers[0].sync().probability)  # a second sync adds nothing
    assert mappers[0].rings_ == 30  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    "bad",
    [
        {"forward_sweeps": -1},
        {"forward_gamma": 0.0},
        {"forward_beyond": -1.0},
        {"forward_no_echo": 9.0},
    ],
)
def test_bad_refinement_settings_are_refused(bad: dict[str, float]) -> None:
    with pytest.raises(ConfigError, match="forward"):
        ElfesMapper(_grid(), FRONT_AND_BACK, **bad)  # type: ignore[arg-type]


def test_a_cone_meets_a_held_surface_only_where_one_is() -> None:
    grid = _grid()
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied[grid.world_to_cell(3.0, 0.5)] = True  # 9.5° off the +x axis, inside a 25° cone
    centres = np.zeros((3, 2))
    axis = np.array([0.0, math.pi, 0.0])
    reach = np.array([5.0, 5.0, 2.5])
    half = math.radians(12.5)
    found = [
        bool(
            surface_in_cone(occupied, grid, centres[i : i + 1], axis[i : i + 1], reach[i], half)[0]
        )
        for i in range(3)
    ]
    assert found == [True, False, False]


class _RejectEverySilence:
    """A stand-in filter: Trait Verification rejects every silence, keeps every echo."""

    def process_many(self, poses: np.ndarray, ranges: np.ndarray) -> RingVerdict:
        silent = ranges >= 5.0
        return RingVerdict(
            accepted=~silent,
            flagged=np.zeros(ranges.shape, dtype=bool),
            stage=np.where(silent, int(Stage.TRAIT_VERIFICATION), int(Stage.ACCEPTED)),
            free_limit=np.full(ranges.shape, np.inf),
        )


def test_silences_judged_by_the_map_are_kept_where_it_holds_nothing() -> None:
    mapper = ElfesMapper(_grid(), FRONT_AND_BACK, no_echo="clear", clear_distance=1.0)
    poses = np.zeros((4, 3))
    ranges = np.array([[2.0, 6.0]] * 2 + [[6.0, 6.0]] * 2)  # a wall ahead, then silence
    run = map_log(poses, ranges, mapper, _RejectEverySilence(), silences_by_map=True)  # type: ignore[arg-type]
    # One batch: the map before it is empty, so no silence is explained by a surface.
    assert run.accepted[:, 1].all() and run.accepted[2:, 0].all()
    assert (run.stage == Stage.ACCEPTED).all()
    ahead = mapper.surface_ahead(poses[2:], ranges[2:])
    assert ahead[:, 0].all() and not ahead[:, 1].any()  # now the wall ahead is held
    plain = map_log(poses, ranges, ElfesMapper(_grid(), FRONT_AND_BACK), _RejectEverySilence())  # type: ignore[arg-type]
    assert not plain.accepted[:, 1].any()
