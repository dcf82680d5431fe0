"""Sonar figures: the transient cells are drawn where they are, over the map."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

from bayesmap.viz.sonar import transient_png


def _orange_pixels(png: bytes) -> int:
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return int(((r > 200) & (g > 100) & (g < 170) & (b < 80)).sum())


def test_transient_cells_are_drawn_in_orange_over_the_map() -> None:
    probability = np.full((40, 60), 0.1)
    probability[10:14, 20:40] = 0.9  # a trace the map holds
    none = np.zeros(probability.shape, dtype=bool)
    moved = none.copy()
    moved[10:14, 20:40] = True
    extent = (0.0, 6.0, 0.0, 4.0)
    track = np.array([[2.0, 1.2], [4.0, 1.2]])
    without = transient_png(probability, none, extent, tracks=[track], title="none")
    with_ = transient_png(probability, moved, extent, tracks=[track], title="trace")
    assert with_[:8] == b"\x89PNG\r\n\x1a\n"
    # 80 cells of 0.1 m drawn over a 7 in wide figure at 110 dpi: well over a thousand pixels
    assert _orange_pixels(with_) > _orange_pixels(without) + 1000
