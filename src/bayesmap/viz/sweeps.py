"""Figures of a sweep: each key metric across arms, one point per world and seed.

Functions take arrays and return PNG bytes; pyplot never sees the figures.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure

from bayesmap.viz import figure_png

__all__ = ["MetricPanel", "metrics_figure"]


@dataclass(frozen=True)
class MetricPanel:
    """One metric of a sweep: per arm, its values and the bootstrap interval of the mean.

    Attributes
    ----------
    metric
        The metric's name (the panel's title).
    arms
        Names of the arms, in drawing order.
    values
        Per arm, the metric's finite values (one per world, seed and unit).
    ci
        Per arm, ``(low, high)`` of the 95 % interval of the mean (NaN if undefined).
    """

    metric: str
    arms: Sequence[str]
    values: Sequence[np.ndarray]
    ci: Sequence[tuple[float, float]]


def metrics_figure(panels: Sequence[MetricPanel], *, title: str) -> bytes:
    """Dot plots of several metrics side by side: every run as a grey dot, the mean as a
    black bar with its 95 % bootstrap interval, one column per arm."""
    n = max(len(panels), 1)
    columns = min(n, 3)
    rows = -(-n // columns)
    fig = Figure(figsize=(4.2 * columns, 3.4 * rows + 0.5), layout="constrained")
    fig.suptitle(title)
    axes = fig.subplots(rows, columns, squeeze=False).ravel()
    for ax, panel in zip(axes, panels, strict=False):
        for position, (values, (low, high)) in enumerate(zip(panel.values, panel.ci, strict=True)):
            values = np.asarray(values, dtype=np.float64)
            if values.size:
                offsets = np.linspace(-0.18, 0.18, values.size) if values.size > 1 else [0.0]
                ax.plot(
                    position + np.asarray(offsets),
                    values,
                    "o",
                    color="0.55",
                    markersize=4,
                    alpha=0.8,
                    label="one run" if position == 0 else None,
                )
                ax.hlines(
                    values.mean(),
                    position - 0.3,
                    position + 0.3,
                    color="black",
                    lw=2,
                    label="mean" if position == 0 else None,
                )
            if np.isfinite(low) and np.isfinite(high):
                ax.vlines(
                    position,
                    low,
                    high,
                    color="tab:red",
                    lw=2,
                    label="95 % CI of the mean" if position == 0 else None,
                )
        ax.set_title(panel.metric)
        ax.set_xticks(range(len(panel.arms)), panel.arms, rotation=20, ha="right")
        ax.set_xlim(-0.6, len(panel.arms) - 0.4)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes[len(panels) :]:
        ax.set_axis_off()
    if panels:
        axes[0].legend(fontsize="small", loc="best")
    return figure_png(fig)
