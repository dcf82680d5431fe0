"""The one error hierarchy of bayesmap.

Every error the library raises on purpose derives from :class:`BayesmapError`, so a
caller can catch the whole family at once, or one kind at a time:

- :class:`ModelError`: a model that cannot be right (a cycle, a CPT row that does not
  sum to 1, an unknown state, a shape mismatch).
- :class:`FormatError`: a file that cannot be read (it names the file, the line or
  element, and what is wrong).
- :class:`ConfigError`: a configuration that cannot run (a negative resolution, an
  empty arena, thresholds out of order).
- :class:`InputError`: data handed to an algorithm that it cannot use (NaN readings,
  arrays of the wrong shape, poses out of order).

Messages say what is wrong, where, and how to fix it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pathlib costs ~8 ms to import; only the annotations name it
    from pathlib import Path


class BayesmapError(Exception):
    """Base class of every error bayesmap raises on purpose."""


class ModelError(BayesmapError, ValueError):
    """A model is inconsistent: cycle, bad CPT, unknown state or shape mismatch."""


class ConfigError(BayesmapError, ValueError):
    """A configuration is impossible or out of range."""


class InputError(BayesmapError, ValueError):
    """Input data (readings, poses, evidence) cannot be used as given."""


class FormatError(BayesmapError, ValueError):
    """A file is malformed or inconsistent.

    Parameters
    ----------
    message
        What is wrong.
    path
        The file being read or written, if known.
    line
        1-based line number where the problem is, if known.
    element
        The element, block or field at fault (e.g. ``"<DEFINITION> of 'Smoker'"``).
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        line: int | None = None,
        element: str | None = None,
    ) -> None:
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        self.element = element
        where = []
        if self.path is not None:
            where.append(self.path)
        if line is not None:
            where.append(f"line {line}")
        if element is not None:
            where.append(element)
        prefix = ": ".join([", ".join(where)]) + ": " if where else ""
        super().__init__(prefix + message)
