"""Tests of the forward-model refinement of the eq. 1 map and of the map's verdict."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from tests.sonar.helpers import DATA, pipelines_as_recorded, recorder

from bayesmap.errors import ConfigError, InputError
from bayesmap.grid import OccupancyGrid
from bayesmap.sonar import map_verdict
from bayesmap.sonar.filter import RingVerdict, Stage
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.map_verdict import (
    MapVerdict,
    clearance,
    first_surface,
    judge_by_map,
    transient_cells,
)
from bayesmap.sonar.mapping import ElfesMapper
from bayesmap.sonar.pipeline import PIPELINES, MapRun, map_log

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


def test_the_sweep_keeps_the_recorded_forward_maps_of_two_logs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # tests/sonar/data/make_golden_forward_map.py recorded two logs and the default
    # pipeline's map (then called ``forward``) made of them before the sweep and the cone
    # cells were rewritten for speed: every swept cell and verdict must stay the same, bit
    # for bit, and every log-odds value to rounding (with the symmetric arc the pipeline had
    # then). NumPy releases may sum in another order: with NumPy 2.4 about 3 % of the
    # values moved by at most 3e-14.
    pipelines_as_recorded(monkeypatch)
    maker = recorder("make_golden_forward_map")
    recorded = np.load(DATA / "golden_forward_map.npz")
    for world_name, _ in maker.LOGS:
        poses, ranges = recorded[f"{world_name}/poses"], recorded[f"{world_name}/ranges"]
        got = maker.mapped("default", poses, ranges)
        assert np.count_nonzero(got["log_odds"]) > 5000  # the log maps something
        for key, value in got.items():
            expected = recorded[f"{world_name}/{key}"]
            if key == "log_odds":
                assert np.allclose(value, expected, rtol=0.0, atol=1e-9), world_name
            else:
                assert np.array_equal(value, expected), (world_name, key)


def test_three_pipelines_keep_the_recorded_outcomes_of_a_log_of_thousands_of_rings(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # tests/sonar/data/make_golden_whole_log.py recorded (at a3c633a, before the outcomes
    # and the rejection log were kept as compact arrays and the map's verdict judged in
    # chunks) what default, streaming and paper return for a 3,158-ring log: every value
    # must stay the same (the log-odds to 1e-6, see there), with the verdict judged here
    # 500 rings at a time.
    monkeypatch.setattr(map_verdict, "_RINGS_PER_CHUNK", 500)
    pipelines_as_recorded(monkeypatch)
    maker = recorder("make_golden_whole_log")
    recorded = json.loads((DATA / "golden_whole_log.json").read_text())
    poses, ranges = maker.log()
    log = {"poses": maker.digest(poses), "ranges": maker.digest(ranges)}
    assert log == recorded["log"], "the simulator changed: rewrite the record at a3c633a"
    for name in maker.NAMES:
        assert maker.outcome(name, poses, ranges) == recorded[name], name


def _trace_across_the_axis() -> tuple[OccupancyGrid, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """A grid whose map is sure of a short trace 2.05 m in front of the origin (+x)."""
    grid = _grid()
    probability = np.full(grid.shape, 0.5)
    cells = grid.world_to_cell(np.full(5, 2.05), np.linspace(-0.2, 0.2, 5))
    probability[cells] = 0.999
    return grid, probability, cells


_ALONG_X = np.c_[np.linspace(0.0, 0.03, 4), np.zeros((4, 2))]  # four rings facing +x
_OBLIQUE = np.array([[2.05 - 2.0 * math.cos(0.5), -2.0 * math.sin(0.5), 0.5]])  # axis through it


def test_a_surface_a_silence_crossed_along_the_bearing_an_echo_found_it_from_is_transient() -> None:
    grid, probability, cells = _trace_across_the_axis()
    # Twice echoed along +x, then twice crossed along +x by silences: a person walked on.
    echoed_then_gone = np.array([[2.05, 6.0], [2.05, 6.0], [6.0, 6.0], [6.0, 6.0]])
    moved = transient_cells(
        probability, grid, FRONT_AND_BACK, _ALONG_X, echoed_then_gone, MapVerdict()
    )
    assert moved[cells].all()
    assert moved.sum() <= 25  # the trace and what leans occupied 0.2 m around it only
    # Echoed along +x, silent along a bearing 29° off: a wall seen obliquely, lost. It stays.
    poses = np.vstack([_ALONG_X[:2], _OBLIQUE, _OBLIQUE])
    oblique = np.array([[2.05, 6.0], [2.05, 6.0], [6.0, 6.0], [6.0, 6.0]])
    static = transient_cells(probability, grid, FRONT_AND_BACK, poses, oblique, MapVerdict())
    assert not static.any()
    # One pair is not enough for the default's two; a setting of 0 turns the test off.
    once = transient_cells(
        probability, grid, FRONT_AND_BACK, _ALONG_X[1:3], echoed_then_gone[1:3], MapVerdict()
    )
    off = MapVerdict(transient_pairs=0)
    assert not once.any()
    assert not transient_cells(
        probability, grid, FRONT_AND_BACK, _ALONG_X, echoed_then_gone, off
    ).any()


def test_the_verdict_does_not_call_a_silence_lost_on_a_trace_that_moved_on() -> None:
    grid, probability, _ = _trace_across_the_axis()
    poses = np.vstack([_ALONG_X, _OBLIQUE])
    ranges = np.array([[2.05, 6.0], [2.05, 6.0], [6.0, 6.0], [6.0, 6.0], [6.0, 6.0]])
    accepted = np.zeros(ranges.shape, dtype=bool)
    stage = np.full(ranges.shape, int(Stage.TRAIT_VERIFICATION))

    def judged(verdict: MapVerdict) -> tuple[bool, int]:
        ok, why = judge_by_map(
            probability, grid, FRONT_AND_BACK, poses, ranges, accepted, stage, verdict
        )
        return bool(ok[4, 0]), int(why[4, 0])

    # The oblique silence's cone holds the trace: a lost echo if the trace were a surface,
    # open space once the silences along +x showed it gone.
    assert judged(MapVerdict(transient_pairs=0)) == (False, Stage.MAP_VERDICT)
    assert judged(MapVerdict()) == (True, Stage.ACCEPTED)


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


def test_a_sweeps_silences_stop_at_a_surface_the_echoes_alone_hold() -> None:
    """Three echoes of a wall 0.8 m ahead, then ten silences (its echo lost): the pass's
    silences clear the wall, so the pass's map no longer holds it and a sweep that stops
    free space at that map's surfaces clears it too; with ``forward_echo_stop`` the
    silences stop at the wall the echoes alone hold, and its far side stays occupied."""
    grid = OccupancyGrid(10.0, 4.0, 0.05, origin=(-3.0, -2.0))

    def mapped(echo_stop: bool) -> tuple[np.ndarray, np.ndarray]:
        mapper = ElfesMapper(
            grid,
            FRONT_AND_BACK,
            no_echo="clear",
            clear_distance=1.0,
            forward_sweeps=1,
            forward_free_stop=True,
            forward_echo_stop=echo_stop,
        )
        for _ in range(3):
            mapper.integrate([0.0, 0.0, 0.0], [0.8, 6.0])
        for _ in range(10):
            mapper.integrate([0.0, 0.0, 0.0], [6.0, 6.0])
        streaming = mapper.log_odds_.copy()
        mapper.sync()
        assert mapper.echo_reference_ is None  # kept for the sweep only
        return streaming, mapper.log_odds_.copy()

    wall, near = grid.world_to_cell(0.85, 0.0), grid.world_to_cell(0.65, 0.0)
    streaming, plain = mapped(False)
    assert streaming[wall] < 0 and plain[wall] < 0  # the lost echoes erased the wall
    streaming_too, stopped = mapped(True)
    assert np.array_equal(streaming_too, streaming)  # the pass is the same
    assert stopped[wall] > 0  # the silences stopped at the wall the echoes hold
    assert stopped[near] == plain[near] < 0  # and still cleared the space before it


def test_the_first_surface_is_found_only_inside_the_cone_and_within_reach() -> None:
    grid = _grid()
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied[grid.world_to_cell(3.0, 0.5)] = True  # 9.5° off the +x axis, 3.04 m away
    occupied[grid.world_to_cell(4.5, 0.0)] = True  # on the axis, 4.5 m away
    free_distance = clearance(occupied, grid)
    centres = np.zeros((4, 2))
    axis = np.array([0.0, math.pi, 0.0, 0.0])
    reach = np.array([5.0, 5.0, 2.5, 5.0])
    half = np.radians([12.5, 12.5, 12.5, 4.0])
    found = [
        first_surface(
            free_distance, grid, centres[i : i + 1], axis[i : i + 1], reach[i : i + 1], half[i]
        )[0]
        for i in range(4)
    ]
    assert 2.9 <= found[0] <= 3.25  # to within a cell or two
    assert found[1] == np.inf and found[2] == np.inf  # behind the transducer; beyond the reach
    assert 4.3 <= found[3] <= 4.65  # a narrower cone passes the point 9.5° off


def _wall_ahead() -> tuple[OccupancyGrid, np.ndarray]:
    """A grid holding a wall 3 m in front of the origin (+x) and nothing behind it."""
    grid = _grid()
    probability = np.full(grid.shape, 0.5)
    rows, cols = grid.world_to_cell(np.full(9, 3.0), np.linspace(-0.4, 0.4, 9))
    probability[rows, cols] = 0.999
    return grid, probability


def test_the_map_rejects_silences_facing_a_wall_it_is_sure_of_and_keeps_the_rest() -> None:
    grid, probability = _wall_ahead()
    poses = np.zeros((3, 3))
    ranges = np.array([[6.0, 6.0], [6.0, 6.0], [2.0, 6.0]])
    accepted = np.array([[True, False], [False, False], [False, True]])
    stage = np.where(accepted, int(Stage.ACCEPTED), int(Stage.TRAIT_VERIFICATION))
    stage[1, 0] = int(Stage.AGREEABILITY)  # the bottom-up stages' rejections stand
    ok, why = judge_by_map(
        probability, grid, FRONT_AND_BACK, poses, ranges, accepted, stage, MapVerdict()
    )
    # Facing the wall, silent: a lost echo; facing nothing, silent: open space.
    assert not ok[0, 0] and why[0, 0] == Stage.MAP_VERDICT
    assert ok[0, 1] and why[0, 1] == Stage.ACCEPTED and ok[1, 1]
    assert not ok[1, 0] and why[1, 0] == Stage.AGREEABILITY
    # An echo before the wall has nothing in its way: kept although the filter rejected it.
    assert ok[2, 0] and why[2, 0] == Stage.ACCEPTED


def test_an_echo_beyond_a_wall_the_map_is_sure_of_keeps_the_filters_verdict() -> None:
    grid, probability = _wall_ahead()
    ranges = np.array([[4.5, 6.0], [4.5, 6.0]])  # 1.5 m beyond the wall: a bounce
    accepted = np.array([[False, True], [True, True]])
    stage = np.where(accepted, int(Stage.ACCEPTED), int(Stage.TRAIT_VERIFICATION))
    ok, why = judge_by_map(
        probability, grid, FRONT_AND_BACK, np.zeros((2, 3)), ranges, accepted, stage, MapVerdict()
    )
    assert ok[:, 0].tolist() == [False, True]
    assert why[0, 0] == Stage.TRAIT_VERIFICATION


@pytest.mark.parametrize(
    "bad",
    [
        {"silence_confidence": 0.3},
        {"echo_confidence": 1.0},
        {"silence_width": 0.0},
        {"echo_margin": -0.1},
        {"transient_pairs": -1},
        {"transient_pairs": 1.5},
        {"transient_bearing": 0.0},
        {"transient_spread": -0.1},
    ],
)
def test_bad_map_verdict_settings_are_refused(bad: dict[str, float]) -> None:
    with pytest.raises(ConfigError, match="map verdict"):
        MapVerdict(**bad)  # type: ignore[arg-type]


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


_CREEPING = np.c_[np.linspace(0.0, 0.11, 12), np.zeros((12, 2))]  # no ring repeats another
_WALL_THEN_SILENCE = np.array([[2.0, 6.0]] * 8 + [[6.0, 6.0]] * 4)


def _judged_log(verdict: MapVerdict | None) -> tuple[ElfesMapper, object]:
    mapper = ElfesMapper(
        _grid(), FRONT_AND_BACK, no_echo="clear", clear_distance=1.0, forward_sweeps=1
    )
    run = map_log(
        _CREEPING,
        _WALL_THEN_SILENCE,
        mapper,
        _RejectEverySilence(),  # type: ignore[arg-type]
        map_verdict=verdict,
    )
    return mapper, run


def test_map_log_judges_every_ring_by_the_map_the_pass_ended_with() -> None:
    # (Silences along the bearing the wall echoed along would show it gone: counted off.)
    judging = MapVerdict(silence_confidence=0.9, remap=False, transient_pairs=0)
    mapper, run = _judged_log(judging)
    accepted, stage = run.accepted, run.stage  # type: ignore[attr-defined]
    # The silences facing the wall the echoes built lost their echo; those behind saw nothing.
    assert not accepted[8:, 0].any() and (stage[8:, 0] == Stage.MAP_VERDICT).all()
    assert accepted[:, 1].all() and accepted[:8, 0].all()
    # Without remap the verdict only labels the readings: the map is the filter's.
    plain, _ = _judged_log(None)
    assert np.array_equal(mapper.probability(), plain.probability())


def test_with_remap_the_sweep_maps_the_readings_the_map_kept() -> None:
    remapped, _ = _judged_log(MapVerdict(silence_confidence=0.9, remap=True))
    labelled, _ = _judged_log(MapVerdict(silence_confidence=0.9, remap=False))
    behind = remapped.grid.world_to_cell(-0.8, 0.0)  # only the kept rear silences clear it
    assert labelled.probability()[behind] == 0.5
    assert remapped.probability()[behind] < 0.5


def test_remask_refuses_a_mask_of_the_wrong_shape() -> None:
    mapper = ElfesMapper(_grid(), FRONT_AND_BACK, forward_sweeps=1)
    mapper.integrate([0.0, 0.0, 0.0], [2.0, 6.0])
    with pytest.raises(InputError, match="stored rings"):
        mapper.remask(np.ones((2, 2), dtype=bool))


class _RejectLastSilences:
    """A stand-in filter: Trait Verification rejects the silences of the last three rings."""

    def process_many(self, poses: np.ndarray, ranges: np.ndarray) -> RingVerdict:
        ring = np.rint(poses[:, 0] / 0.01).astype(int)[:, None]  # _CREEPING moves 1 cm a ring
        rejected = (ranges >= 5.0) & (ring >= 9)
        return RingVerdict(
            accepted=~rejected,
            flagged=np.zeros(ranges.shape, dtype=bool),
            stage=np.where(rejected, int(Stage.TRAIT_VERIFICATION), int(Stage.ACCEPTED)),
            free_limit=np.full(ranges.shape, np.inf),
        )


def _forward_run(front: list[float], verdict: MapVerdict) -> tuple[ElfesMapper, MapRun]:
    """The creeping log with ``front`` ranges ahead and silence behind, mapped as ``default``.

    The filter keeps every reading but the silences of the last three rings.
    """
    mapper = ElfesMapper(
        _grid(),
        FRONT_AND_BACK,
        no_echo="clear",
        clear_distance=1.0,
        forward_sweeps=1,
        forward_free_stop=True,
        forward_no_echo=3.0,
    )
    ranges = np.c_[front, np.full(len(front), 6.0)]
    run = map_log(_CREEPING, ranges, mapper, _RejectLastSilences(), map_verdict=verdict)  # type: ignore[arg-type]
    return mapper, run


_PASSER_BY = [2.0] * 3 + [6.0] * 9  # someone 2 m ahead for three rings, then open space
# Every reading of these logs looks along one bearing: silences there after echoes show a
# surface gone (transient_cells, tested above), which is counted off here.
_JUDGE = MapVerdict(silence_confidence=0.9, open_confidence=0.9, transient_pairs=0)


def test_a_silence_facing_a_transient_trace_is_judged_open_by_the_refined_map() -> None:
    # The streaming map (kept silences clear 1 m) keeps the passer-by's trace at 2 m: judged
    # by it, the rejected silences of the last rings would stay rejected, as lost echoes.
    _, streaming = _forward_run(_PASSER_BY, replace(_JUDGE, remap=True))
    assert not streaming.accepted[9:, 0].any()
    assert (streaming.stage[9:, 0] == Stage.MAP_VERDICT).all()
    # In the refined map the kept silences (clearing 3 m) have erased the trace: open space.
    mapper, refined = _forward_run(_PASSER_BY, _JUDGE)
    assert mapper.probability()[mapper.grid.world_to_cell(2.0, 0.0)] < 0.5
    assert refined.accepted[9:, 0].all()
    assert (refined.stage[9:, 0] == Stage.ACCEPTED).all()


def test_a_silence_facing_a_wall_seen_again_and_again_stays_a_lost_echo() -> None:
    mapper, run = _forward_run(_WALL_THEN_SILENCE[:, 0].tolist(), _JUDGE)
    assert mapper.probability()[mapper.grid.world_to_cell(2.0, 0.0)] > 0.9
    assert not run.accepted[9:, 0].any()
    assert (run.stage[9:, 0] == Stage.MAP_VERDICT).all()


def test_the_refined_verdict_is_the_same_every_time() -> None:
    first_map, first = _forward_run(_PASSER_BY, _JUDGE)
    second_map, second = _forward_run(_PASSER_BY, _JUDGE)
    assert np.array_equal(first.accepted, second.accepted)
    assert np.array_equal(first_map.probability(), second_map.probability())
