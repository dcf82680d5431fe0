"""What every format shares: parsed specs → a fresh network, node kinds as properties, names.

A reader parses its file into :class:`VariableSpec` records (plain data, each carrying
where in the file it came from) and hands them to :func:`build_network`, which orders the
variables so that parents come first, checks the graph and builds a *fresh*
:class:`~bayesmap.bn.model.BayesNet`. Any :class:`~bayesmap.errors.ModelError` the model
raises becomes a :class:`~bayesmap.errors.FormatError` that names the file and the line or
element of the offending variable, and nothing half-built ever escapes.
"""

from __future__ import annotations

import gzip
import heapq
import math
import re
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayesmap._io import read_input, write_bytes
from bayesmap._numbers import NOT_IN_DECIMALS, is_decimal
from bayesmap._typing import FloatArray
from bayesmap.bn.model import BayesNet, NodeKind, Variable
from bayesmap.errors import FormatError, ModelError
from bayesmap.limits import DEFAULT_LIMITS, ReadLimits, check_size

KIND_PROPERTY = "kind"
"""Property name under which a node's kind (Post et al. 2016 §3.4) is stored in files."""


@dataclass
class Location:
    """Where something was found in a file: a 1-based line and/or an element description."""

    path: str | None = None
    line: int | None = None
    element: str | None = None

    def error(self, message: str) -> FormatError:
        """A :class:`FormatError` at this location."""
        return FormatError(message, path=self.path, line=self.line, element=self.element)


@dataclass
class VariableSpec:
    """One variable as parsed from a file, before it is checked by the model."""

    name: str
    states: tuple[str, ...]
    where: Location
    parents: tuple[str, ...] = ()
    cpt: FloatArray | None = None
    cpt_where: Location | None = None
    properties: dict[str, str] = field(default_factory=dict)


def build_network(
    name: str,
    specs: Iterable[VariableSpec],
    *,
    properties: Mapping[str, str] | None = None,
    path: str | None = None,
) -> BayesNet:
    """Check parsed variables and build a new :class:`BayesNet` from them.

    Variables are added in declaration order as far as the graph allows (a parent always
    before its children). Unknown parents, cycles, missing tables and every model error
    raise :class:`FormatError` at the location of the variable concerned.
    """
    by_name: dict[str, VariableSpec] = {}
    for spec in specs:
        if spec.name in by_name:
            first = by_name[spec.name].where
            raise spec.where.error(
                f"variable {spec.name!r} is declared twice (first at {_describe(first)})"
            )
        by_name[spec.name] = spec
    order = _topological(by_name)
    net = BayesNet(name)
    net.properties = dict(properties or {})
    for variable_name in order:
        spec = by_name[variable_name]
        where = spec.cpt_where or spec.where
        if spec.cpt is None:
            raise spec.where.error(f"variable {variable_name!r} has no probability table")
        kind, props = split_kind(spec.properties)
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                net.add_variable(
                    variable_name,
                    spec.states,
                    parents=spec.parents,
                    cpt=spec.cpt,
                    kind=kind,
                    properties=props,
                )
        except ModelError as error:
            raise where.error(str(error)) from None
        for warning in caught:
            warnings.warn_explicit(
                f"{_describe(where)}: {warning.message}",
                warning.category,
                where.path or "<string>",
                where.line or 0,
            )
    return net


def _topological(by_name: Mapping[str, VariableSpec]) -> list[str]:
    """Kahn's algorithm, preferring declaration order; errors for unknown parents and cycles."""
    rank = {n: i for i, n in enumerate(by_name)}
    waiting: dict[str, int] = {}
    children: dict[str, list[str]] = {n: [] for n in by_name}
    for spec in by_name.values():
        for parent in spec.parents:
            if parent not in by_name:
                raise (spec.cpt_where or spec.where).error(
                    f"variable {spec.name!r} has parent {parent!r}, which is not declared"
                )
            children[parent].append(spec.name)
        waiting[spec.name] = len(spec.parents)
    ready = [rank[n] for n, count in waiting.items() if count == 0]
    heapq.heapify(ready)
    names = list(by_name)
    order: list[str] = []
    while ready:
        current = names[heapq.heappop(ready)]
        order.append(current)
        for child in children[current]:
            waiting[child] -= 1
            if waiting[child] == 0:
                heapq.heappush(ready, rank[child])
    if len(order) != len(by_name):
        stuck = sorted((n for n in by_name if waiting[n] > 0), key=rank.__getitem__)
        cycle = _cycle(stuck[0], by_name, waiting)
        first = by_name[cycle[0]]
        raise (first.cpt_where or first.where).error(
            f"the parents form a cycle through {cycle[:8]}" + (" ..." if len(cycle) > 8 else "")
        )
    return order


def _cycle(start: str, by_name: Mapping[str, VariableSpec], waiting: dict[str, int]) -> list[str]:
    """A cycle of parents among the variables left ``waiting``, found from ``start``.

    Each such variable has a parent that is waiting too (else it would have been ordered),
    so following such parents from ``start`` must come back to a variable met before; the
    walk from there on is the cycle, in child-to-parent order."""
    seen: dict[str, int] = {}
    walk: list[str] = []
    current = start
    while current not in seen:
        seen[current] = len(walk)
        walk.append(current)
        current = next(p for p in by_name[current].parents if waiting.get(p, 0) > 0)
    return walk[seen[current] :]


def _describe(where: Location) -> str:
    parts = [
        p for p in (where.path, f"line {where.line}" if where.line else None, where.element) if p
    ]
    return ", ".join(parts) if parts else "an earlier place"


def split_kind(properties: Mapping[str, str]) -> tuple[NodeKind | None, dict[str, str]]:
    """Take the node kind out of a file's properties (``kind = A``; other values stay)."""
    props = dict(properties)
    text = props.get(KIND_PROPERTY)
    if text is None:
        return None, props
    kind = parse_kind(text)
    if kind is not None:
        del props[KIND_PROPERTY]
    return kind, props


def parse_kind(text: str) -> NodeKind | None:
    """The :class:`NodeKind` written as ``text`` (letter or name), or ``None``."""
    key = text.strip().upper()
    for member in NodeKind:
        if key in (member.value, member.name):
            return member
    return None


def properties_with_kind(variable: Variable, *, path: str | None = None) -> dict[str, str]:
    """The properties to write for ``variable``: its own, plus ``kind`` if it has one.

    Raises
    ------
    FormatError
        When a property called ``kind`` would be read back as the node kind, or clashes
        with it.
    """
    props = dict(variable.properties)
    clash = KIND_PROPERTY in props and (
        variable.kind is not None or parse_kind(props[KIND_PROPERTY]) is not None
    )
    if clash:
        raise FormatError(
            f"variable {variable.name!r} has a property {KIND_PROPERTY!r} = "
            f"{props[KIND_PROPERTY]!r}, but that name stores the node kind in files; rename it",
            path=path,
        )
    if variable.kind is not None:
        props[KIND_PROPERTY] = variable.kind.value
    return props


def check_name(what: str, name: str, *, path: str | None = None) -> None:
    """Refuse names a file cannot hold exactly: empty, or with surrounding whitespace."""
    if not name or name != name.strip():
        raise FormatError(
            f"{what} {name!r} is empty or starts/ends with whitespace, which no network "
            "file format keeps; rename it",
            path=path,
        )


def check_property(owner: str, key: str, value: str, *, path: str | None = None) -> None:
    """Refuse properties that cannot be written as ``key = value`` and read back exactly."""
    if not key or key != key.strip() or "=" in key:
        raise FormatError(
            f"{owner}: property name {key!r} is empty, has surrounding whitespace or "
            "contains '='; rename it",
            path=path,
        )
    if value != value.strip():
        raise FormatError(
            f"{owner}: the value of property {key!r} starts or ends with whitespace, "
            "which files do not keep; strip it",
            path=path,
        )


def split_property(text: str) -> tuple[str, str]:
    """``"key = value"`` → ``("key", "value")``; text without ``=`` is a key with value ``""``."""
    key, _, value = text.partition("=")
    return key.strip(), value.strip()


_ESCAPE = re.compile(r"\\(.)", re.DOTALL)
_UNESCAPES = {"n": "\n", "r": "\r", "t": "\t"}
_ESCAPES = {"\\": "\\\\", '"': '\\"', "\n": "\\n", "\r": "\\r", "\t": "\\t"}


def quoted(text: str) -> str:
    """``text`` in double quotes with backslash escapes (``\\"``, ``\\\\``, ``\\n``, ``\\r``,
    ``\\t``), as the text formats (BIF, NET) write names and strings."""
    return '"' + "".join(_ESCAPES.get(c, c) for c in text) + '"'


def unescape(text: str) -> str:
    """The inside of a quoted string back to its text (the inverse of :func:`quoted`)."""
    if "\\" not in text:
        return text
    return _ESCAPE.sub(lambda m: _UNESCAPES.get(m.group(1), m.group(1)), text)


def table_values(array: FloatArray) -> str:
    """Probabilities as text with every digit a double needs (shortest round-trip form)."""
    return " ".join(map(repr, np.asarray(array, dtype=np.float64).ravel().tolist()))


def read_source(path: str | Path, limits: ReadLimits | None = None) -> bytes:
    """The bytes of the regular file ``path``, gunzipped when its name ends in ``.gz``.

    Both the file and its gunzipped content are capped at ``limits.max_bytes``; every
    problem is a :class:`FormatError` naming the file.
    """
    limits = limits or DEFAULT_LIMITS
    return read_input(path, max_bytes=limits.max_bytes, gunzip=str(path).lower().endswith(".gz"))


def write_output(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically, gzipped when the name ends in ``.gz``."""
    data = text.encode("utf-8")
    if str(path).lower().endswith(".gz"):
        data = gzip.compress(data, mtime=0)
    return write_bytes(path, data)


def decode(data: str | bytes) -> str:
    """Text of a plain-text network file: UTF-8, or Latin-1 when it is not UTF-8."""
    if isinstance(data, str):
        return data
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


# ---------------------------------------------------------------------------- strict reading


def probabilities(
    tokens: Sequence[str], locate: Location | Callable[[int], Location]
) -> FloatArray:
    """Table entries as float64, accepting only ASCII decimal numbers that are finite.

    ``1_0``, ``0x1``, ``inf``, ``Infinity``, ``nan``, non-ASCII digits and numbers too large
    for a double (``1e999``) are refused with a :class:`FormatError` at ``locate(k)``, the
    place of the ``k``-th token (or at ``locate`` itself, when it is a :class:`Location`).
    One vectorised conversion does the work; the tokens are looked at one by one only to
    name the culprit.
    """
    if isinstance(locate, Location):
        where = locate
        locate = lambda _: where  # noqa: E731 - one place for every token
    if not tokens:
        return np.empty(0)
    if NOT_IN_DECIMALS.search(" ".join(tokens)) is None:
        try:
            values = np.array(tokens, dtype=np.float64)
        except ValueError:
            values = None
        if values is not None:
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size == 0:
                return values
            k = int(bad[0])
            raise locate(k).error(f"{tokens[k][:40]!r} is too large for a probability")
    k = next(k for k, token in enumerate(tokens) if not is_decimal(token))
    raise locate(k).error(
        f"{tokens[k][:40]!r} is not a number (write plain decimals such as 0.25 or 1e-3)"
    )


def check_names(what: str, names: Iterable[str], where: Location) -> None:
    """Refuse an empty name (which no writer produces) in a file being read."""
    for name in names:
        if not name:
            raise where.error(f"{what}: an empty name")


class TableBudget:
    """Sizes of the tables of one file, checked against :class:`ReadLimits` before allocation.

    A variable with ``L`` parents of ``N_l`` states and ``N`` states of its own has a table
    of ``N x prod(N_l)`` entries (Post et al. 2016 eq. 28), counted here with Python
    integers, which cannot overflow.
    """

    def __init__(self, limits: ReadLimits | None) -> None:
        self.limits = limits or DEFAULT_LIMITS
        self.total = 0

    def claim(self, name: str, n_states: int, cards: Sequence[int], where: Location) -> int:
        """Entries of ``name``'s table; :class:`FormatError` when a limit is passed."""
        limits = self.limits
        self._check(f"parents of {name!r}", len(cards), limits.max_parents, "max_parents", where)
        entries = n_states * math.prod(cards)
        self._check(
            f"entries in the table of {name!r}",
            entries,
            limits.max_table_entries,
            "max_table_entries",
            where,
        )
        self.total += entries
        self._check(
            "entries in all tables of the network",
            self.total,
            limits.max_network_entries,
            "max_network_entries",
            where,
        )
        return entries

    @staticmethod
    def _check(what: str, size: int, limit: int, field: str, where: Location) -> None:
        check_size(
            what, size, limit, field, path=where.path, line=where.line, element=where.element
        )
