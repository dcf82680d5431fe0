"""Logical propositions over variable states (Post et al. 2016 §2.4, eqs. 15–21).

A proposition is built from ``variable == state`` terms with conjunction ``&`` (∧),
disjunction ``|`` (∨) and negation ``~`` (¬)::

    >>> p = (V("Rain") == "yes") & ~(V("Sprinkler") == "on")
    >>> str(p)
    '(Rain=yes and not Sprinkler=on)'

    >>> parse("Rain=yes and not Sprinkler=on") == p
    True

Its probability is the sum of the exact joint posterior of the variables it mentions
over the states where it holds, so and/or/not follow eqs. 15–18 exactly. (Eq. 16 of the
paper prints the disjunction rule with ``P(y)P(x, y)`` as the last term; the rule used here
is the correct ``P(x ∨ y) = P(x) + P(y) − P(x ∧ y)``.)
"""

from __future__ import annotations

import abc
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from bayesmap._typing import BoolArray, IntArray
from bayesmap.errors import InputError

StateIndex = Callable[[str, str], int]
"""``(variable, state name) -> state index`` of the network being asked."""


class Proposition(abc.ABC):
    """Base of the proposition tree; combine with ``&``, ``|`` and ``~``."""

    def __and__(self, other: Proposition) -> Proposition:
        return And(self, _checked(other))

    def __or__(self, other: Proposition) -> Proposition:
        return Or(self, _checked(other))

    def __invert__(self) -> Proposition:
        return Not(self)

    @abc.abstractmethod
    def variables(self) -> tuple[str, ...]:
        """Variables mentioned, in order of first appearance."""

    @abc.abstractmethod
    def holds(self, grids: Mapping[str, IntArray], index: StateIndex) -> BoolArray:
        """Where the proposition is true, given each variable's state index on a grid."""


@dataclass(frozen=True, eq=True)
class Is(Proposition):
    """The atom ``variable = state``."""

    variable: str
    state: str

    def variables(self) -> tuple[str, ...]:
        """Just this variable."""
        return (self.variable,)

    def holds(self, grids: Mapping[str, IntArray], index: StateIndex) -> BoolArray:
        """True where the variable is in this state."""
        return np.asarray(grids[self.variable] == index(self.variable, self.state))

    def __str__(self) -> str:
        return f"{_quote(self.variable)}={_quote(self.state)}"


@dataclass(frozen=True, eq=True)
class And(Proposition):
    """Conjunction ``left ∧ right``."""

    left: Proposition
    right: Proposition

    def variables(self) -> tuple[str, ...]:
        """Variables of both sides."""
        return tuple(dict.fromkeys(self.left.variables() + self.right.variables()))

    def holds(self, grids: Mapping[str, IntArray], index: StateIndex) -> BoolArray:
        """Both sides hold."""
        return self.left.holds(grids, index) & self.right.holds(grids, index)

    def __str__(self) -> str:
        return f"({self.left} and {self.right})"


@dataclass(frozen=True, eq=True)
class Or(Proposition):
    """Disjunction ``left ∨ right``."""

    left: Proposition
    right: Proposition

    def variables(self) -> tuple[str, ...]:
        """Variables of both sides."""
        return tuple(dict.fromkeys(self.left.variables() + self.right.variables()))

    def holds(self, grids: Mapping[str, IntArray], index: StateIndex) -> BoolArray:
        """Either side holds."""
        return self.left.holds(grids, index) | self.right.holds(grids, index)

    def __str__(self) -> str:
        return f"({self.left} or {self.right})"


@dataclass(frozen=True, eq=True)
class Not(Proposition):
    """Negation ``¬ operand``."""

    operand: Proposition

    def variables(self) -> tuple[str, ...]:
        """Variables of the operand."""
        return self.operand.variables()

    def holds(self, grids: Mapping[str, IntArray], index: StateIndex) -> BoolArray:
        """The operand does not hold."""
        return ~self.operand.holds(grids, index)

    def __str__(self) -> str:
        return f"not {self.operand}"


class V:
    """A variable handle for writing atoms: ``V("Rain") == "yes"`` is ``Is("Rain", "yes")``."""

    __hash__ = None  # type: ignore[assignment]

    def __init__(self, name: str) -> None:
        self.name = name

    def __eq__(self, state: object) -> Is:  # type: ignore[override]
        return Is(self.name, str(state))

    def __ne__(self, state: object) -> Not:  # type: ignore[override]
        return Not(Is(self.name, str(state)))


def _checked(other: object) -> Proposition:
    if not isinstance(other, Proposition):
        raise InputError(f"cannot combine a proposition with {other!r}; use V(name) == state")
    return other


_TOKEN = r"""\s*(?:
        (?P<op>==|!=|=|&&|\|\||[&|!~¬∧∨()])
      | (?P<quoted>"(?:[^"\\]|\\.)*"|'(?:[^'\\]|\\.)*')
      | (?P<word>[^\s&|!~¬∧∨()="']+)
    )"""
"""One token (verbose regular expression), compiled by the first :func:`parse` and kept in
:mod:`re`'s cache, so importing the module compiles nothing."""
_KEYWORDS = {"and": "&", "or": "|", "not": "!"}
_SYMBOLS = {"&&": "&", "∧": "&", "||": "|", "∨": "|", "~": "!", "¬": "!", "==": "="}


def parse(text: str, *, bar: bool = True) -> Proposition:
    """Parse a proposition such as ``'Rain=yes and not (Sprinkler=on or "Wet grass"=no)'``.

    Atoms are ``name = state`` (or ``==``; ``!=`` negates); names and states containing
    spaces or operator characters are quoted with ``"`` or ``'``. Operators: ``and``/``&``/
    ``∧``, ``or``/``|``/``∨``, ``not``/``!``/``~``/``¬``, with ``not`` binding tighter than
    ``and``, and ``and`` tighter than ``or``; parentheses group. Propositions print with the
    words, so that a printed ``P(A=x or B=y | evidence)`` cannot be misread.

    Parameters
    ----------
    text
        The proposition.
    bar
        Accept ``|`` and ``||`` for ``or``. A reader of ``P(A=x | B=y)`` sees a conditional
        probability, so front ends that print the question (the CLI) refuse the bar and
        take the condition separately (``given``).

    Raises
    ------
    InputError
        The text is not a proposition; the message gives the position.
    """
    raw_tokens = _tokenise(text)
    if not bar and any(token == ("op", "|") and raw in ("|", "||") for token, raw in raw_tokens):
        raise InputError(
            f"proposition {text!r}: '|' would read as 'given'; write 'or' for a disjunction "
            "and pass a condition separately (given=..., or --given on the command line)"
        )
    tokens = [token for token, _ in raw_tokens]
    position = 0

    def peek() -> tuple[str, str] | None:
        return tokens[position] if position < len(tokens) else None

    def take(expected: str | None = None) -> tuple[str, str]:
        nonlocal position
        token = peek()
        if token is None or (expected is not None and token != ("op", expected)):
            found = "the end" if token is None else repr(token[1])
            want = f"{expected!r}" if expected else "more"
            raise InputError(f"proposition {text!r}: expected {want}, found {found}")
        position += 1
        return token

    def disjunction() -> Proposition:
        left = conjunction()
        while peek() == ("op", "|"):
            take()
            left = Or(left, conjunction())
        return left

    def conjunction() -> Proposition:
        left = unary()
        while peek() == ("op", "&"):
            take()
            left = And(left, unary())
        return left

    def unary() -> Proposition:
        token = peek()
        if token == ("op", "!"):
            take()
            return Not(unary())
        if token == ("op", "("):
            take()
            inner = disjunction()
            take(")")
            return inner
        kind, name = take()
        if kind != "name":
            raise InputError(f"proposition {text!r}: expected a variable name, found {name!r}")
        kind, op = take()
        if kind != "op" or op not in ("=", "!="):
            raise InputError(f"proposition {text!r}: expected '=' after {name!r}, found {op!r}")
        kind, state = take()
        if kind != "name":
            raise InputError(f"proposition {text!r}: expected a state after '{name} {op}'")
        atom = Is(name, state)
        return Not(atom) if op == "!=" else atom

    result = disjunction()
    if position != len(tokens):
        raise InputError(f"proposition {text!r}: unexpected {tokens[position][1]!r}")
    return result


def _quote(text: str) -> str:
    """``text`` as one parser token: bare if it can be, else double-quoted."""
    bare = re.fullmatch(r"[^\s&|!~¬∧∨()=\"']+", text) and text.lower() not in _KEYWORDS
    if bare:
        return text
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _tokenise(text: str) -> list[tuple[tuple[str, str], str]]:
    """``[((kind, value), raw text)]`` of a proposition; kind is "op" or "name"."""
    tokens: list[tuple[tuple[str, str], str]] = []
    token = re.compile(_TOKEN, re.VERBOSE)
    position = 0
    stripped = text.rstrip()
    while position < len(stripped):
        match = token.match(stripped, position)
        if match is None or match.end() == position:
            raise InputError(f"proposition {text!r}: cannot read from position {position}")
        position = match.end()
        if match.group("op"):
            op = match.group("op")
            tokens.append((("op", _SYMBOLS.get(op, op)), op))
        elif match.group("quoted"):
            quoted = match.group("quoted")
            tokens.append((("name", re.sub(r"\\(.)", r"\1", quoted[1:-1])), quoted))
        else:
            word = match.group("word")
            keyword = _KEYWORDS.get(word.lower())
            tokens.append((("op", keyword) if keyword else ("name", word), word))
    if not tokens:
        raise InputError("empty proposition; write e.g. 'Rain=yes & Sprinkler=off'")
    return tokens
