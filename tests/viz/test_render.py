"""Saving figures: characters the font lacks are named once, other warnings pass on."""

from __future__ import annotations

import warnings

import pytest
from matplotlib.figure import Figure

from bayesmap.viz.render import MissingGlyphWarning, figure_png


def _figure(title: str) -> Figure:
    fig = Figure(figsize=(2, 1))
    ax = fig.subplots()
    ax.set_title(title)
    ax.set_xlabel(title)
    return fig


def test_missing_glyphs_are_one_warning_naming_them() -> None:
    with pytest.warns(MissingGlyphWarning) as caught:
        png = figure_png(_figure("世界 room"))
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(caught) == 1 and "'世界'" in str(caught[0].message)
    assert not [w for w in caught if "Glyph" in str(w.message)]


def test_a_figure_the_font_can_draw_saves_without_warnings() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        svg = figure_png(_figure("room [m]"), format="svg")
    assert svg.lstrip().startswith(b"<?xml")
