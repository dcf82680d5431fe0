"""Reading world files: the JSON document and its schema check, with errors naming the file.

The rover's and the sonar's world files (:mod:`bayesmap.sim.rover_worlds`,
:mod:`bayesmap.sim.sonar_worlds`) are JSON documents checked against a JSON Schema before
their own checks; both read them through these two functions, so a bad file gets the same
one-line :class:`~bayesmap.errors.FormatError` whichever simulator reads it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema

from bayesmap.errors import FormatError


def read_document(path: str | Path) -> Any:
    """The JSON document of the world file at ``path``.

    Raises
    ------
    FormatError
        The file cannot be read, is not UTF-8 text or is not JSON (with its line).
    """
    file = Path(path)
    try:
        return json.loads(file.read_text(encoding="utf-8"))
    except OSError as error:
        raise FormatError(f"cannot read the world file ({error.strerror})", path=file) from None
    except UnicodeDecodeError:
        raise FormatError("the world file is not UTF-8 text", path=file) from None
    except json.JSONDecodeError as error:
        raise FormatError(f"not JSON: {error.msg}", path=file, line=error.lineno) from None


def check_schema(document: Any, schema: dict[str, Any], source: str | Path) -> None:
    """Check ``document`` against ``schema``; a :class:`FormatError` naming ``source`` and
    the offending element (a ``/``-separated path) if it breaks it."""
    try:
        jsonschema.validate(document, schema)
    except jsonschema.ValidationError as error:
        where = "/".join(str(part) for part in error.absolute_path) or "the document"
        raise FormatError(error.message, path=source, element=where) from None
