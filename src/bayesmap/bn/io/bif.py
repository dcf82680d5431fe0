"""BIF, the text format of the bnlearn repository (Cozman's Interchange Format 0.15).

A file is a sequence of blocks::

    network asia {
      property author = "me" ;
    }
    variable smoke {
      type discrete [ 2 ] { yes, no };
      property kind = "A" ;
    }
    probability ( lung | smoke ) {
      (yes) 0.1, 0.9;
      (no) 0.01, 0.99;
    }

Reading
    One linear pass of a regular-expression tokenizer checks quotes and removes comments,
    then a block scanner whose every regular expression is matched once, forwards, so the
    time is linear in the size of the file, whatever it holds (see the ``bif_scaling``
    section of docs/benchmarks.md). The numbers of a table are converted in one numpy
    call, at full double precision, and must be plain ASCII decimals (``1_0``, ``inf``,
    ``nan`` and non-ASCII digits are refused); a table's size is checked against
    :class:`~bayesmap.limits.ReadLimits` before it is allocated. ``//`` and ``/* */`` comments,
    quoted names (``"a b"``, with ``\\"`` and ``\\\\`` escapes), unquoted names with any
    character other than the separators (``<5``, ``Asy/Patch``, ``>=7.5``), whitespace-
    or comma-separated lists, ``table`` (child state slowest, last parent fastest, as
    pgmpy and pyAgrum read it), ``default`` rows and old-style headers
    ``probability ( child parent ... )`` are accepted. ``property`` lines of a variable
    become its properties, ``kind = A`` its node kind; properties inside ``probability``
    blocks are ignored.
Writing
    Names that are not plain identifiers are double-quoted with backslash escapes (pgmpy
    reads them, since it drops the quotes); probabilities are written with the shortest
    text that gives back the same double.

Every problem raises :class:`~bayesmap.errors.FormatError` naming the file and line.
"""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np

from bayesmap._typing import FloatArray
from bayesmap.bn.io._common import (
    Location,
    TableBudget,
    VariableSpec,
    build_network,
    check_name,
    check_property,
    decode,
    probabilities,
    properties_with_kind,
    quoted,
    read_source,
    split_property,
    unescape,
    write_output,
)
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["dumps", "loads", "read", "write"]

# A quoted name on one line, with backslash escapes; possessive, so a quote that is never
# closed costs one scan to the end of its line, not a backtracking search.
_QUOTED = r'"[^"\\\n]*+(?:\\[^\n][^"\\\n]*+)*+"'
# One linear pass over the text: complete quoted names, comments, and runs of anything else;
# a quote or a comment that is not closed is an error, found at once.
_LEXEME = re.compile(
    r"(?P<quoted>" + _QUOTED + r")"
    r'|(?P<open_quote>")'
    r"|(?P<line_comment>//[^\n]*)"
    r"|(?P<block_comment>/\*[\s\S]*?\*/)"
    r"|(?P<open_comment>/\*)"
    r'|(?:[^"/]|/(?![/*]))+'
)
_BLOCK = re.compile(r"\s*(?:(network|variable|probability)(?![\w.\-])|\Z)")
_WORD = re.compile(r"\S{1,40}")
_HEADER_END = re.compile(_QUOTED + r'|[{};"]')
_BODY_TOKEN = re.compile(_QUOTED + r'|[{}"]')
_STATEMENT = re.compile(r"(?:" + _QUOTED + r'|[^";])*;')
_ITEM = re.compile(r'\s*(?:"((?:[^"\\\n]|\\.)*)"\s*(,|\Z|(?="))|([^",]*)(,|\Z))')
"""One name of a list and what ends it: a quoted name (group 1) ends at a comma, the end, or
the next quoted name (group 2); an unquoted one (group 3) at a comma or the end (group 4)."""
_TYPE = re.compile(r"\s*type\s+discrete\s*\[\s*([0-9]{1,9})\s*\]\s*\{(.*)\}\s*\Z", re.DOTALL)
_PROPERTY = re.compile(r"\s*property(?![\w.\-])(.*)\Z", re.DOTALL)
_PAREN_TOKEN = re.compile(_QUOTED + r'|[()"]')
_TABLE = re.compile(r"\s*(table|default)(?![\w.\-])(.*)\Z", re.DOTALL)
_PARENS = re.compile(r"\s*\((.*)\)\s*\Z", re.DOTALL)
_PLAIN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*")


# ---------------------------------------------------------------------------- reading
def read(path: str | Path, *, limits: ReadLimits | None = None) -> BayesNet:
    """Read a BIF file (``.bif`` or ``.bif.gz``) into a new :class:`BayesNet`.

    Raises
    ------
    FormatError
        The file cannot be read, is malformed, passes a :class:`ReadLimits` limit or
        describes an inconsistent network; the message names the file and line.
    """
    return loads(read_source(path, limits), path=str(path), limits=limits)


def loads(
    text: str | bytes, *, path: str | None = None, limits: ReadLimits | None = None
) -> BayesNet:
    """Parse BIF text; ``path`` only names the source in error messages."""
    decoded = decode(text)
    if not decoded.strip():
        raise FormatError(
            "the file is empty; a BIF network starts with a 'network' block", path=path
        )
    return _Parser(decoded, path, TableBudget(limits)).parse()


class _Parser:
    """One pass over the blocks of a BIF text."""

    def __init__(self, text: str, path: str | None, budget: TableBudget) -> None:
        self.text = text
        self.path = path
        self.budget = budget
        if '"' in text or "/" in text:
            self.text = _LEXEME.sub(self._lexeme, text)
        self._line_pos = 0
        self._line = 1

    def _lexeme(self, match: re.Match[str]) -> str:
        """Keep names and text, blank comments (keeping their line breaks), stop at a stray."""
        kind = match.lastgroup
        if kind is None or kind == "quoted":
            return match.group()
        if kind == "open_quote":
            raise self.error(match.start(), "unterminated quoted name (it must close on its line)")
        if kind == "open_comment":
            raise self.error(match.start(), "unterminated comment: '/*' without '*/'")
        return "\n" * match.group().count("\n") or " "

    def line_at(self, offset: int) -> int:
        """1-based line of ``offset`` (offsets must not go backwards between calls)."""
        if offset < self._line_pos:
            return self.text.count("\n", 0, offset) + 1
        self._line += self.text.count("\n", self._line_pos, offset)
        self._line_pos = offset
        return self._line

    def error(self, offset: int, message: str, element: str | None = None) -> FormatError:
        line = self.text.count("\n", 0, offset) + 1
        return FormatError(message, path=self.path, line=line, element=element)

    def parse(self) -> BayesNet:
        text = self.text
        name = "network"
        net_properties: dict[str, str] = {}
        specs: dict[str, VariableSpec] = {}
        tables: list[tuple[str, str, int, int]] = []  # (header, body, body offset, line)
        seen_network = False
        pos = 0
        while True:
            match = _BLOCK.match(text, pos)
            if match is None:
                found = _WORD.search(text, pos)
                raise self.error(
                    found.start() if found else pos,
                    "expected 'network', 'variable' or 'probability', found "
                    f"{found.group() if found else ''!r}",
                )
            keyword = match.group(1)
            if keyword is None:
                break
            start = match.start(1)
            line = self.line_at(start)
            brace = self._header_end(match.end(), keyword)
            header = text[match.end() : brace]
            close = self._block_end(brace + 1, keyword, line)
            body = text[brace + 1 : close]
            pos = close + 1
            if keyword == "network":
                if seen_network:
                    raise self.error(start, "a second 'network' block")
                seen_network = True
                name = self._network_name(header, start) or name
                net_properties = self._properties(body, brace + 1, "network block")
            elif keyword == "variable":
                spec = self._variable(header, body, start, brace + 1, line)
                if spec.name in specs:
                    first = specs[spec.name].where.line
                    raise self.error(
                        start, f"variable {spec.name!r} is declared twice (first on line {first})"
                    )
                specs[spec.name] = spec
            else:
                tables.append((header, body, brace + 1, line))
        done: dict[str, int] = {}
        for header, body, offset, line in tables:
            self._probability(header, body, offset, line, specs, done)
        return build_network(name, specs.values(), properties=net_properties, path=self.path)

    # ------------------------------------------------------------------ block scanning
    def _header_end(self, pos: int, keyword: str) -> int:
        for match in _HEADER_END.finditer(self.text, pos):
            token = match.group()
            if token == "{":
                return match.start()
            if token == '"' or token in "};":
                what = "an unterminated quoted name" if token == '"' else repr(token)
                raise self.error(match.start(), f"'{keyword}' block: found {what} before its '{{'")
        raise self.error(pos, f"'{keyword}' block without '{{'")

    def _block_end(self, pos: int, keyword: str, line: int) -> int:
        depth = 1
        for match in _BODY_TOKEN.finditer(self.text, pos):
            token = match.group()
            if token == "}":
                depth -= 1
                if depth == 0:
                    return match.start()
            elif token == "{":
                depth += 1
            elif token == '"':
                raise self.error(match.start(), "unterminated quoted name")
        raise self.error(pos, f"'{keyword}' block opened on line {line} is never closed")

    def _statements(self, body: str, offset: int) -> list[tuple[str, int]]:
        """``;``-terminated statements of a block body with their offsets in the text."""
        if '"' not in body:
            pieces = body.split(";")
            tail = pieces.pop()
            result = []
            at = offset
            for piece in pieces:
                result.append((piece, at))
                at += len(piece) + 1
        else:
            result = []
            at = 0
            while (match := _STATEMENT.match(body, at)) is not None:
                result.append((match.group()[:-1], offset + match.start()))
                at = match.end()
            tail = body[at:]
            at += offset
        if tail.strip():
            raise self.error(at + len(tail) - len(tail.lstrip()), "statement without a closing ';'")
        return [(s, o + len(s) - len(s.lstrip())) for s, o in result if s.strip()]

    # ------------------------------------------------------------------ blocks
    def _network_name(self, header: str, offset: int) -> str:
        items = self._items(header, offset, "network name", allow_empty=True)
        return " ".join(items)

    def _properties(self, body: str, offset: int, element: str) -> dict[str, str]:
        props: dict[str, str] = {}
        for statement, at in self._statements(body, offset):
            match = _PROPERTY.match(statement)
            if match is None:
                raise self.error(
                    at, f"{element}: expected 'property', found {_first_word(statement)!r}"
                )
            key, value = self._property(match.group(1), at)
            props[key] = value
        return props

    def _property(self, raw: str, offset: int) -> tuple[str, str]:
        raw = raw.strip()
        if raw.startswith('"') and _fullquoted(raw):
            return split_property(unescape(raw[1:-1]))
        key, eq, value = raw.partition("=")
        key = key.strip()
        value = value.strip()
        if key.startswith('"'):
            key = self._one_item(key, offset, "property name")
        if value.startswith('"') and _fullquoted(value):
            value = unescape(value[1:-1])
        if not key:
            raise self.error(offset, "property without a name")
        return key, value

    def _variable(self, header: str, body: str, start: int, offset: int, line: int) -> VariableSpec:
        name = self._one_item(header, start, "variable name")
        where = Location(self.path, line, f"variable {name!r}")
        states: list[str] | None = None
        props: dict[str, str] = {}
        for statement, at in self._statements(body, offset):
            type_match = _TYPE.match(statement)
            if type_match is not None:
                if states is not None:
                    raise self.error(at, f"variable {name!r}: a second 'type' statement")
                states = self._items(type_match.group(2), at, f"states of {name!r}")
                declared = int(type_match.group(1))
                if declared != len(states):
                    raise self.error(
                        at,
                        f"variable {name!r} declares {declared} states "
                        f"but lists {len(states)}: {states}",
                    )
                if len(set(states)) != len(states):
                    dup = sorted({s for s in states if states.count(s) > 1})
                    raise self.error(at, f"variable {name!r} lists state(s) {dup} twice")
                continue
            prop_match = _PROPERTY.match(statement)
            if prop_match is not None:
                key, value = self._property(prop_match.group(1), at)
                props[key] = value
                continue
            raise self.error(
                at,
                f"variable {name!r}: expected 'type discrete [ n ] {{ ... }}' or 'property', "
                f"found {statement.strip()[:60]!r}",
            )
        if states is None:
            raise self.error(
                start, f"variable {name!r} has no 'type discrete [ n ] {{ ... }}' statement"
            )
        return VariableSpec(name, tuple(states), where, properties=props)

    def _probability(
        self,
        header: str,
        body: str,
        offset: int,
        line: int,
        specs: dict[str, VariableSpec],
        done: dict[str, int],
    ) -> None:
        start = offset
        match = _PARENS.match(header)
        if match is None:
            raise self.error(start, "expected 'probability ( child | parents ) {'")
        child, parents = self._probability_header(match.group(1), start)
        element = f"probability block of {child!r}"
        if child not in specs:
            raise self.error(start, f"{element}: variable {child!r} is not declared")
        if child in done:
            raise self.error(start, f"a second {element} (first on line {done[child]})")
        for parent in parents:
            if parent not in specs:
                raise self.error(start, f"{element}: parent {parent!r} is not declared")
        if len(set(parents)) != len(parents):
            raise self.error(start, f"{element}: a parent is listed twice in {parents}")
        done[child] = line
        spec = specs[child]
        spec.parents = tuple(parents)
        spec.cpt_where = Location(self.path, line, element)
        self.budget.claim(
            child, len(spec.states), [len(specs[p].states) for p in parents], spec.cpt_where
        )
        spec.cpt = self._table(spec, [specs[p].states for p in parents], body, offset, element)

    def _probability_header(self, inner: str, offset: int) -> tuple[str, list[str]]:
        bar = _split_bar(inner)
        if bar is None:
            names = self._items(inner, offset, "probability header")
            if not names:
                raise self.error(offset, "probability block names no variable")
            return names[0], names[1:]
        child = self._one_item(inner[:bar], offset, "probability header")
        parents = self._items(inner[bar + 1 :], offset, "parents in the probability header")
        if not parents:
            raise self.error(offset, f"probability block of {child!r}: no parents after '|'")
        return child, parents

    def _table(
        self,
        spec: VariableSpec,
        parent_states: list[tuple[str, ...]],
        body: str,
        offset: int,
        element: str,
    ) -> FloatArray:
        n_child = len(spec.states)
        cards = [len(s) for s in parent_states]
        n_columns = math.prod(cards)
        lookups = [{s: i for i, s in enumerate(states)} for states in parent_states]
        strides = [math.prod(cards[k + 1 :]) for k in range(len(cards))]
        tokens: list[str] = []
        columns: list[int] = []
        row_offsets: list[int] = []
        table: tuple[str, int] | None = None
        default: tuple[list[str], int] | None = None
        for statement, at in self._statements(body, offset):
            stripped = statement.lstrip()
            if stripped.startswith("("):
                open_at = len(statement) - len(stripped)
                close = self._closing_paren(statement, open_at, at)
                items, rest = statement[open_at + 1 : close], statement[close + 1 :]
                names = self._items(items, at, f"{element}: parent states")
                if len(names) != len(cards):
                    raise self.error(
                        at,
                        f"{element}: row names {len(names)} parent states, expected {len(cards)}",
                    )
                column = 0
                for k, state in enumerate(names):
                    index = lookups[k].get(state)
                    if index is None:
                        raise self.error(
                            at,
                            f"{element}: parent {spec.parents[k]!r} has no state {state!r}; "
                            f"its states are {list(parent_states[k])}",
                        )
                    column += index * strides[k]
                values = rest.replace(",", " ").split()
                if len(values) != n_child:
                    raise self.error(
                        at,
                        f"{element}: row ({', '.join(names)}) has {len(values)} probabilities, "
                        f"expected {n_child} (one per state of {spec.name!r})",
                    )
                tokens.extend(values)
                columns.append(column)
                row_offsets.append(at)
                continue
            keyword = _TABLE.match(statement)
            if keyword is None:
                if _PROPERTY.match(statement):
                    continue
                raise self.error(
                    at,
                    f"{element}: expected '( states ) numbers;', 'table' or 'default', "
                    f"found {statement.strip()[:60]!r}",
                )
            values = keyword.group(2).replace(",", " ").split()
            if keyword.group(1) == "table":
                if table is not None:
                    raise self.error(at, f"{element}: a second 'table'")
                expected = n_child * n_columns
                if len(values) != expected:
                    raise self.error(
                        at,
                        f"{element}: 'table' has {len(values)} probabilities, expected {expected} "
                        f"({n_child} states x {n_columns} parent configurations)",
                    )
                table = (" ".join(values), at)
            else:
                if default is not None:
                    raise self.error(at, f"{element}: a second 'default'")
                if len(values) != n_child:
                    raise self.error(
                        at,
                        f"{element}: 'default' has {len(values)} probabilities, expected {n_child}",
                    )
                default = (values, at)
        if table is not None:
            if columns or default is not None:
                raise self.error(table[1], f"{element}: 'table' mixed with rows or 'default'")
            return self._numbers(
                table[0].split(), [table[1]], len(table[0].split()), element
            ).reshape((n_child, *cards))
        matrix = np.empty((n_columns, n_child))
        given = np.zeros(n_columns, dtype=bool)
        if columns:
            numbers = self._numbers(tokens, row_offsets, n_child, element)
            rows = np.asarray(columns, dtype=np.int64)
            if np.unique(rows).size != rows.size:
                seen: set[int] = set()
                for column, at in zip(columns, row_offsets, strict=True):
                    if column in seen:
                        raise self.error(
                            at, f"{element}: this row's parent states were already given"
                        )
                    seen.add(column)
            matrix[rows] = numbers.reshape(-1, n_child)
            given[rows] = True
        if default is not None:
            matrix[~given] = self._numbers(default[0], [default[1]], n_child, element)
            given[:] = True
        missing_columns = np.flatnonzero(~given)
        if missing_columns.size:
            where = np.unravel_index(int(missing_columns[0]), cards) if cards else ()
            config = ", ".join(
                f"{p}={parent_states[k][int(i)]}"
                for k, (p, i) in enumerate(zip(spec.parents, where, strict=True))
            )
            raise self.error(
                offset,
                f"{element}: no probabilities for {config or 'the variable'} "
                f"({missing_columns.size} parent configuration(s) missing; "
                "add rows or a 'default')",
            )
        return np.moveaxis(matrix.reshape((*cards, n_child)), -1, 0)

    def _numbers(
        self, tokens: list[str], offsets: list[int], per_row: int, element: str
    ) -> FloatArray:
        def locate(k: int) -> Location:
            at = offsets[min(k // per_row, len(offsets) - 1)]
            return Location(self.path, self.text.count("\n", 0, at) + 1, element)

        return probabilities(tokens, locate)

    def _closing_paren(self, statement: str, open_at: int, at: int) -> int:
        if '"' not in statement:
            close = statement.find(")", open_at)
            if close >= 0:
                return close
        else:
            for match in _PAREN_TOKEN.finditer(statement, open_at + 1):
                if match.group() == ")":
                    return match.start()
                if match.group() in ('"', "("):
                    break
        raise self.error(at, "row without a closing ')'")

    # ------------------------------------------------------------------ names
    def _items(self, raw: str, offset: int, what: str, *, allow_empty: bool = False) -> list[str]:
        """Names in a comma- (or, without commas, whitespace-) separated list; quoted names
        may also follow one another with only whitespace between (JavaBayes' BIF 0.15)."""
        if '"' not in raw:
            items = [s.strip() for s in raw.split(",")] if "," in raw else raw.split()
            if any(not s for s in items):
                raise self.error(offset, f"{what}: an empty name in {raw.strip()[:60]!r}")
            return items
        items = []
        pos = 0
        while True:
            match = _ITEM.match(raw, pos)
            if match is None:
                raise self.error(
                    offset, f"{what}: cannot read {raw.strip()[:60]!r} as a list of names"
                )
            quoted, quoted_end, plain, plain_end = match.groups()
            if quoted is not None:
                if not quoted:
                    raise self.error(offset, f'{what}: an empty name "" in {raw.strip()[:60]!r}')
                items.append(unescape(quoted))
            else:
                item = plain.strip()
                if not item:
                    raise self.error(offset, f"{what}: an empty name in {raw.strip()[:60]!r}")
                items.append(item)
            if (quoted_end if quoted is not None else plain_end) == "" and match.end() == len(raw):
                break
            pos = match.end()
        if not items and not allow_empty:
            raise self.error(offset, f"{what}: no name")
        return items

    def _one_item(self, raw: str, offset: int, what: str) -> str:
        if '"' in raw:
            items = self._items(raw, offset, what)
            if len(items) != 1:
                raise self.error(offset, f"{what}: expected one name, found {items}")
            return items[0]
        name = raw.strip()
        if not name or "," in name:
            raise self.error(offset, f"{what}: expected one name, found {name[:60]!r}")
        return name


def _first_word(statement: str) -> str:
    words = statement.split()
    return words[0] if words else ""


def _fullquoted(text: str) -> bool:
    return re.fullmatch(_QUOTED, text) is not None


def _split_bar(inner: str) -> int | None:
    """Offset of the first ``|`` outside quotes, or ``None``."""
    if '"' not in inner:
        index = inner.find("|")
        return None if index < 0 else index
    for match in re.finditer(_QUOTED + r"|\|", inner):
        if match.group() == "|":
            return match.start()
    return None


# ---------------------------------------------------------------------------- writing
def write(net: BayesNet, path: str | Path) -> Path:
    """Write ``net`` as BIF to ``path`` (gzipped if it ends in ``.gz``), atomically."""
    return write_output(path, dumps(net, path=str(path)))


def dumps(net: BayesNet, *, path: str | None = None) -> str:
    """``net`` as BIF text.

    Raises
    ------
    FormatError
        A name or property the format cannot hold exactly (see :func:`check_name`).
    """
    out = [f"network {_quote(net.name) if net.name else 'unknown'} {{\n"]
    out.extend(_property_lines(net.properties, "network", path))
    out.append("}\n")
    for name in net.variables:
        variable = net.variable(name)
        check_name("variable name", name, path=path)
        for state in variable.states:
            check_name(f"state of {name!r}", state, path=path)
        states = ", ".join(_quote(s) for s in variable.states)
        out.append(
            f"variable {_quote(name)} {{\n"
            f"  type discrete [ {len(variable.states)} ] {{ {states} }};\n"
        )
        out.extend(
            _property_lines(properties_with_kind(variable, path=path), f"variable {name!r}", path)
        )
        out.append("}\n")
    for name in net.variables:
        variable = net.variable(name)
        cpt = variable.cpt
        if not variable.parents:
            out.append(
                f"probability ( {_quote(name)} ) {{\n  table {_numbers(cpt.tolist())};\n}}\n"
            )
            continue
        parents = ", ".join(_quote(p) for p in variable.parents)
        out.append(f"probability ( {_quote(name)} | {parents} ) {{\n")
        rows = np.moveaxis(cpt, 0, -1).reshape(-1, cpt.shape[0]).tolist()
        labels = itertools.product(*([_quote(s) for s in net.states(p)] for p in variable.parents))
        out.extend(
            f"  ({', '.join(label)}) {_numbers(row)};\n"
            for label, row in zip(labels, rows, strict=True)
        )
        out.append("}\n")
    return "".join(out)


def _property_lines(props: dict[str, str], owner: str, path: str | None) -> list[str]:
    lines = []
    for key, value in props.items():
        check_property(owner, key, value, path=path)
        lines.append(f"  property {_quote(key)} = {quoted(value)} ;\n")
    return lines


def _numbers(values: list[float]) -> str:
    return ", ".join(map(repr, values))


def _quote(name: str) -> str:
    """``name`` as is when it is a plain identifier, else double-quoted with escapes."""
    return name if _PLAIN.fullmatch(name) else quoted(name)
