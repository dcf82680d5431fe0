"""The UAI format (``.uai``): the networks of the UAI inference evaluations (2008 onwards).

A generalisation of Noetic Systems' Ergo format, used for the benchmark networks of the UAI
probabilistic-inference competitions and read by most exact and approximate solvers::

    BAYES
    3             number of variables
    2 2 3         their numbers of states
    3             number of functions: one per variable
    1 0           a function's scope: its size, then variable indices, the child last
    2 0 1
    2 1 2
    2             each table in that order: its number of entries, then the entries,
     0.8 0.2      the last variable of the scope fastest (row-major over the scope)
    4
     0.9 0.1 0.2 0.8
    6
     0.5 0.3 0.2 0.1 0.1 0.8

Reading
    Numbers are separated by any blank space; a line starting with ``c`` (the 2016
    evaluation's comments) and anything after ``#`` are comments. The variables have no
    names in the format: variable ``i`` is named ``i`` and its states ``0``, ``1``, ...
    (pyAgrum names them so too), in file order. Each variable needs exactly one function
    whose scope ends with it; the functions may come in any order. A ``MARKOV`` network
    (undirected factors) is not a Bayesian network and is refused, as is anything the
    preamble and the tables disagree on, with the line it is on.
Writing
    The variables in the network's order, each function's scope its parents then the
    variable, its table in row-major order over that scope. The format holds no names,
    properties or node kinds, so none are written: a network written and read back has the
    same structure and tables under the names ``0``, ``1``, ... (the network is named
    after the file). Keep names in any other format.
"""

from __future__ import annotations

import bisect
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bayesmap.bn.io._common import (
    Location,
    TableBudget,
    VariableSpec,
    build_network,
    decode,
    probabilities,
    read_source,
    table_values,
    write_output,
)
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits, check_size

__all__ = ["dumps", "loads", "read", "write"]

_TOKEN = re.compile(r"\S+")
_COMMENT = re.compile(r"#[^\n]*|^[ \t]*c(?:[ \t][^\n]*)?$", re.MULTILINE)
_COUNT = re.compile(r"[0-9]+")


class _Tokens:
    """The file's tokens with their lines, read one after another."""

    def __init__(self, text: str, path: str | None) -> None:
        text = _COMMENT.sub(lambda m: " " * len(m.group()), text)
        self.tokens = [(m.group(), m.start()) for m in _TOKEN.finditer(text)]
        self.line_starts = [0, *(m.end() for m in re.finditer("\n", text))]
        self.path = path
        self.at = 0

    def line(self, index: int | None = None) -> int | None:
        k = self.at if index is None else index
        if k >= len(self.tokens):
            return len(self.line_starts) if self.tokens else None
        return bisect.bisect_right(self.line_starts, self.tokens[k][1])

    def error(self, message: str, index: int | None = None) -> FormatError:
        return FormatError(message, path=self.path, line=self.line(index))

    def word(self, what: str) -> str:
        if self.at >= len(self.tokens):
            raise self.error(f"the file ends where {what} should be")
        token = self.tokens[self.at][0]
        self.at += 1
        return token

    def count(self, what: str, limit: int | None = None) -> int:
        token = self.word(what)
        if not _COUNT.fullmatch(token):
            raise self.error(f"{what} must be a whole number, got {token[:40]!r}", self.at - 1)
        value = int(token)
        if limit is not None and value >= limit:
            raise self.error(f"{what} is {value}, but there are only {limit}", self.at - 1)
        return value


def read(path: str | Path, *, limits: ReadLimits | None = None) -> BayesNet:
    """Read a UAI file (``.uai``, optionally ``.gz``).

    Raises
    ------
    FormatError
        Unreadable, malformed or inconsistent file, a Markov network, or a file past a
        :class:`ReadLimits` limit; the message names file and line.
    """
    return loads(read_source(path, limits), path=str(path), limits=limits)


def loads(
    text: str | bytes, *, path: str | None = None, limits: ReadLimits | None = None
) -> BayesNet:
    """Parse UAI text; ``path`` only names the source in error messages."""
    tokens = _Tokens(decode(text), path)
    kind = tokens.word("the network type (BAYES)")
    if kind.upper() == "MARKOV":
        raise tokens.error(
            "a MARKOV network (undirected factors) is not a Bayesian network; bayesmap reads "
            "BAYES networks",
            0,
        )
    if kind.upper() != "BAYES":
        raise tokens.error(f"a UAI file starts with BAYES, not {kind[:40]!r}", 0)
    n = tokens.count("the number of variables")
    budget = TableBudget(limits)
    cards = [tokens.count(f"the number of states of variable {i}") for i in range(n)]
    for i, card in enumerate(cards):
        if card == 0:
            raise tokens.error(f"variable {i} has no states", tokens.at - n + i)
        # a number of states is one token, unlike the other formats' lists of names: check
        # it against the table limit (its own table holds at least that many entries)
        # before its state names are made
        check_size(
            f"states of variable {i}",
            card,
            budget.limits.max_table_entries,
            "max_table_entries",
            path=path,
            line=tokens.line(tokens.at - n + i),
        )
    functions = tokens.count("the number of functions")
    if functions != n:
        raise tokens.error(
            f"{functions} functions for {n} variables: a BAYES network has one per variable",
            tokens.at - 1,
        )
    scopes: list[list[int]] = []
    owner: dict[int, int] = {}
    for f in range(functions):
        start = tokens.at
        size = tokens.count(f"the scope size of function {f}", n + 1)
        if size == 0:
            raise tokens.error(f"function {f} has an empty scope", start)
        scope = [tokens.count(f"a variable of function {f}", n) for _ in range(size)]
        if len(set(scope)) != size:
            raise tokens.error(f"function {f} lists a variable twice: {scope}", start)
        child = scope[-1]
        if child in owner:
            raise tokens.error(
                f"functions {owner[child]} and {f} both end with variable {child}: each "
                "variable has one table",
                start,
            )
        owner[child] = f
        scopes.append(scope)
    specs: dict[int, VariableSpec] = {
        i: VariableSpec(str(i), tuple(map(str, range(card))), Location(path, None, f"variable {i}"))
        for i, card in enumerate(cards)
    }
    for f, scope in enumerate(scopes):
        child, parents = scope[-1], scope[:-1]
        where = Location(path, tokens.line(), f"table {f} (of variable {child})")
        expected = budget.claim(str(child), cards[child], [cards[p] for p in parents], where)
        entries = tokens.count(f"the number of entries of table {f}")
        if entries != expected:
            raise tokens.error(
                f"table {f} (of variable {child}) has {entries} entries, its scope "
                f"{scope} needs {expected}",
                tokens.at - 1,
            )
        first = tokens.at
        if first + entries > len(tokens.tokens):
            raise tokens.error(f"the file ends inside table {f} (of variable {child})")
        words = [token for token, _ in tokens.tokens[first : first + entries]]
        tokens.at += entries
        values = probabilities(words, _locator(tokens, first, where))
        table = values.reshape([cards[p] for p in parents] + [cards[child]])
        spec = specs[child]
        spec.parents = tuple(str(p) for p in parents)
        spec.cpt = np.moveaxis(table, -1, 0)
        spec.cpt_where = where
    if tokens.at < len(tokens.tokens):
        raise tokens.error(f"text after the last table: {tokens.tokens[tokens.at][0][:40]!r}")
    name = re.sub(r"(\.uai)?(\.gz)?$", "", Path(path).name, flags=re.IGNORECASE) if path else ""
    return build_network(name or "network", specs.values(), path=path)


def _locator(tokens: _Tokens, first: int, where: Location) -> Callable[[int], Location]:
    """Where the ``k``-th entry of a table whose first entry is token ``first`` stands."""
    return lambda k: Location(where.path, tokens.line(first + k), where.element)


def write(net: BayesNet, path: str | Path) -> Path:
    """Write ``net`` as UAI to ``path`` (gzipped if it ends in ``.gz``), atomically."""
    return write_output(path, dumps(net, path=str(path)))


def dumps(net: BayesNet, *, path: str | None = None) -> str:
    """``net`` as UAI text (structure and tables only: the format holds no names)."""
    index = {name: i for i, name in enumerate(net.variables)}
    out = ["BAYES", str(len(index))]
    out.append(" ".join(str(len(net.states(name))) for name in net.variables))
    out.append(str(len(index)))
    for name in net.variables:
        scope = [index[p] for p in net.parents(name)] + [index[name]]
        out.append(" ".join(map(str, [len(scope), *scope])))
    out.append("")
    for name in net.variables:
        table = np.moveaxis(net.cpt(name), 0, -1)
        out.append(str(table.size))
        out.append(" " + table_values(table))
        out.append("")
    return "\n".join(out)
