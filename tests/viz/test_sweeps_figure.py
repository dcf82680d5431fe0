"""The sweep dot plot: a PNG for any mix of arms, including empty and single-run ones."""

from __future__ import annotations

import io
import math

import numpy as np
from PIL import Image

from bayesmap.viz.sweeps import MetricPanel, metrics_figure


def test_draws_every_panel_even_with_missing_values():
    panels = [
        MetricPanel(
            "recall",
            ["a", "b"],
            [np.array([0.2, 0.4, 0.3]), np.array([])],
            [(0.2, 0.4), (math.nan, math.nan)],
        ),
        MetricPanel(
            "gospa",
            ["a", "b"],
            [np.array([1.0]), np.array([2.0, 2.5])],
            [(math.nan, math.nan), (2.0, 2.5)],
        ),
        MetricPanel(
            "phantoms",
            ["a", "b"],
            [np.array([3.0, 4.0]), np.array([5.0, 6.0])],
            [(3.0, 4.0), (5.0, 6.0)],
        ),
        MetricPanel("collisions", ["a", "b"], [np.zeros(4), np.ones(4)], [(0, 0), (1, 1)]),
    ]
    png = metrics_figure(panels, title="t")
    image = Image.open(io.BytesIO(png))
    assert image.format == "PNG"
    width, height = image.size
    assert 1.4 < width / height < 2.0  # three panels a row, two rows
    rgb = np.asarray(image.convert("RGB")).astype(int)
    red = (rgb[..., 0] > 180) & (rgb[..., 1] < 80) & (rgb[..., 2] < 80)
    assert red.sum() > 100  # the intervals are drawn
