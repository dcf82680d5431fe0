"""Network files: XMLBIF 0.3, BIF and XBN, chosen by the file's extension.

Models don't know their files: each format is a module (:mod:`~bayesmap.bn.io.xmlbif`,
:mod:`~bayesmap.bn.io.bif`, :mod:`~bayesmap.bn.io.xbn`) with ``read``/``write`` and
``loads``/``dumps``, and :data:`FORMATS` maps a format name to them and to its file
extensions. :func:`read` and :func:`write` dispatch on the extension
(``.xml``/``.xmlbif``/``.bifxml`` → XMLBIF, ``.bif`` → BIF, ``.xbn`` → XBN), each optionally
followed by ``.gz``.

Examples
--------
>>> import tempfile, pathlib
>>> from bayesmap.bn.model import BayesNet
>>> net = BayesNet("rain")
>>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2], kind="B")
>>> path = pathlib.Path(tempfile.mkdtemp()) / "rain.xml.gz"
>>> _ = write(net, path)
>>> read(path).kind("Rain")
<NodeKind.BUS: 'B'>
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bayesmap.bn.io._common import read_source, write_output
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["FORMATS", "Format", "dumps", "format_of", "loads", "read", "write"]


@dataclass(frozen=True)
class Format:
    """One file format: how to parse and print it, and the extensions that select it."""

    name: str
    loads: Callable[..., BayesNet]
    dumps: Callable[..., str]
    extensions: tuple[str, ...]


def _deferred(module: str, function: str) -> Callable[..., Any]:
    """``bayesmap.bn.io.<module>.<function>``, imported on first call (lxml, for the XML
    formats, then loads only when an XML file is read or written)."""

    def call(*args: Any, **kwargs: Any) -> Any:
        target = getattr(importlib.import_module(f"bayesmap.bn.io.{module}"), function)
        return target(*args, **kwargs)

    call.__name__ = call.__qualname__ = f"{module}.{function}"
    return call


FORMATS: dict[str, Format] = {
    "xmlbif": Format(
        "xmlbif",
        _deferred("xmlbif", "loads"),
        _deferred("xmlbif", "dumps"),
        (".xml", ".xmlbif", ".bifxml"),
    ),
    "bif": Format("bif", _deferred("bif", "loads"), _deferred("bif", "dumps"), (".bif",)),
    "xbn": Format("xbn", _deferred("xbn", "loads"), _deferred("xbn", "dumps"), (".xbn",)),
}
"""Registered formats by name."""


def format_of(path: str | Path, format: str | None = None) -> Format:
    """The :class:`Format` for ``path``: ``format`` if given, else from its extension.

    Raises
    ------
    FormatError
        Unknown format name or extension.
    """
    if format is not None:
        try:
            return FORMATS[format.lower()]
        except KeyError:
            raise FormatError(
                f"unknown format {format!r}; choose one of {sorted(FORMATS)}", path=str(path)
            ) from None
    name = Path(path).name.lower()
    if name.endswith(".gz"):
        name = name[:-3]
    for fmt in FORMATS.values():
        if name.endswith(fmt.extensions):
            return fmt
    known = sorted(ext for fmt in FORMATS.values() for ext in fmt.extensions)
    raise FormatError(
        f"cannot tell the format from the file name; use one of the extensions {known} "
        "(optionally followed by .gz), or from Python pass format=",
        path=str(path),
    )


def read(
    path: str | Path, format: str | None = None, *, limits: ReadLimits | None = None
) -> BayesNet:
    """Read a network file into a new :class:`BayesNet` (format from the extension).

    ``limits`` caps the file's bytes (also after gunzipping) and its tables' sizes before
    anything is allocated (default :data:`~bayesmap.limits.DEFAULT_LIMITS`).

    Raises
    ------
    FormatError
        Unknown extension, unreadable or non-regular file, a limit passed, malformed or
        inconsistent content; the message names the file and the line or element.
    """
    fmt = format_of(path, format)
    return fmt.loads(read_source(path, limits), path=str(path), limits=limits)


def write(net: BayesNet, path: str | Path, format: str | None = None) -> Path:
    """Write ``net`` to ``path`` atomically in the format its extension names."""
    fmt = format_of(path, format)
    return write_output(path, fmt.dumps(net, path=str(path)))


def loads(text: str | bytes, format: str, *, limits: ReadLimits | None = None) -> BayesNet:
    """Parse a network from file text in ``format`` (``"xmlbif"``, ``"bif"`` or ``"xbn"``)."""
    return format_of("<string>", format).loads(text, limits=limits)


def dumps(net: BayesNet, format: str) -> str:
    """``net`` as the text of a file in ``format``."""
    return format_of("<string>", format).dumps(net)
