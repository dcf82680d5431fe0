"""Figures of the whiskered table-mapping experiment (Fox & Prescott 2011 Figs. 1–2, 4–7).

Everything here takes arrays: tables as ``(k, ≥3)`` rows ``x, y, theta`` [m, m, rad],
legs as ``(m, ≥3)`` rows ``x, y, theta``, shapelets as ``(n, 4)`` rows
``x, y, theta, tau``, and a :class:`TableShape` giving the one table size. A table is a
``length`` × ``width`` rectangle centred at ``(x, y)`` with its long side along ``theta``
and square legs of side ``leg_width`` flush with its corners.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from PIL import Image

from bayesmap._typing import FloatArray
from bayesmap.geometry import is_solid_square
from bayesmap.viz.render import figure_png

__all__ = [
    "BoardView",
    "MappedObjects",
    "TableShape",
    "annealing_gif",
    "fused_map_figure",
    "ground_truth_figure",
    "montage_figure",
    "snapshot_figure",
]

TRUTH_COLOR = "#e377c2"
MAP_COLOR = "#1f4e9c"


class TableShape(NamedTuple):
    """The microworld's one table size [m]."""

    length: float
    width: float
    leg_width: float


class BoardView(Protocol):
    """What a blackboard snapshot must offer to be drawn (e.g. a blackboard ``Snapshot``)."""

    @property
    def beta(self) -> float: ...
    @property
    def index(self) -> int: ...
    @property
    def n_temperatures(self) -> int: ...
    @property
    def tables(self) -> FloatArray: ...
    @property
    def legs(self) -> FloatArray: ...
    @property
    def shapelets(self) -> FloatArray: ...


def _rectangles(poses: FloatArray, length: float, width: float) -> FloatArray:
    """``(k, 4, 2)`` corners of rectangles at ``(k, ≥3)`` poses ``x, y, theta``."""
    poses = np.asarray(poses, dtype=np.float64).reshape(
        -1, np.shape(poses)[-1] if np.size(poses) else 3
    )
    local = 0.5 * np.array([[length, width], [-length, width], [-length, -width], [length, -width]])
    c, s = np.cos(poses[:, 2:3]), np.sin(poses[:, 2:3])
    x = poses[:, 0:1] + c * local[:, 0] - s * local[:, 1]
    y = poses[:, 1:2] + s * local[:, 0] + c * local[:, 1]
    return np.stack([x, y], axis=-1)


def _legs_of(tables: FloatArray, shape: TableShape) -> FloatArray:
    """``(4k, 3)`` leg poses of ``(k, ≥3)`` tables."""
    tables = np.asarray(tables, dtype=np.float64).reshape(
        -1, np.shape(tables)[-1] if np.size(tables) else 3
    )
    centres = _rectangles(tables, shape.length - shape.leg_width, shape.width - shape.leg_width)
    theta = np.repeat(tables[:, 2], 4)
    return np.column_stack([centres.reshape(-1, 2), theta])


def draw_tables(
    ax: Axes,
    tables: FloatArray,
    shape: TableShape,
    *,
    color: str,
    alpha: float,
    filled: bool = True,
    linewidth: float = 0.8,
    linestyle: str = "-",
) -> None:
    """Draw tables (outline, of ``linestyle``, or translucent fill) with their four legs; a
    solid box or pillar (legs that meet) as its outline alone, filled darker."""
    if not np.size(tables):
        return
    tops = _rectangles(tables, shape.length, shape.width)
    legs = _rectangles(_legs_of(tables, shape), shape.leg_width, shape.leg_width)
    if is_solid_square(shape.length, shape.width, shape.leg_width):
        tops, legs = tops[:0], tops  # the legs meet: one square, drawn as a leg is
    if filled:
        ax.add_collection(
            PolyCollection(list(tops), facecolors=color, edgecolors="none", alpha=alpha)
        )
        ax.add_collection(
            PolyCollection(
                list(legs), facecolors=color, edgecolors="none", alpha=min(1.0, 2 * alpha)
            )
        )
    else:
        for parts in (tops, legs):
            ax.add_collection(
                PolyCollection(
                    list(parts),
                    facecolors="none",
                    edgecolors=color,
                    alpha=alpha,
                    linewidths=linewidth,
                    linestyles=linestyle,
                )
            )


def _arena(ax: Axes, bounds: tuple[float, float, float, float], pad: float = 0.3) -> None:
    xmin, ymin, xmax, ymax = bounds
    ax.plot([xmin, xmax, xmax, xmin, xmin], [ymin, ymin, ymax, ymax, ymin], color="k", lw=1.5)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)
    ax.set_xlabel("x [m]", fontsize=8)
    ax.set_ylabel("y [m]", fontsize=8)


def ground_truth_figure(
    truth: FloatArray,
    shape: TableShape,
    bounds: tuple[float, float, float, float],
    poses: FloatArray,
    *,
    truth_sizes: FloatArray | None = None,
) -> Figure:
    """Fig. 4: the true tables and the robot's positions, with the order they are visited.

    ``truth_sizes`` (rows ``length, width, leg`` per table) draws a world of several table
    sizes at each table's own size; without it every table has ``shape``.
    """
    fig = Figure(figsize=(5.2, 5.2))
    ax = fig.subplots()
    _draw_sized(
        ax, truth, _sizes_of(truth, shape, truth_sizes), color=TRUTH_COLOR, alpha=0.55, filled=True
    )
    xy = np.asarray(poses)[:, :2]
    _, first = np.unique(xy, axis=0, return_index=True)
    path = xy[np.sort(first)]
    ax.plot(path[:, 0], path[:, 1], color="0.6", lw=0.6, zorder=1)
    ax.plot(path[:, 0], path[:, 1], "k.", ms=4, zorder=2)
    ax.annotate("start", path[0], xytext=(4, -10), textcoords="offset points", fontsize=7)
    for i, (x, y, _) in enumerate(np.asarray(truth)[:, :3]):
        ax.text(x, y, f"T{i}", ha="center", va="center", fontsize=8, color="0.15")
    _arena(ax, bounds)
    ax.set_title("Ground truth and robot positions (4 headings each)", fontsize=9)
    return fig


def montage_figure(
    truth: FloatArray,
    maps: Sequence[FloatArray],
    shape: TableShape,
    bounds: tuple[float, float, float, float],
    title: str,
    *,
    truth_sizes: FloatArray | None = None,
) -> Figure:
    """Figs. 5–7: every pose's MAP tables, translucent, over the true tables' outlines.

    The fill's opacity falls with the number of tables drawn, so that where many poses
    agree on a table the map is dark and a lone table stays faint. The MAP tables have the
    mapper's one size ``shape``; the true tables have ``truth_sizes`` (rows ``length, width,
    leg``) when given.
    """
    fig = Figure(figsize=(5.2, 6.0))
    ax = fig.subplots()
    stacked = [np.asarray(m)[:, :3] for m in maps if np.size(m)]
    every = np.concatenate(stacked) if stacked else np.zeros((0, 3))
    if len(every):
        alpha = float(np.clip(12.0 / len(every), 0.025, 0.3))
        draw_tables(ax, every, shape, color=MAP_COLOR, alpha=alpha)
    _draw_sized(
        ax,
        truth,
        _sizes_of(truth, shape, truth_sizes),
        color=TRUTH_COLOR,
        alpha=1.0,
        filled=False,
        linewidth=1.4,
    )
    _arena(ax, bounds)
    ax.set_title(title, fontsize=9)
    corners = _rectangles(every, shape.length, shape.width)
    xmin, ymin, xmax, ymax = bounds
    outside = (
        (corners[..., 0] < xmin)
        | (corners[..., 0] > xmax)
        | (corners[..., 1] < ymin)
        | (corners[..., 1] > ymax)
    ).any(axis=1)
    ax.legend(
        handles=[
            Patch(facecolor="none", edgecolor=TRUTH_COLOR, lw=1.4, label="true table"),
            Patch(
                facecolor=MAP_COLOR,
                alpha=0.35,
                label="MAP tables of all poses (darker: more agree)",
            ),
        ],
        loc="upper center",
        bbox_to_anchor=(0.5, -0.1),
        ncol=1,
        fontsize=7,
        frameon=False,
        title=(
            f"{int(outside.sum())} of {len(every)} MAP tables cross a wall: the paper's model has "
            "no walls, so wall contacts become table legs"
        ),
        title_fontsize=7,
    )
    return fig


def snapshot_figure(
    board: BoardView,
    shape: TableShape,
    truth: FloatArray,
    pose: FloatArray,
    whisker_points: FloatArray,
    bounds: tuple[float, float, float, float],
    *,
    radius: float = 2.0,
    label: str = "",
) -> Figure:
    """Figs. 1–2: one blackboard around the robot.

    True tables filled pink; hypothesised tables and legs as wire frames; shapelets as
    small yellow bars along the touched surface with a tick along their normal; the robot
    as a cone and its whiskers as lines to their contacts (or protracted tips). ``label``
    starts the title (e.g. "high temperature"); a bar under the title shows how far through
    the schedule the board is. The legend sits below the axes, never over a table.
    """
    fig = Figure(figsize=(4.8, 5.4))
    ax = fig.subplots()
    draw_tables(ax, truth, shape, color=TRUTH_COLOR, alpha=0.45)
    draw_tables(ax, board.tables, shape, color="tab:blue", alpha=0.9, filled=False, linewidth=0.8)
    legs = np.asarray(board.legs, dtype=np.float64).reshape(-1, 6)
    if len(legs):
        squares = _rectangles(legs[:, :3], shape.leg_width, shape.leg_width)
        ax.add_collection(
            PolyCollection(list(squares), facecolors="none", edgecolors="tab:green", linewidths=0.7)
        )
    x, y, heading = np.asarray(pose, dtype=np.float64)
    for px, py in np.asarray(whisker_points).reshape(-1, 2):
        ax.plot([x, px], [y, py], color="0.35", lw=0.7)
    cone = np.array([[0.18, 0.0], [-0.12, 0.1], [-0.12, -0.1]])
    c, s = np.cos(heading), np.sin(heading)
    ax.fill(x + c * cone[:, 0] - s * cone[:, 1], y + s * cone[:, 0] + c * cone[:, 1], color="k")
    shapelets = np.asarray(board.shapelets, dtype=np.float64).reshape(-1, 4)
    if len(shapelets):
        bars = _rectangles(
            np.column_stack([shapelets[:, :2], shapelets[:, 2] + np.pi / 2]), 0.12, 0.03
        )
        ax.add_collection(
            PolyCollection(list(bars), facecolors="gold", edgecolors="k", linewidths=0.5, zorder=5)
        )
        tips = shapelets[:, :2] + 0.1 * np.column_stack(
            [np.cos(shapelets[:, 2]), np.sin(shapelets[:, 2])]
        )
        for (sx, sy), (tx, ty) in zip(shapelets[:, :2], tips, strict=True):
            ax.plot([sx, tx], [sy, ty], color="darkgoldenrod", lw=0.8, zorder=5)
    ax.legend(
        handles=[
            Patch(facecolor=TRUTH_COLOR, alpha=0.45, label="true table"),
            Patch(facecolor="none", edgecolor="tab:blue", label="table hypothesis"),
            Patch(facecolor="none", edgecolor="tab:green", label="leg hypothesis"),
            Line2D([], [], color="gold", lw=3, label="shapelet (tick: normal)"),
        ],
        loc="upper center",
        bbox_to_anchor=(0.5, -0.13),
        ncol=2,
        fontsize=7,
        frameon=False,
    )
    _arena(ax, bounds, pad=0.3)
    ax.set_xlim(max(bounds[0] - 0.3, x - radius), min(bounds[2] + 0.3, x + radius))
    ax.set_ylim(max(bounds[1] - 0.3, y - radius), min(bounds[3] + 0.3, y + radius))
    prefix = f"{label}: " if label else ""
    ax.set_title(
        f"{prefix}step {board.index + 1} of {board.n_temperatures} temperatures, "
        f"β = {board.beta:.3g}\n"
        f"{len(np.asarray(board.tables).reshape(-1, 5))} tables, {len(legs)} legs on the board",
        fontsize=9,
    )
    done = (board.index + 1) / max(board.n_temperatures, 1)
    bar = ax.inset_axes((0.0, 1.005, 1.0, 0.012))
    bar.barh([0], [done], color="tab:red", height=1.0)
    bar.set_xlim(0, 1)
    bar.set_axis_off()
    return fig


def annealing_gif(
    boards: Sequence[BoardView],
    shape: TableShape,
    truth: FloatArray,
    pose: FloatArray,
    whisker_points: FloatArray,
    bounds: tuple[float, float, float, float],
    *,
    frame_ms: int = 150,
) -> bytes:
    """A GIF of one pose's annealing: one :func:`snapshot_figure` frame per temperature.

    Every frame differs (its title and the schedule bar move on) even when the board has
    settled, so the animation never looks stuck; the last frame is held for two seconds.
    """
    frames = []
    for board in boards:
        fig = snapshot_figure(board, shape, truth, pose, whisker_points, bounds)
        fig.subplots_adjust(left=0.13, right=0.97, bottom=0.24, top=0.88)
        png = figure_png(fig, dpi=100, tight=False)
        frames.append(Image.open(io.BytesIO(png)).convert("P", palette=Image.Palette.ADAPTIVE))
    if not frames:
        return b""
    size = frames[0].size
    frames = [f if f.size == size else f.resize(size) for f in frames]
    buffer = io.BytesIO()
    durations = [frame_ms] * (len(frames) - 1) + [2000]
    frames[0].save(
        buffer, format="GIF", save_all=True, append_images=frames[1:], duration=durations, loop=0
    )
    return buffer.getvalue()


def _sizes_of(tables: FloatArray, shape: TableShape, sizes: FloatArray | None) -> FloatArray:
    """Per-table sizes ``length, width, leg``: ``sizes`` if given, else ``shape`` for all."""
    if sizes is not None:
        return np.asarray(sizes, dtype=np.float64).reshape(-1, 3)
    return np.tile(np.array(shape, dtype=np.float64), (len(np.asarray(tables).reshape(-1, 3)), 1))


def _draw_sized(
    ax: Axes,
    tables: FloatArray,
    sizes: FloatArray,
    *,
    color: str,
    alpha: float,
    filled: bool,
    linewidth: float = 0.8,
    linestyle: str = "-",
) -> None:
    """Draw tables of several sizes (``sizes`` rows ``length, width, leg``)."""
    tables = np.asarray(tables, dtype=np.float64).reshape(-1, 3)
    sizes = np.asarray(sizes, dtype=np.float64).reshape(-1, 3)
    for size in np.unique(sizes, axis=0):
        same = np.all(sizes == size, axis=1)
        shape = TableShape(float(size[0]), float(size[1]), float(size[2]))
        draw_tables(
            ax,
            tables[same],
            shape,
            color=color,
            alpha=alpha,
            filled=filled,
            linewidth=linewidth,
            linestyle=linestyle,
        )


class MappedObjects(NamedTuple):
    """Mapped objects to draw: ``poses`` (n, 3) ``x, y, θ``, ``sizes`` (n, 3) ``length,
    width, leg`` [m], ``existence`` (n,) probabilities and ``labels`` (n) type names."""

    poses: FloatArray
    sizes: FloatArray
    existence: FloatArray
    labels: Sequence[str]


DOUBTFUL_COLOR = "0.45"


def fused_map_figure(
    truth: FloatArray,
    truth_sizes: FloatArray,
    mapped: MappedObjects,
    bounds: tuple[float, float, float, float],
    title: str,
    *,
    doubtful: MappedObjects | None = None,
) -> Figure:
    """The fused map over the truth: true tables filled (none: no truth), mapped objects
    outlined, and the ``doubtful`` ones — MAP objects left off the map — dashed in grey.

    Each object is labelled with its type and existence probability; the legend sits below
    the axis label, outside the axes, so it never hides a table or the label; the figure's
    height follows the arena's shape.
    """
    aspect = (bounds[3] - bounds[1]) / max(bounds[2] - bounds[0], 1e-9)
    # the axes' height [in] follows the arena's (a long corridor gets a low strip, not a
    # gap above the legend), within bounds that keep a tall room on the page
    fig = Figure(figsize=(5.6, 1.1 + max(4.5 * min(aspect, 1.6), 0.5)), layout="constrained")
    ax = fig.subplots()
    _draw_sized(ax, truth, truth_sizes, color=TRUTH_COLOR, alpha=0.45, filled=True)
    handles: list[Artist] = []
    if len(truth):  # a map of a logged tour may have no truth to show
        handles.append(Patch(facecolor=TRUTH_COLOR, alpha=0.45, label="true table"))
    layers = [(mapped, MAP_COLOR, "-", "fused map (type, existence p)")]
    if doubtful is not None and len(doubtful.poses):
        layers.append((doubtful, DOUBTFUL_COLOR, "--", "left off the map (doubtful)"))
    for objects, color, style, label in layers:
        _draw_sized(
            ax,
            objects.poses,
            objects.sizes,
            color=color,
            alpha=1.0,
            filled=False,
            linewidth=1.4,
            linestyle=style,
        )
        rows = np.asarray(objects.poses).reshape(-1, 3)
        for (x, y, _), p, name in zip(rows, objects.existence, objects.labels, strict=True):
            ax.text(x, y, f"{name}\np={p:.2f}", ha="center", va="center", fontsize=6, color=color)
        handles.append(Line2D([], [], color=color, lw=1.4, ls=style, label=label))
    _arena(ax, bounds)
    ax.set_title(title, fontsize=9)
    handles.append(Line2D([], [], color="k", lw=1.5, label="arena walls"))
    fig.legend(
        handles=handles, loc="outside lower center", ncol=len(handles), fontsize=7, frameon=False
    )
    return fig
