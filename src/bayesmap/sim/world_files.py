"""Reading world files: the JSON document and its schema check, with errors naming the file.

The whisker, rover and sonar world files (:mod:`bayesmap.sim.whisker_worlds`,
:mod:`bayesmap.sim.rover_worlds`, :mod:`bayesmap.sim.sonar_worlds`) are JSON documents
checked against a JSON Schema before their own checks; all three read them through these
functions, so a bad file gets the same one-line :class:`~bayesmap.errors.FormatError`
whichever simulator reads it.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import jsonschema
import shapely

from bayesmap.errors import FormatError


def read_document(path: str | Path) -> Any:
    """The JSON document of the world file at ``path``.

    Raises
    ------
    FormatError
        The file cannot be read, is not UTF-8 text, is not JSON, or holds ``NaN`` or
        ``Infinity`` (which Python's JSON reader would take), with its line.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except OSError as error:
        raise FormatError(f"cannot read the world file ({error.strerror})", path=file) from None
    except UnicodeDecodeError:
        raise FormatError("the world file is not UTF-8 text", path=file) from None

    def refuse(constant: str) -> Any:
        line = text.count("\n", 0, max(text.find(constant), 0)) + 1
        raise FormatError(
            f"{constant} is not a number (sizes, positions and angles must be finite)",
            path=file,
            line=line,
        )

    try:
        return json.loads(text, parse_constant=refuse)
    except json.JSONDecodeError as error:
        raise FormatError(f"not JSON: {error.msg}", path=file, line=error.lineno) from None


def element_name(path: Iterable[str | int]) -> str:
    """The element at a JSON ``path`` as a reader writes it: ``tables[2].x``, ``size[1]``;
    ``the document`` for the top level."""
    name = "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in path)
    return name.lstrip(".") or "the document"


def check_schema(document: Any, schema: dict[str, Any], source: str | Path) -> None:
    """Check ``document`` against ``schema``; a :class:`FormatError` naming ``source`` and
    the offending element (:func:`element_name`) if it breaks it."""
    try:
        jsonschema.validate(document, schema)
    except jsonschema.ValidationError as error:
        raise FormatError(
            error.message, path=source, element=element_name(error.absolute_path)
        ) from None


def polygon_problem(polygon: shapely.Polygon) -> str | None:
    """What keeps ``polygon`` from being a simple polygon of positive area, or ``None``.

    The text follows the element's name in a :class:`FormatError`
    (``obstacles[0]: must be a simple polygon of positive area (Self-intersection[4 4])``).
    """
    if polygon.is_valid and polygon.area > 0:
        return None
    flat = polygon.convex_hull.area <= 0
    reason = "its vertices lie on one line" if flat else shapely.is_valid_reason(polygon)
    return f"must be a simple polygon of positive area ({reason})"
