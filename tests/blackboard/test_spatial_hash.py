"""SpatialHash: radius queries agree with brute force."""

from __future__ import annotations

import math

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from bayesmap.blackboard.spatial_hash import SpatialHash
from bayesmap.errors import ConfigError

coords = st.floats(-5.0, 5.0, allow_nan=False, allow_subnormal=False)


@settings(max_examples=60, deadline=None)
@given(
    points=st.lists(st.tuples(coords, coords), max_size=40),
    centre=st.tuples(coords, coords),
    radius=st.floats(0.001, 3.0),
    cell=st.floats(0.1, 2.0),
    removed=st.sets(st.integers(0, 39)),
)
# A point a hair left of a cell edge, on the disc's boundary once the distance test rounds.
@example(
    points=[(-1.5124449081850387e-68, 0.0)], centre=(1.0, 0.0), radius=1.0, cell=1.0, removed=set()
)
def test_query_matches_brute_force(
    points: list[tuple[float, float]],
    centre: tuple[float, float],
    radius: float,
    cell: float,
    removed: set[int],
) -> None:
    h = SpatialHash(cell)
    for key, (x, y) in enumerate(points):
        h.insert(key, x, y)
    for key in removed:
        if key < len(points):
            h.remove(key)
    expected = {
        key
        for key, (x, y) in enumerate(points)
        if key not in removed and (x - centre[0]) ** 2 + (y - centre[1]) ** 2 <= radius**2
    }
    assert set(h.query(*centre, radius)) == expected
    assert len(h) == len(points) - len([k for k in removed if k < len(points)])


def test_reinsert_moves_a_point() -> None:
    h = SpatialHash(1.0)
    h.insert(3, 0.0, 0.0)
    h.insert(3, 10.0, 10.0)
    assert h.query(0.0, 0.0, 1.0) == []
    assert h.query(10.0, 10.0, 0.1) == [3]
    assert 3 in h


@pytest.mark.parametrize("cell", [0.0, -1.0, math.inf, math.nan])
def test_bad_cell_is_config_error(cell: float) -> None:
    with pytest.raises(ConfigError):
        SpatialHash(cell)
