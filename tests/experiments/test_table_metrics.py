"""Matching, GOSPA and the run scores of the table-mapping experiment."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from bayesmap.experiments.table_metrics import (
    MatchTolerance,
    angle_difference,
    gospa,
    match_tables,
    near_wall,
    pose_distance,
    recall_by_support,
    score_run,
)

TOL = MatchTolerance()
C = TOL.c


def _gospa_brute_force(x, y, tol=TOL):
    """GOSPA (α = 2) by enumerating every partial assignment."""
    best = math.inf
    m, n = len(x), len(y)
    d = pose_distance(x, y, tol.angle_scale) if m and n else np.zeros((m, n))
    for k in range(min(m, n) + 1):
        for rows in itertools.combinations(range(m), k):
            for cols in itertools.permutations(range(n), k):
                cost = sum(min(d[i, j], tol.c) ** tol.p for i, j in zip(rows, cols, strict=True))
                cost += tol.c**tol.p / 2 * (m + n - 2 * k)
                best = min(best, cost)
    return best ** (1 / tol.p)


def test_angle_difference_respects_the_half_turn_symmetry():
    assert angle_difference(0.3, 0.3 + np.pi) == pytest.approx(0.0, abs=1e-12)
    assert angle_difference(0.0, np.pi / 2) == pytest.approx(np.pi / 2)
    assert angle_difference(0.1, np.pi - 0.1) == pytest.approx(0.2)
    values = angle_difference(np.linspace(-10, 10, 101), 0.7)
    assert np.all((values >= 0) & (values <= np.pi / 2 + 1e-12))


def test_match_tolerances_and_symmetry():
    truth = np.array([[2.0, 2.0, 0.4]])
    assert len(match_tables(np.array([[2.0, 2.19, 0.4 + np.pi]]), truth)[0]) == 1
    assert len(match_tables(np.array([[2.0, 2.21, 0.4]]), truth)[0]) == 0
    assert len(match_tables(np.array([[2.0, 2.0, 0.4 + np.radians(14)]]), truth)[0]) == 1
    assert len(match_tables(np.array([[2.0, 2.0, 0.4 + np.radians(16)]]), truth)[0]) == 0
    assert len(match_tables(np.array([[2.0, 2.0, 0.4 + np.pi / 2]]), truth)[0]) == 0


def test_matching_is_one_to_one_and_optimal():
    truth = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])
    est = np.array([[0.15, 0.0, 0.0], [0.35, 0.0, 0.0], [0.02, 0.0, 0.0]])
    i, j = match_tables(est, truth)
    assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == [(1, 1), (2, 0)]


def test_gospa_hand_cases():
    t = np.array([[1.0, 1.0, 0.2]])
    assert gospa(np.zeros((0, 3)), np.zeros((0, 3))) == 0.0
    assert gospa(t, np.zeros((0, 3))) == pytest.approx(C / math.sqrt(2))
    assert gospa(np.zeros((0, 3)), t) == pytest.approx(C / math.sqrt(2))
    assert gospa(t, t) == pytest.approx(0.0)
    assert gospa(t + [0.3, 0.0, 0.0], t) == pytest.approx(0.3)
    assert gospa(t + [0.0, 0.0, np.pi], t) == pytest.approx(0.0, abs=1e-12)
    assert gospa(t + [0.0, 0.0, 0.1], t) == pytest.approx(TOL.angle_scale * 0.1)
    assert gospa(t + [2.0, 0.0, 0.0], t) == pytest.approx(C)
    two = np.array([[1.0, 1.0, 0.2], [4.0, 4.0, 1.0]])
    assert gospa(t, two) == pytest.approx(C / math.sqrt(2))


def test_gospa_equals_brute_force_and_is_a_metric():
    rng = np.random.default_rng(5)
    sets = [
        np.column_stack([rng.uniform(0, 1.5, (k, 2)), rng.uniform(0, np.pi, k)])
        for k in (0, 1, 2, 3, 1, 2, 4, 3)
    ]
    for x, y in itertools.product(sets, repeat=2):
        assert gospa(x, y) == pytest.approx(_gospa_brute_force(x, y))
        assert gospa(x, y) == pytest.approx(gospa(y, x))
    for x, y, z in itertools.product(sets[:6], repeat=3):
        assert gospa(x, z) <= gospa(x, y) + gospa(y, z) + 1e-12


def test_near_wall():
    tables = np.array([[0.5, 3.0, 0.0], [3.0, 3.0, 0.0], [3.0, 5.9, 0.0], [-0.4, 3.0, 0.0]])
    np.testing.assert_array_equal(near_wall(tables, (0, 0, 6, 6), 1.2), [True, False, True, True])


def test_score_run_by_hand():
    truth = np.array([[2.0, 2.0, 0.0], [4.0, 4.0, 1.0]])
    maps = [
        np.array([[2.05, 2.0, 0.02, 0.1, 0.3], [0.3, 3.0, 0.0, 0.1, 0.3]]),  # hit + wall phantom
        np.zeros((0, 5)),  # touched table 1, found nothing
        np.array([[4.0, 4.0, 1.0 + np.pi, 0.1, 0.3]]),  # found table 1 (symmetric angle)
    ]
    touched = [np.array([0, 0]), np.array([1]), np.array([1, 0])]
    s = score_run(maps, touched, truth, (0, 0, 6, 6), 1.2)
    assert s["map_tables"] == 3 and s["matched"] == 2
    assert s["precision"] == pytest.approx(2 / 3)
    assert s["recall"] == pytest.approx(2 / 4)
    assert s["position_error_mean"] == pytest.approx(0.025)
    assert s["angle_error_mean"] == pytest.approx(0.01)
    assert s["phantoms"] == 1 and s["phantom_near_walls"] == 1
    first = math.sqrt(0.05**2 + (0.6 * 0.02) ** 2 + C**2 / 2)
    expected = (first + C / math.sqrt(2) + C / math.sqrt(2)) / 3
    assert s["gospa_mean"] == pytest.approx(expected)


def test_recall_by_support_splits_pairs_by_legs_in_memory():
    truth = np.array([[2.0, 2.0, 0.0], [4.0, 4.0, 1.0]])
    maps = [
        np.array([[2.05, 2.0, 0.02]]),  # finds table 0 (3 legs seen), misses table 1 (1 leg)
        np.zeros((0, 3)),  # misses table 1 (2 legs seen)
        np.array([[4.0, 4.0, 1.0], [2.0, 2.0, 0.0]]),  # finds both (2 and 3 legs seen)
    ]
    touched = [np.array([0, 1]), np.array([1]), np.array([1, 0])]
    support = [np.array([3, 1]), np.array([2]), np.array([2, 3])]
    r = recall_by_support(maps, touched, support, truth)
    assert (r["1"], r["2"], r["3"]) == (0.0, 0.5, 1.0)
    assert (r["pairs_1"], r["pairs_2"], r["pairs_3"], r["pairs_4"]) == (1, 2, 2, 0)
    assert math.isnan(r["4"])
    with pytest.raises(ValueError, match="align"):
        recall_by_support(maps[:1], touched[:1], [np.array([3])], truth)


def test_fused_scores_respect_square_symmetry_types_and_walls():
    from bayesmap.experiments.table_metrics import fused_scores

    truth = np.array([[2.0, 2.0, 0.1], [4.0, 2.0, 0.3]])
    truth_sizes = np.array([[1.2, 0.8], [0.8, 0.8]])
    mapped = np.array(
        [
            [2.05, 2.0, 0.1 + np.pi],  # the desk, half a turn round: a match
            [4.0, 2.02, 0.3 + np.pi / 2],  # the square stool, a quarter turn round: a match
            [0.5, 3.0, 0.0],  # a phantom with a corner 0.1 m from the wall x = 0
            [3.0, 3.8, 0.0],  # a phantom crossing the wall y = 4
            [3.0, 1.0, 0.0],  # a phantom in the open
        ]
    )
    sizes = np.array([[1.2, 0.8], [1.2, 0.8], [0.8, 0.8], [1.2, 0.8], [0.8, 0.8]])
    scores = fused_scores(mapped, sizes, truth, truth_sizes, (0.0, 0.0, 6.0, 4.0))
    assert scores["fused_matched"] == 2 and scores["fused_recall"] == 1.0
    assert scores["fused_precision"] == pytest.approx(2 / 5)
    assert scores["fused_wall_phantoms"] == 2
    assert scores["type_accuracy"] == 0.5  # the stool was mapped as a desk
    assert scores["fused_angle_error_mean"] == pytest.approx(0.0, abs=1e-12)
    # a rectangle a quarter turn round is not the same table
    turned = fused_scores(
        truth[:1] + [0, 0, np.pi / 2], truth_sizes[:1], truth[:1], truth_sizes[:1], (0, 0, 6, 4)
    )
    assert turned["fused_matched"] == 0
