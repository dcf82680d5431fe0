"""Rendering a figure to bytes: the one place every figure of bayesmap is saved.

Figures here are plain :class:`~matplotlib.figure.Figure` objects, never registered with
pyplot, so drawing them neither changes the caller's backend nor leaks memory.

Names from the user (a world's name, a network's variables, a file name) may hold
characters the figure's font cannot draw (CJK, emoji). Matplotlib draws those as empty
boxes and warns once per character; here they are gathered into one
:class:`MissingGlyphWarning` naming them.
"""

from __future__ import annotations

import io
import re
import warnings

from matplotlib.figure import Figure

__all__ = ["MissingGlyphWarning", "figure_png"]

_GLYPH = re.compile(r"^Glyph (\d+) .*missing from font")


class MissingGlyphWarning(UserWarning):
    """A figure's text holds characters its font cannot draw; they show as empty boxes."""


def figure_png(fig: Figure, dpi: int = 110, *, tight: bool = True, format: str = "png") -> bytes:
    """Render ``fig`` to PNG (or ``format``: ``"svg"``) bytes; ``tight`` crops to its content.

    Characters the font lacks are named in one :class:`MissingGlyphWarning`; every other
    warning of the drawing passes on unchanged.
    """
    buffer = io.BytesIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fig.savefig(buffer, format=format, dpi=dpi, bbox_inches="tight" if tight else None)
    missing: set[str] = set()
    for warning in caught:
        glyph = _GLYPH.match(str(warning.message))
        if glyph is not None:
            missing.add(chr(int(glyph.group(1))))
        else:
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    if missing:
        warnings.warn(
            f"the figures' font has no glyph for {''.join(sorted(missing))!r}, drawn as empty "
            "boxes (names with such characters read correctly in the JSON and CSV outputs)",
            MissingGlyphWarning,
            stacklevel=2,
        )
    return buffer.getvalue()
