"""Figures of the micro-rover experiments: maps with the path (Post et al. 2016 Figs. 11–14).

Every function takes arrays and returns PNG bytes; the caller writes them atomically. The
figures are plain :class:`~matplotlib.figure.Figure` objects that pyplot never sees, so
drawing them leaves the caller's backend and figure list alone.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle

from bayesmap.viz.render import figure_png

_DPI = 90


def _draw_extras(
    ax: Axes,
    path: npt.ArrayLike | None,
    boxes: npt.ArrayLike | None,
    colour: str,
    polygons: Sequence[npt.ArrayLike] = (),
) -> None:
    """Obstacle outlines, path and start, each labelled once for the legend."""
    for k, polygon in enumerate(polygons):
        ax.add_patch(
            Polygon(
                np.asarray(polygon, dtype=float),
                closed=True,
                fill=False,
                edgecolor="red",
                linewidth=1.2,
                linestyle="--",
                label="true obstacle" if k == 0 and boxes is None else None,
            )
        )
    if boxes is not None:
        for k, (xmin, ymin, xmax, ymax) in enumerate(np.asarray(boxes, dtype=float).reshape(-1, 4)):
            ax.add_patch(
                Rectangle(
                    (xmin, ymin),
                    xmax - xmin,
                    ymax - ymin,
                    fill=False,
                    edgecolor="red",
                    linewidth=1.2,
                    linestyle="--",
                    label="true obstacle" if k == 0 else None,
                )
            )
    if path is not None:
        xy = np.asarray(path, dtype=float)
        if xy.size:
            ax.plot(xy[:, 0], xy[:, 1], color=colour, linewidth=0.7, label="path")
            ax.plot(
                xy[0, 0],
                xy[0, 1],
                marker="o",
                color=colour,
                markeredgecolor="black",
                markersize=6,
                linestyle="none",
                label="start",
                clip_on=False,  # whole even where the start lies on the area's edge
                zorder=5,
            )


def _layer_panel(
    fig: Figure,
    ax: Axes,
    layer: npt.ArrayLike,
    extent: tuple[float, float, float, float],
    *,
    cmap: str,
    label: str,
    path: npt.ArrayLike | None,
    boxes: npt.ArrayLike | None,
    path_colour: str,
    polygons: Sequence[npt.ArrayLike] = (),
) -> None:
    """Draw one map layer in [0, 1] (row 0 at the bottom) with its colour bar and extras."""
    image = ax.imshow(
        np.asarray(layer),
        origin="lower",
        extent=extent,
        cmap=cmap,
        vmin=0.0,
        vmax=1.0,
        interpolation="nearest",
    )
    fig.colorbar(image, ax=ax, label=label, fraction=0.046, pad=0.04)
    _draw_extras(ax, path, boxes, path_colour, polygons)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel("x [m]")


def _legend_below(fig: Figure, ax: Axes) -> None:
    """One legend for the path, start and true obstacles, under the map(s)."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(
            handles,
            labels,
            loc="outside lower center",
            ncols=len(handles),
            fontsize=8,
            facecolor="0.55",
            framealpha=1.0,
        )


def maps_pair_figure(
    probability: npt.ArrayLike,
    entropy: npt.ArrayLike,
    extent: tuple[float, float, float, float],
    *,
    title: str,
    path: npt.ArrayLike | None = None,
    boxes: npt.ArrayLike | None = None,
    polygons: Sequence[npt.ArrayLike] = (),
) -> bytes:
    """Probability and entropy maps side by side with the path, as in Figs. 11–14.

    ``boxes`` ``(k, 4)`` and ``polygons`` (vertex arrays) are the true obstacles.
    """
    fig = Figure(figsize=(10.5, 5.0), layout="constrained")
    axes = fig.subplots(1, 2)
    panels = [
        (probability, "(a) P(O | R, r, x)", "viridis", "probability", "white"),
        (entropy, "(b) H(O | R, r, x) [bits]", "magma", "entropy [bits]", "cyan"),
    ]
    for ax, (layer, sub, cmap, label, colour) in zip(axes, panels, strict=True):
        _layer_panel(
            fig,
            ax,
            layer,
            extent,
            cmap=cmap,
            label=label,
            path=path,
            boxes=boxes,
            path_colour=colour,
            polygons=polygons,
        )
        ax.set_title(sub, fontsize=10)
        ax.set_ylabel("y [m]")
    fig.suptitle(title, fontsize=11)
    _legend_below(fig, axes[0])
    return figure_png(fig, _DPI, tight=False)


def coverage_figure(curves: Mapping[str, Sequence[tuple[float, float]]], *, title: str) -> bytes:
    """Coverage (fraction of cells below ``H_desired``) against distance driven, per run.

    Curves that are identical point for point (the frontier rule ignores the entropy
    initialisation) are drawn once, their names joined, so no line hides another.
    """
    fig = Figure(figsize=(7.0, 4.6), layout="constrained")
    ax = fig.subplots()
    merged: dict[bytes, tuple[list[str], npt.NDArray[np.float64]]] = {}
    for name, curve in curves.items():
        xy = np.asarray(curve, dtype=float).reshape(-1, 2)
        merged.setdefault(xy.tobytes(), ([], xy))[0].append(name)
    for names, xy in merged.values():
        label = " = ".join(names)
        ax.plot(xy[:, 0], xy[:, 1], label=label, linestyle="--" if "frontier" in label else "-")
    ax.axhline(0.9, color="grey", linewidth=0.8, linestyle=":", label="90 % coverage")
    ax.set_xlabel("distance driven [m]")
    ax.set_ylabel("coverage")
    ax.set_ylim(0.0, 1.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(title, fontsize=10)
    return figure_png(fig, _DPI, tight=False)
