"""Figures for sonar mapping: occupancy maps side by side, with the true walls overlaid.

Every map has its axes in metres and the figure carries a grey-level key: white is free
(p = 0), mid-grey unknown (p = 0.5), black occupied (p = 1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.image import AxesImage

from bayesmap._typing import BoolArray, FloatArray, Grid
from bayesmap.viz.render import figure_png

__all__ = ["map_png", "maps_side_by_side", "transient_png"]


def _draw(
    ax: Axes,
    probability: Grid,
    extent: tuple[float, float, float, float],
    walls: FloatArray | None,
    path: FloatArray | None,
) -> AxesImage:
    image = ax.imshow(
        np.asarray(probability, dtype=np.float64),
        origin="lower",
        extent=extent,
        cmap="gray_r",
        vmin=0.0,
        vmax=1.0,
        interpolation="nearest",
    )
    if walls is not None:
        for x0, y0, x1, y1 in walls:
            ax.plot([x0, x1], [y0, y1], color="tab:red", lw=0.8, alpha=0.8)
    if path is not None and len(path):
        ax.plot(path[:, 0], path[:, 1], color="tab:blue", lw=0.6, ls=":")
    ax.set_aspect("equal")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.tick_params(labelsize=6)
    ax.set_xlabel("x [m]", fontsize=7)
    ax.set_ylabel("y [m]", fontsize=7)
    return image


def _key(fig: Figure, image: AxesImage, axes: Axes | np.ndarray) -> None:
    """The grey-level key of the maps on ``axes``."""
    key = fig.colorbar(image, ax=axes, shrink=0.8, ticks=[0.0, 0.25, 0.5, 0.75, 1.0])
    key.set_label("P(occupied)\nwhite free, grey unknown, black occupied", fontsize=7)
    key.ax.tick_params(labelsize=6)


_KEY_HEIGHT = 3.0
"""Smallest figure height [in] of :func:`maps_side_by_side`: its key's label, two lines of
7 pt text about 2.1 in long, was cut off beside a single row of long corridors."""


def maps_side_by_side(
    panels: Sequence[tuple[str, Grid]],
    extent: tuple[float, float, float, float],
    *,
    walls: FloatArray | None = None,
    path: FloatArray | None = None,
    title: str = "",
    columns: int = 3,
    panel_width: float = 3.2,
) -> bytes:
    """PNG bytes of occupancy maps side by side (black = occupied, white = free, grey = unknown).

    Parameters
    ----------
    panels
        ``(title, probability)`` pairs; each probability is ``(ny, nx)`` with row 0 at the bottom.
    extent
        ``(xmin, xmax, ymin, ymax)`` [m] of the maps.
    walls
        Optional ``(n, 4)`` true wall segments [m], drawn in red.
    path
        Optional ``(m, 2)`` robot path [m], drawn dotted.
    title
        Figure title.
    columns
        Panels per row.
    panel_width
        Width of each panel [inches].
    """
    n = len(panels)
    cols = min(columns, n)
    rows = (n + cols - 1) // cols
    width = extent[1] - extent[0]
    height = extent[3] - extent[2]
    panel_height = panel_width * height / max(width, 1e-9) + 0.35
    # At least _KEY_HEIGHT tall, so that the colour key's label fits beside one row of wide maps.
    fig_height = max(panel_height * rows + 0.6, _KEY_HEIGHT)
    fig = Figure(figsize=(panel_width * cols + 1.0, fig_height), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    image = None
    for ax, (name, probability) in zip(axes.ravel(), panels, strict=False):
        image = _draw(ax, probability, extent, walls, path)
        ax.set_title(name, fontsize=8)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    if image is not None:
        _key(fig, image, axes)
    if title:
        fig.suptitle(title, fontsize=9)
    return figure_png(fig, 90, tight=False)


def map_png(
    probability: Grid,
    extent: tuple[float, float, float, float],
    *,
    path: FloatArray | None = None,
    title: str = "",
) -> bytes:
    """PNG bytes of one occupancy map, with the robot path if given."""
    return maps_side_by_side([(title, probability)], extent, path=path, columns=1, panel_width=6.0)


def transient_png(
    probability: Grid,
    transient: BoolArray,
    extent: tuple[float, float, float, float],
    *,
    walls: FloatArray | None = None,
    tracks: Sequence[FloatArray] = (),
    title: str = "",
) -> bytes:
    """PNG bytes of one occupancy map with the cells the map's verdict set aside as surfaces
    that moved on (:func:`~bayesmap.sonar.map_verdict.transient_cells`) in orange.

    Parameters
    ----------
    probability, transient
        ``(ny, nx)`` the map and its transient cells, row 0 at the bottom.
    extent
        ``(xmin, xmax, ymin, ymax)`` [m] of the map.
    walls
        Optional ``(n, 4)`` true wall segments [m], drawn in red.
    tracks
        Optional ``(m, 2)`` paths of whatever moved (people walking by) [m], drawn in green.
    title
        Figure title.
    """
    width, height = extent[1] - extent[0], extent[3] - extent[2]
    fig = Figure(figsize=(7.0, max(7.0 * height / max(width, 1e-9) + 0.8, _KEY_HEIGHT)))
    ax = fig.subplots()
    image = _draw(ax, probability, extent, walls, None)
    overlay = np.zeros((*np.shape(transient), 4))
    overlay[np.asarray(transient, dtype=bool)] = (1.0, 0.5, 0.0, 0.85)
    ax.imshow(overlay, origin="lower", extent=extent, interpolation="nearest")
    for k, track in enumerate(tracks):
        ax.plot(
            track[:, 0],
            track[:, 1],
            color="tab:green",
            lw=0.8,
            alpha=0.7,
            label="paths of what moved (truth)" if k == 0 else None,
        )
    if walls is not None:
        ax.plot([], [], color="tab:red", lw=0.8, label="walls (truth)")
    ax.plot([], [], "s", color=(1.0, 0.5, 0.0), ms=5, label="moved on (transient cells)")
    ax.legend(fontsize=6, loc="upper right", framealpha=0.9)
    _key(fig, image, ax)
    if title:
        ax.set_title(title, fontsize=8)
    return figure_png(fig, 110)
