"""Tests of split-and-merge traits and of Trait Verification's pieces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayesmap.sim.sonar import cast_rays
from bayesmap.sonar.traits import fit_line, fit_traits, point_segment_distance
from bayesmap.sonar.verification import (
    TVReason,
    axis_segment_hits,
    certainty,
    equivalent,
    extend_segments,
    head_on,
    reconcile,
)


def test_fit_line_recovers_direction_of_noisy_points() -> None:
    rng = np.random.default_rng(1)
    t = np.linspace(0, 3, 40)
    angle = 0.7
    pts = np.column_stack([t * math.cos(angle), t * math.sin(angle)]) + rng.normal(0, 0.01, (40, 2))
    _, direction = fit_line(pts)
    assert abs(abs(direction @ [math.cos(angle), math.sin(angle)]) - 1) < 1e-3


def test_split_and_merge_finds_two_walls_of_a_corner_and_leaves_outliers() -> None:
    rng = np.random.default_rng(2)
    a = np.column_stack([np.linspace(0, 2, 15), np.full(15, 2.0)])
    b = np.column_stack([np.full(15, 2.0), np.linspace(1.9, 0, 15)])
    pts = np.vstack([a, b]) + rng.normal(0, 0.005, (30, 2))
    traits = fit_traits(pts, tolerance=0.05, min_points=4, max_gap=0.5)
    assert len(traits.segments) == 2
    assert set(traits.labels[:14].tolist()) == {0} and set(traits.labels[16:].tolist()) == {1}
    assert np.nanmax(traits.residuals) <= 0.05
    lone = fit_traits(np.array([[0.0, 0.0], [5.0, 5.0], [10.0, 0.0]]), max_gap=1.0)
    assert len(lone.segments) == 0 and np.all(lone.labels == -1)


def test_merge_joins_collinear_pieces_around_an_outlier() -> None:
    wall = np.column_stack([np.linspace(0, 3, 13), np.zeros(13)])
    pts = np.vstack([wall[:6], [[1.4, 0.4]], wall[6:]])
    traits = fit_traits(pts, tolerance=0.05, min_points=3, max_gap=1.0)
    assert len(traits.segments) == 1
    assert traits.labels[6] == -1 and np.all(np.delete(traits.labels, 6) == 0)


def test_point_segment_distance_against_hand_values() -> None:
    seg = np.array([[0.0, 0.0, 2.0, 0.0]])
    d = point_segment_distance(np.array([[1.0, 1.0], [3.0, 0.0], [-1.0, -1.0]]), seg)[:, 0]
    assert d.tolist() == pytest.approx([1.0, 1.0, math.sqrt(2)])


def test_axis_segment_hits_agree_with_the_simulators_ray_caster() -> None:
    rng = np.random.default_rng(3)
    segments = rng.uniform(-5, 5, (12, 4))
    centres = rng.uniform(-5, 5, (50, 2))
    axis = rng.uniform(-math.pi, math.pi, 50)
    mine = axis_segment_hits(centres, axis, segments).min(axis=1)
    theirs, _ = cast_rays(centres, np.column_stack([np.cos(axis), np.sin(axis)]), segments)
    assert np.allclose(mine, theirs)


def test_equivalence_needs_angle_offset_and_overlap() -> None:
    ell = np.array([[0.0, 0.0, 4.0, 0.0]])
    v = np.array(
        [
            [1.0, 0.05, 2.0, 0.08],  # same wall
            [1.0, 0.5, 2.0, 0.5],  # parallel, too far
            [1.0, 0.0, 2.0, 1.0],  # 45°
            [6.0, 0.0, 7.0, 0.0],  # collinear, no overlap
        ]
    )
    match = equivalent(v, ell, match_angle=math.radians(10), match_offset=0.2)[:, 0]
    assert match.tolist() == [True, False, False, False]
    assert equivalent(v[3:], extend_segments(ell, 2.5), match_angle=0.2, match_offset=0.2)[0, 0]


def test_certainty_is_one_on_the_line_and_falls_with_residual() -> None:
    c = certainty(
        np.array([0.0, 0.02, 0.2, np.nan]),
        np.array([1.0, 1.0, 1.0, 1.0]),
        sigma=0.02,
        half_width=math.radians(12.5),
    )
    assert c[0] == 1.0 and 0.5 < c[1] < 1.0 and c[2] < 0.01 and np.isnan(c[3])


def _reconcile(enough: bool, **over: object) -> np.ndarray:
    # Four readings facing +y at a wall y = 2 known to L: 0 on a V trait that matches L,
    # 1 an echo far beyond the wall (contradicts L), 2 a no-echo reading, 3 a loose echo on L.
    base = {
        "candidate": np.ones(4, bool),
        "echo": np.array([True, True, False, True]),
        "flagged": np.zeros(4, bool),
        "ranges": np.array([2.0, 4.0, 5.0, 2.0]),
        "centres": np.column_stack([np.arange(4.0), np.zeros(4)]),
        "axis": np.full(4, math.pi / 2),
        "labels": np.array([0, -1, -1, -1]),
        "certainties": np.array([0.9, np.nan, np.nan, np.nan]),
        "v_segments": np.array([[-0.5, 2.0, 0.5, 2.0]]),
        "l_segments": np.array([[-1.0, 2.0, 5.0, 2.0]]),
        "enough_state": enough,
        "max_range": 5.0,
        "certainty_threshold": 0.5,
        "match_angle": math.radians(10),
        "match_offset": 0.2,
        "margin": 0.3,
    }
    base.update(over)
    return reconcile(**base)  # type: ignore[arg-type]


def test_case_a_discards_only_flagged_or_uncertain_readings_without_support() -> None:
    assert _reconcile(False).tolist() == [TVReason.KEPT] * 4
    flagged = np.array([True, True, True, True])
    reason = _reconcile(False, flagged=flagged)
    assert reason.tolist() == [
        TVReason.KEPT,
        TVReason.UNSUPPORTED_FLAGGED,
        TVReason.UNSUPPORTED_FLAGGED,
        TVReason.KEPT,
    ]
    lonely = _reconcile(
        False, certainties=np.array([0.1, np.nan, np.nan, np.nan]), l_segments=np.zeros((0, 4))
    )
    assert lonely[0] == TVReason.UNSUPPORTED_UNCERTAIN


def test_case_b_discards_contradictions_and_flagged_uncertain_matches() -> None:
    reason = _reconcile(True)
    assert reason.tolist() == [
        TVReason.KEPT,
        TVReason.CONTRADICTS_L,
        TVReason.CONTRADICTS_L,
        TVReason.KEPT,
    ]
    reason = _reconcile(
        True,
        flagged=np.array([True, False, False, False]),
        certainties=np.array([0.2, np.nan, np.nan, np.nan]),
    )
    assert reason[0] == TVReason.FLAGGED_UNCERTAIN
    reason = _reconcile(True, candidate=np.array([True, False, False, True]))
    assert reason.tolist() == [TVReason.KEPT] * 4


def test_an_echo_that_lands_on_l_can_be_kept_despite_a_trait_in_front() -> None:
    # A second known trait at y = 1 (say an extended trait poking across the axes) lies in
    # front of the wall y = 2: by default every reading through it is contradicted; with
    # keep_supported_echoes the echoes that land on the wall agree with L and stay; the
    # phantom at 4 m (on no trait) and the silent reading still claim free space through it.
    two_walls = np.array([[-1.0, 2.0, 5.0, 2.0], [-1.0, 1.0, 5.0, 1.0]])
    assert _reconcile(True, l_segments=two_walls).tolist() == [TVReason.CONTRADICTS_L] * 4
    reason = _reconcile(True, l_segments=two_walls, keep_supported_echoes=True)
    assert reason.tolist() == [
        TVReason.KEPT,
        TVReason.CONTRADICTS_L,
        TVReason.CONTRADICTS_L,
        TVReason.KEPT,
    ]
    # Without the wall at y = 2 in L, the same echoes are contradicted by the trait at y = 1.
    only_front = _reconcile(True, l_segments=two_walls[1:], keep_supported_echoes=True)
    assert only_front.tolist() == [TVReason.CONTRADICTS_L] * 4
    # Only an anchor (a trait of L that looks like static structure) keeps an echo so: the
    # same echoes, supported only by a wall that is not an anchor, are contradicted.
    anchored = _reconcile(
        True, l_segments=two_walls, keep_supported_echoes=True, anchors=np.array([True, False])
    )
    assert anchored.tolist() == reason.tolist()
    unanchored = _reconcile(
        True, l_segments=two_walls, keep_supported_echoes=True, anchors=np.array([False, True])
    )
    assert unanchored.tolist() == [TVReason.CONTRADICTS_L] * 4


def test_case_a_can_discard_silence_through_an_oblique_known_wall() -> None:
    # contradict_in_case_a: in case A an unflagged no-echo reading whose axis crosses a trait
    # of L is discarded (its echo was lost), while the unflagged echo beyond the wall keeps
    # the fragment's case A verdict (kept); a wall the silent axis meets head-on would have
    # echoed, so with the critical angle given it does not contradict the silence.
    reason = _reconcile(False, contradict_in_case_a=True)
    assert reason.tolist() == [
        TVReason.KEPT,
        TVReason.KEPT,
        TVReason.CONTRADICTS_L,
        TVReason.KEPT,
    ]
    head_on_wall = _reconcile(False, contradict_in_case_a=True, critical_angle=math.radians(15))
    assert head_on_wall.tolist() == [TVReason.KEPT] * 4
    # A wall at 45° to the silent axis (from (1, 1) to (3, 3)) is too oblique to echo.
    oblique = np.array([[1.0, 1.0, 3.0, 3.0]])
    reason = _reconcile(
        False, contradict_in_case_a=True, critical_angle=math.radians(15), l_segments=oblique
    )
    assert reason[2] == TVReason.CONTRADICTS_L


def test_one_point_repeated_is_not_a_trait() -> None:
    # A standing robot: one echo point, jittering by a millimetre, six times.
    standing = np.array([[1.0, 2.0]] * 2 + [[1.001, 2.0]] * 2 + [[1.002, 2.0]] * 2)
    assert len(fit_traits(standing).segments) == 1  # counted as points, it is a "line"
    assert len(fit_traits(standing, min_spacing=0.05).segments) == 0
    wall = np.column_stack([np.linspace(0.0, 0.2, 4), np.ones(4)])
    assert len(fit_traits(wall, min_length=0.3).segments) == 0
    assert len(fit_traits(wall, min_length=0.1).segments) == 1


def test_short_traits_are_equivalent_to_nothing_far_away() -> None:
    point = np.array([[0.0, 0.0, 0.0, 0.0]])
    far_wall = np.array([[70.0, 0.01, 75.0, 0.01]])
    assert not equivalent(point, far_wall, match_angle=0.2, match_offset=0.2).any()
    assert not equivalent(far_wall, point, match_angle=0.2, match_offset=0.2).any()
    # A wall seen again a little further along still matches ...
    near = np.array([[1.0, 0.05, 3.0, 0.05]])
    wall = np.array([[0.0, 0.0, 2.0, 0.0]])
    assert equivalent(near, wall, match_angle=0.2, match_offset=0.2).all()
    # ... but one that only shares the line, not a stretch of it, does not.
    beyond = np.array([[2.5, 0.0, 4.0, 0.0]])
    assert not equivalent(beyond, wall, match_angle=0.2, match_offset=0.2).any()


@pytest.mark.parametrize("tilt_deg", [0.0, 10.0, 14.0, 16.0, 40.0, 89.0])
def test_head_on_is_incidence_within_the_critical_angle(tilt_deg: float) -> None:
    # A wall along y at x = 2, rotated by tilt; the beam runs along x, so the incidence
    # off the wall's normal is the tilt, whichever way the segment is drawn.
    t = math.radians(tilt_deg)
    wall = np.array([[2 - math.sin(t), math.cos(t), 2 + math.sin(t), -math.cos(t)]])
    expected = tilt_deg <= 15.0
    assert head_on(np.array([0.0]), wall, math.radians(15.0))[0, 0] == expected
    assert head_on(np.array([math.pi]), wall[:, [2, 3, 0, 1]], math.radians(15.0))[0, 0] == expected
