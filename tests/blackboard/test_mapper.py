"""TableMapper: input checks, working memory, pruning, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.blackboard import BlackboardParams, TableMapper
from bayesmap.errors import InputError

from .synth import three_leg_shapelets


@pytest.mark.parametrize(
    "bad",
    [
        np.array([[0.0, np.nan, 0.0, 0.5]]),
        np.array([[np.inf, 0.0, 0.0, 0.5]]),
        np.zeros((2, 3)),
        np.zeros(4),
    ],
)
def test_bad_shapelets_raise_input_error(bad: np.ndarray) -> None:
    with pytest.raises(InputError):
        TableMapper(BlackboardParams()).step(bad, rng=0)


def test_same_seed_same_result_over_a_sequence() -> None:
    p = BlackboardParams()
    poses = [three_leg_shapelets(p, (x, 0.0, 0.2 * x)) for x in (0.0, 0.1, 3.0)]
    runs = []
    for _ in range(2):
        mapper = TableMapper(p)
        rng = np.random.default_rng(9)
        runs.append([mapper.step(s, rng=rng) for s in poses])
    for a, b in zip(*runs, strict=True):
        assert np.array_equal(a.tables, b.tables) and a.info == b.info


def test_working_memory_keeps_the_seven_most_recent() -> None:
    p = BlackboardParams(n_temperatures=3)
    mapper = TableMapper(p)
    rows = [np.array([[float(i), 0.0, 0.0, 0.5]]) for i in range(10)]
    for r in rows:
        mapper.step(r, rng=0)
    assert np.array_equal(mapper.memory_[:, 0], np.arange(3.0, 10.0))
    mapper.reset()
    assert len(mapper.memory_) == 0 and len(mapper.board_) == 0


def test_tables_far_from_the_memory_are_pruned() -> None:
    p = BlackboardParams()
    mapper = TableMapper(p)
    first = mapper.step(three_leg_shapelets(p, (0.0, 0.0, 0.0)), rng=0)
    assert len(first.tables) == 1
    # seven far contacts, too far apart to share a table, push the old ones out of memory
    far = np.array([[20.0 + 3.0 * i, 20.0, 0.0, 0.5] for i in range(7)])
    result = mapper.step(far, rng=0)
    assert np.all(result.tables[:, 0] > 15.0)  # the first table is gone
    assert all(
        any(v >= p.c_S for v in mapper.board_.contrib_[k]) or mapper.board_.parent_[k] != -1
        for k in mapper.board_.legs_
    )
    assert result.info["n_shapelets"] == 7


def test_empty_pose_gives_no_tables() -> None:
    result = TableMapper(BlackboardParams()).step(np.zeros((0, 4)), rng=0)
    assert result.tables.shape == (0, 5) and result.info["n_tables"] == 0


def test_prune_keeps_only_what_a_shapelet_reaches() -> None:
    """Algorithm 1's pruning: keep hypotheses linked to a shapelet directly or via a common
    ancestor (a table with a linked leg, and that table's other legs)."""
    from bayesmap.blackboard import Blackboard, make_leg, make_table, prune

    from .synth import leg_contact

    p = BlackboardParams()
    near = make_table(0.0, 0.0, 0.0, p.leg_width, 0.5, p)
    far = make_table(5.0, 5.0, 0.0, p.leg_width, 0.5, p)
    board = Blackboard(p)
    board.set_shapelets(np.array([leg_contact((0.0, 0.0, 0.0), 0, 0, 0.0, p)]))
    t_near, t_far = board.add_table(near), board.add_table(far)
    legs = {}
    for name, table, tid, corner in [
        ("touched", near, t_near, 0),
        ("sibling", near, t_near, 2),
        ("far_child", far, t_far, 1),
    ]:
        cx, cy = table.corners[corner]
        legs[name] = board.add_leg(make_leg(cx, cy, 0.0, p.leg_width, p.leg_width, 0.5), tid)
    legs["lonely"] = board.add_leg(make_leg(-3.0, 0.0, 0.0, p.leg_width, p.leg_width, 0.5))
    prune(board)
    assert list(board.tables_) == [t_near]
    assert sorted(board.legs_) == sorted([legs["touched"], legs["sibling"]])
