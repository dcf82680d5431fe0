"""Figures of the table-mapping experiment: they render, and leave pyplot alone."""

from __future__ import annotations

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from bayesmap.blackboard.annealing import Snapshot
from bayesmap.viz.render import figure_png
from bayesmap.viz.tables import (
    DOUBTFUL_COLOR,
    MappedObjects,
    TableShape,
    annealing_gif,
    fused_map_figure,
    ground_truth_figure,
    montage_figure,
    snapshot_figure,
)

SHAPE = TableShape(1.2, 0.8, 0.1)
BOUNDS = (0.0, 0.0, 6.0, 6.0)
TRUTH = np.array([[2.0, 2.0, 0.3], [4.0, 4.5, 1.2]])


def _snapshot(index: int) -> Snapshot:
    return Snapshot(
        beta=0.1 * (index + 1),
        index=index,
        n_temperatures=3,
        tables=np.array([[2.0, 2.0, 0.3, 0.1, 0.3]]),
        legs=np.array([[1.5, 1.6, 0.3, 0.1, 0.1, 0.3]]),
        leg_parent=np.array([0]),
        shapelets=np.array([[1.45, 1.6, np.pi, 0.3]]),
        shapelet_parent=np.array([0]),
        log_joint=0.0,
    )


def test_figures_render_without_touching_the_pyplot_backend():
    backend = matplotlib.get_backend()
    pose = np.array([1.0, 1.0, 0.5])
    figures = [
        ground_truth_figure(TRUTH, SHAPE, BOUNDS, np.array([[0.5, 0.5, 0.0], [1.0, 0.5, 0.0]])),
        montage_figure(TRUTH, [TRUTH, np.zeros((0, 5))], SHAPE, BOUNDS, "montage"),
        montage_figure(TRUTH, [np.zeros((0, 5))], SHAPE, BOUNDS, "nothing mapped"),
        snapshot_figure(_snapshot(0), SHAPE, TRUTH, pose, np.array([[1.45, 1.6]]), BOUNDS),
    ]
    for fig in figures:
        assert figure_png(fig)[:8] == b"\x89PNG\r\n\x1a\n"
    gif = annealing_gif(
        [_snapshot(i) for i in range(3)], SHAPE, TRUTH, pose, np.zeros((0, 2)), BOUNDS
    )
    assert gif[:6] == b"GIF89a"
    assert annealing_gif([], SHAPE, TRUTH, pose, np.zeros((0, 2)), BOUNDS) == b""
    assert matplotlib.get_backend() == backend
    assert plt.get_fignums() == []


def _square_tops(fig: matplotlib.figure.Figure, side: float) -> int:
    """Polygons drawn with two adjacent sides of length ``side`` (a square top)."""
    count = 0
    for collection in fig.axes[0].collections:
        for path in collection.get_paths():
            v = path.vertices
            if len(v) >= 4:
                a, b = np.linalg.norm(v[1] - v[0]), np.linalg.norm(v[2] - v[1])
                count += bool(np.isclose(a, side) and np.isclose(b, side))
    return count


def test_truth_of_a_mixed_size_world_is_drawn_at_each_table_size():
    """Truth and montage draw a 0.8 × 0.8 stool as a square, not at the desk's 1.2 × 0.8."""
    sizes = np.array([[1.2, 0.8, 0.1], [0.8, 0.8, 0.08]])
    poses = np.array([[0.5, 0.5, 0.0]])
    mixed = [
        ground_truth_figure(TRUTH, SHAPE, BOUNDS, poses, truth_sizes=sizes),
        montage_figure(TRUTH, [np.zeros((0, 5))], SHAPE, BOUNDS, "m", truth_sizes=sizes),
    ]
    assert [_square_tops(fig, 0.8) for fig in mixed] == [1, 1]
    assert _square_tops(ground_truth_figure(TRUTH, SHAPE, BOUNDS, poses), 0.8) == 0


def test_the_fused_map_draws_the_doubtful_objects_dashed_and_says_so_in_its_legend():
    """MAP objects left off the map are drawn in their own colour, dashed, labelled with
    their type and existence; with none there is no such legend entry."""
    sizes = np.array([[1.2, 0.8, 0.1], [0.8, 0.8, 0.08]])
    mapped = MappedObjects(TRUTH[:1], sizes[:1], np.array([0.97]), ["desk"])
    doubtful = MappedObjects(np.array([[4.6, 1.2, 0.2]]), sizes[1:], np.array([0.31]), ["stool"])

    def dashed_and_legend(fig: matplotlib.figure.Figure) -> tuple[int, list[str]]:
        grey = matplotlib.colors.to_rgba(DOUBTFUL_COLOR)
        dashed = sum(
            1
            for c in fig.axes[0].collections
            if np.allclose(c.get_edgecolor()[:1], grey) and c.get_linestyle()[0][1] is not None
        )
        return dashed, [t.get_text() for t in fig.legends[0].get_texts()]

    with_doubtful = fused_map_figure(TRUTH, sizes, mapped, BOUNDS, "t", doubtful=doubtful)
    dashed, legend = dashed_and_legend(with_doubtful)
    assert dashed == 2  # the stool's top and its legs
    assert "left off the map (doubtful)" in legend
    texts = [t.get_text() for t in with_doubtful.axes[0].texts]
    assert texts == ["desk\np=0.97", "stool\np=0.31"]
    without = fused_map_figure(TRUTH, sizes, mapped, BOUNDS, "t")
    assert dashed_and_legend(without) == (
        0,
        ["true table", "fused map (type, existence p)", "arena walls"],
    )
