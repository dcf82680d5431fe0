"""The fused mapper's model: where a table may stand in the arena."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from bayesmap.blackboard.sweep_model import ObjectType, arena_contains, into_arena, tables_overlap

CATALOGUE = (ObjectType("desk", 1.2, 0.8, 0.1), ObjectType("stool", 0.8, 0.8, 0.08))
ARENA = (5.0, 4.0)


def test_into_arena_moves_a_table_across_a_wall_the_least_distance_inside() -> None:
    # a desk turned 90° whose outline crosses the right wall by 2 cm and the floor by 1 cm
    table = np.array([[5.0 - 0.4 + 0.02, 0.6 - 0.01, 0.5 * math.pi, 0.0]])
    assert not arena_contains(table, CATALOGUE, ARENA)[0]
    inside, moved = into_arena(table, CATALOGUE, ARENA)
    assert arena_contains(inside, CATALOGUE, ARENA)[0]
    assert np.allclose(inside[0], [4.6, 0.6, 0.5 * math.pi, 0.0])
    assert math.isclose(moved[0], math.hypot(0.02, 0.01))


def test_into_arena_leaves_a_table_inside_alone_and_flags_one_that_cannot_fit() -> None:
    tables = np.array([[2.5, 2.0, 0.3, 1.0], [2.5, 2.0, 0.0, 0.0]])
    inside, moved = into_arena(tables, CATALOGUE, (5.0, 0.7))
    assert np.allclose(inside[0, 2:], tables[0, 2:])
    assert moved[1] == math.inf  # a desk 0.8 m wide cannot stand in a 0.7 m corridor
    same, still = into_arena(tables, CATALOGUE, ARENA)
    assert np.array_equal(same, tables)
    assert np.all(still == 0.0)


def _outline(table: np.ndarray) -> Polygon:
    kind = CATALOGUE[int(table[3])]
    c, s = math.cos(table[2]), math.sin(table[2])
    return Polygon(
        [
            (table[0] + c * u - s * v, table[1] + s * u + c * v)
            for u, v in (
                (0.5 * kind.length, 0.5 * kind.width),
                (-0.5 * kind.length, 0.5 * kind.width),
                (-0.5 * kind.length, -0.5 * kind.width),
                (0.5 * kind.length, -0.5 * kind.width),
            )
        ]
    )


@pytest.mark.parametrize("rows", [1, 3, 8, 9, 60])
def test_tables_overlap_matches_shapely_for_few_and_many_rows(rows: int) -> None:
    """Both ways of testing (pair by pair for a few rows, numpy passes for many) agree with
    the outlines' intersection area."""
    rng = np.random.default_rng(rows)
    for _ in range(40):
        p = np.array([*rng.uniform(0, 2.5, 2), rng.uniform(0, math.pi), rng.integers(2)])
        q = np.column_stack(
            [
                rng.uniform(0, 2.5, (rows, 2)),
                rng.uniform(0, math.pi, rows),
                rng.integers(2, size=rows),
            ]
        )
        want = [_outline(p).intersection(_outline(t)).area > 1e-12 for t in q]
        assert tables_overlap(p, q, CATALOGUE).tolist() == want
