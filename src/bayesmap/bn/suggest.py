"""Hints ("did you mean ...?") for misspelt variable and state names in error messages."""

from __future__ import annotations

from collections.abc import Iterable

_SHOWN = 12
"""Lists of known names longer than this are not printed in full."""


def unknown(what: str, name: object, known: Iterable[str]) -> str:
    """The end of an error message about an unknown ``what`` (``"variable"``, ``"state"``).

    Suggests up to three close matches (difflib's ratio, case-insensitive) and, when the
    list is short, names every known value.

    Examples
    --------
    >>> unknown("state", "hgh", ["LOW", "NORMAL", "HIGH"])
    "did you mean 'HIGH'? Known states: ['LOW', 'NORMAL', 'HIGH']"
    """
    import difflib  # only on the error path: keeps ``import bayesmap.bn`` lean

    choices = list(known)
    folded = {c.lower(): c for c in choices}
    close = difflib.get_close_matches(str(name).lower(), list(folded), n=3, cutoff=0.6)
    parts = []
    if close:
        parts.append("did you mean " + " or ".join(repr(folded[c]) for c in close) + "?")
    if len(choices) <= _SHOWN:
        parts.append(f"Known {what}s: {choices}")
    elif not close:
        parts.append(f"{len(choices)} {what}s are known (see 'bayesmap bn info')")
    return " ".join(parts)
