"""Network files: XMLBIF 0.3, BIF, XBN, Hugin NET, GeNIe XDSL and UAI, chosen by the extension.

Models don't know their files: each format is a module (:mod:`~bayesmap.bn.io.xmlbif`,
:mod:`~bayesmap.bn.io.bif`, :mod:`~bayesmap.bn.io.xbn`, :mod:`~bayesmap.bn.io.net`,
:mod:`~bayesmap.bn.io.xdsl`, :mod:`~bayesmap.bn.io.uai`) with ``read``/``write`` and
``loads``/``dumps``, and :data:`FORMATS` maps a format name to them and to its file
extensions. :func:`read` and :func:`write` dispatch on the extension
(``.xml``/``.xmlbif``/``.bifxml``/``.xbif`` → XMLBIF, ``.bif`` → BIF, ``.xbn`` → XBN,
``.net`` → NET, ``.xdsl`` → XDSL, ``.uai`` → UAI), each optionally followed by ``.gz``;
:func:`read` of a file whose extension names no format tells the format from its content
(:func:`sniff`).

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
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bayesmap.bn.io._common import read_source, write_output
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["FORMATS", "Format", "dumps", "format_of", "loads", "read", "sniff", "write"]


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
        (".xml", ".xmlbif", ".bifxml", ".xbif"),
    ),
    "bif": Format("bif", _deferred("bif", "loads"), _deferred("bif", "dumps"), (".bif",)),
    "xbn": Format("xbn", _deferred("xbn", "loads"), _deferred("xbn", "dumps"), (".xbn",)),
    "net": Format("net", _deferred("net", "loads"), _deferred("net", "dumps"), (".net",)),
    "xdsl": Format("xdsl", _deferred("xdsl", "loads"), _deferred("xdsl", "dumps"), (".xdsl",)),
    "uai": Format("uai", _deferred("uai", "loads"), _deferred("uai", "dumps"), (".uai",)),
}
"""Registered formats by name."""


def format_of(path: str | Path, format: str | None = None) -> Format:
    """The :class:`Format` for ``path``: ``format`` if given, else from its extension.

    Raises
    ------
    FormatError
        Unknown format name or extension.
    """
    fmt = _named_format(path, format)
    if fmt is None:
        raise FormatError(
            f"cannot tell the format from the file name; {_EXTENSIONS_HINT}", path=str(path)
        )
    return fmt


def _named_format(path: str | Path, format: str | None) -> Format | None:
    """``format`` if given (unknown: :class:`FormatError`), else the format ``path``'s
    extension names, or ``None``."""
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
    return None


_EXTENSIONS_HINT = (
    "use one of the extensions "
    f"{sorted(ext for fmt in FORMATS.values() for ext in fmt.extensions)} "
    "(optionally followed by .gz), or from Python pass format="
)
_XML_ROOTS = {
    "BIF": "xmlbif",
    "NETWORK": "xmlbif",
    "ANALYSISNOTEBOOK": "xbn",
    "BNMODEL": "xbn",
    "SMILE": "xdsl",
}
_XML_NOISE = re.compile(rb"<!--.*?-->|<[?!][^>]*>|\]>", re.DOTALL)
"""Comments, the XML declaration, processing instructions and DTD declarations."""
_XML_ROOT = re.compile(rb"<(?:[\w.-]+:)?([A-Za-z_][\w.-]*)")
_BIF_NOISE = re.compile(rb"(?:\s|//[^\n]*|/\*.*?\*/)*", re.DOTALL)
"""Blank space and C-style comments, which BIF allows before its ``network`` block."""
_NET_NOISE = re.compile(rb"(?:\s|%[^\n]*)*")
"""Blank space and ``%`` comments, which NET allows before its ``net`` block."""
_UAI_NOISE = re.compile(rb"(?:\s|#[^\n]*|c(?:[ \t][^\n]*)?\n)*")
"""Blank space and comments (``#`` to the end of a line, lines of ``c``) before UAI's type."""


def sniff(data: bytes) -> Format | None:
    """The format of a network file's ``data`` from its content, or ``None``.

    XML is XMLBIF when its root element is ``<BIF>`` (or a bare ``<NETWORK>``), XBN when
    it is ``<ANALYSISNOTEBOOK>`` (or ``<BNMODEL>``) and XDSL when it is ``<smile>``; text
    whose first word, after blank space and comments, is ``network`` is BIF, ``net`` or
    ``class`` Hugin NET, and ``BAYES`` or ``MARKOV`` UAI. Only the first 64 KiB are looked
    at.
    """
    head = data[: 1 << 16].lstrip(b"\xef\xbb\xbf \t\r\n")
    if head.startswith(b"<"):
        root = _XML_ROOT.search(_XML_NOISE.sub(b"", head))
        name = _XML_ROOTS.get(root.group(1).decode("ascii").upper()) if root else None
        return FORMATS[name] if name else None
    words = _BIF_NOISE.sub(b"", head, count=1)  # the pattern matches (maybe empty) at 0
    if re.match(rb"network\b", words):
        return FORMATS["bif"]
    words = _NET_NOISE.sub(b"", head, count=1)
    if re.match(rb"(?:net|class)(?![\w.-])", words):
        return FORMATS["net"]
    words = _UAI_NOISE.sub(b"", head, count=1)
    return FORMATS["uai"] if re.match(rb"(?:BAYES|MARKOV)\s", words) else None


def read(
    path: str | Path, format: str | None = None, *, limits: ReadLimits | None = None
) -> BayesNet:
    """Read a network file into a new :class:`BayesNet` (format from the extension, else
    from the content: :func:`sniff`).

    ``limits`` caps the file's bytes (also after gunzipping) and its tables' sizes before
    anything is allocated (default :data:`~bayesmap.limits.DEFAULT_LIMITS`).

    Raises
    ------
    FormatError
        Unknown extension, unreadable or non-regular file, a limit passed, malformed or
        inconsistent content; the message names the file and the line or element.
    """
    fmt = _named_format(path, format)
    data = read_source(path, limits)
    if fmt is None:
        fmt = sniff(data)
        if fmt is None:
            raise FormatError(
                "cannot tell the format from the file name or its content (XMLBIF, BIF, "
                f"XBN, NET, XDSL or UAI); {_EXTENSIONS_HINT}",
                path=str(path),
            )
    return fmt.loads(data, path=str(path), limits=limits)


def write(net: BayesNet, path: str | Path, format: str | None = None) -> Path:
    """Write ``net`` to ``path`` atomically in the format its extension names."""
    fmt = format_of(path, format)
    return write_output(path, fmt.dumps(net, path=str(path)))


def loads(text: str | bytes, format: str, *, limits: ReadLimits | None = None) -> BayesNet:
    """Parse a network from file text in ``format`` (a name in :data:`FORMATS`)."""
    return format_of("<string>", format).loads(text, limits=limits)


def dumps(net: BayesNet, format: str) -> str:
    """``net`` as the text of a file in ``format``."""
    return format_of("<string>", format).dumps(net)
