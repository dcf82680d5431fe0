"""Hugin's NET format (``.net``): the discrete chance nodes and conditional tables of a network.

The format of the Hugin tools, also read and written by pyAgrum, GeNIe and bnlearn::

    net { name = "rain"; }
    node Rain { label = "Rain"; states = ("no" "yes"); position = (100 50); }
    node Wet { states = ("dry" "wet"); }
    potential (Rain) { data = (0.8 0.2); }
    potential (Wet | Rain) { data = ((0.9 0.1)    % Rain = no
                                     (0.2 0.8));  % Rain = yes
    }

Reading
    ``%`` starts a comment to the end of its line. Blocks come in any order: one optional
    ``net`` block, whose attributes become the network's properties (``name`` its name),
    ``node`` blocks (optionally ``discrete``, ``labelled``, ``numbered``, ``interval`` or
    ``boolean``; a ``boolean`` node without ``states`` has the states ``false``, ``true``),
    whose ``states`` list names the states (strings, or numbers kept as written; where the
    labels are empty, the ``state_values`` name them: ``[0, 18)`` for an interval node, the
    numbers of a numbered one) and whose other attributes become properties (``kind`` the
    node kind, as in the other formats), and one ``potential ( child | parents )`` block
    per node, whose ``data`` lists the probabilities with the first parent's state slowest
    and the child's fastest; the parentheses that group them are checked for balance and
    otherwise ignored, each distribution is normalised as Hugin does (a table of weights
    is a valid NET table), and other potential attributes (``experience``, ``fading``) are
    passed over. A plain network saved as a ``class`` (as the Hugin tools save one) reads
    as the network, named after the class; its empty ``inputs`` and ``outputs`` lists are
    dropped and its other attributes become properties.

    What a Bayesian network of discrete chance nodes cannot hold is refused with the line
    it is on: decision, utility, continuous and function nodes, instances of classes and
    several classes in one file (object-oriented networks), temporal clones, tables given
    by expressions (``model_nodes``, ``model_data``) and potentials over more than one
    node. One pass of a regular-expression tokenizer does the work, so the time is linear
    in the size of the file; a table's size is checked against
    :class:`~bayesmap.limits.ReadLimits` before it is allocated.
Writing
    Node names must be NET names (a letter or ``_``, then letters, digits or ``_``);
    anything else is refused, since the format has no way to quote them. Every node gets
    a ``label`` (its ``label`` property, else its name) and ``states``; other properties
    become attributes, written as they are when they read as a NET list of numbers
    (``position = (100 50)``), else as strings. Probabilities are written with the
    shortest text that gives back the same double.

Every problem raises :class:`~bayesmap.errors.FormatError` naming the file and line.
"""

from __future__ import annotations

import bisect
import math
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

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
    table_values,
    unescape,
    write_output,
)
from bayesmap.bn.model import WARN_TOLERANCE, BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["dumps", "loads", "read", "write"]

_TOKEN = re.compile(
    r'(?P<space>\s+)|(?P<comment>%[^\n]*)|(?P<string>"(?:[^"\\\n]|\\[^\n])*")'
    r'|(?P<open_quote>")|(?P<punct>[{}()=;|])|(?P<word>[^\s{}()=;|"%]+)'
)
"""One token of a NET file; blank space and comments are skipped, a quote that does not
close on its line is an error."""
_DATA_MARK = re.compile(r'[()]|%[^\n]*|[{}=;|"]')
"""What a list of numbers is scanned for: its parentheses, comments, and what ends it badly."""
_COMMENT = re.compile(r"%[^\n]*")
_BLOCK_MARK = re.compile(r'"(?:[^"\\\n]|\\[^\n])*"|%[^\n]*|[{}"]')
"""What a skipped block is scanned for: its braces, and strings and comments that may hide
braces."""
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
"""A NET name: the only names a node may have."""
_NUMBER_LIST = re.compile(r"\(\s*(?:[-+]?[0-9][0-9.eE+-]*[\s,]*)*\)")
"""A property value written as a NET list of numbers (``position = (100 50)``; BIF's
``(100, 50)`` loses its commas)."""
_NODE_TYPES = {"discrete", "labelled", "numbered", "interval", "boolean"}
_OBJECT_ORIENTED = {
    "class": "a second class (an object-oriented network of several classes)",
    "instance": "an instance of a class (an object-oriented network; save it flat)",
    "temporal": "a temporal clone (a dynamic network)",
}
_CLASS_INTERFACE = {"inputs", "outputs"}
"""A class's interface lists, dropped when empty (a plain network saved as a class)."""
_REFUSED_NODES = {
    "decision": "a decision node (influence diagrams are not Bayesian networks)",
    "utility": "a utility node (influence diagrams are not Bayesian networks)",
    "continuous": "a continuous node (only discrete nodes are read)",
    "function": "a function node (only chance nodes with tables are read)",
}


# ---------------------------------------------------------------------------- reading
def read(path: str | Path, *, limits: ReadLimits | None = None) -> BayesNet:
    """Read a Hugin NET file (``.net`` or ``.net.gz``) into a new :class:`BayesNet`.

    Raises
    ------
    FormatError
        The file cannot be read, is malformed, holds what a Bayesian network of discrete
        chance nodes cannot, passes a :class:`ReadLimits` limit or describes an
        inconsistent network; the message names the file and line.
    """
    return loads(read_source(path, limits), path=str(path), limits=limits)


def loads(
    text: str | bytes, *, path: str | None = None, limits: ReadLimits | None = None
) -> BayesNet:
    """Parse NET text; ``path`` only names the source in error messages."""
    decoded = decode(text)
    parser = _Parser(decoded, path, TableBudget(limits))
    if parser.at_end():
        raise FormatError("the file is empty; a NET network has 'node' blocks", path=path)
    return parser.parse()


Token = tuple[str, str, int]
"""A token: its kind (``string``, ``punct`` or ``word``), its text and its offset."""


class _Parser:
    """One pass over a NET text, reading tokens as it goes (a cursor, ``pos``)."""

    def __init__(self, text: str, path: str | None, budget: TableBudget) -> None:
        self.text = text
        self.path = path
        self.budget = budget
        self.pos = 0
        self._lookahead: Token | None = None
        self._newlines: list[int] | None = None

    # ------------------------------------------------------------------ tokens
    def error(self, offset: int, message: str, element: str | None = None) -> FormatError:
        return FormatError(message, path=self.path, line=self.line(offset), element=element)

    def line(self, offset: int) -> int:
        """The 1-based line of ``offset``."""
        if self._newlines is None:
            self._newlines = [m.start() for m in re.finditer("\n", self.text)]
        return bisect.bisect_left(self._newlines, offset) + 1

    def _scan(self) -> Token | None:
        """The token at the cursor (blank space and comments passed over), not consumed."""
        if self._lookahead is None:
            while True:
                match = _TOKEN.match(self.text, self.pos)
                if match is None:
                    return None
                kind = match.lastgroup
                if kind not in ("space", "comment"):
                    break
                self.pos = match.end()
            if kind == "open_quote":
                raise self.error(match.start(), "unterminated string (it must close on its line)")
            assert kind is not None
            self._lookahead = (kind, match.group(), match.start())
        return self._lookahead

    def at_end(self) -> bool:
        return self._scan() is None

    def _at(self) -> int:
        """The offset of the next token (the end of the text when there is none)."""
        token = self._scan()
        return token[2] if token is not None else len(self.text)

    def _next(self, what: str) -> Token:
        token = self._scan()
        if token is None:
            raise self.error(len(self.text), f"the file ends where {what} should be")
        self._lookahead = None
        self.pos = token[2] + len(token[1])
        return token

    def _seek(self, offset: int) -> None:
        self.pos = offset
        self._lookahead = None

    def _expect(self, punct: str, what: str) -> int:
        kind, text, offset = self._next(f"'{punct}' ({what})")
        if kind != "punct" or text != punct:
            raise self.error(offset, f"expected '{punct}' ({what}), found {text[:40]!r}")
        return offset

    def _peek(self, punct: str) -> bool:
        token = self._scan()
        return token is not None and token[0] == "punct" and token[1] == punct

    def _name(self, what: str) -> tuple[str, int]:
        kind, text, offset = self._next(what)
        if kind != "word" or not _NAME.fullmatch(text):
            raise self.error(offset, f"expected {what}, found {text[:40]!r}")
        return text, offset

    # ------------------------------------------------------------------ blocks
    def parse(self) -> BayesNet:
        name = "network"
        net_properties: dict[str, str] = {}
        specs: dict[str, VariableSpec] = {}
        potentials: list[int] = []  # where each potential block starts, after its keyword
        seen_net = False
        in_class = self._class_header()
        if in_class is not None:
            name = in_class
        while True:
            if in_class is not None and self._peek("}"):
                self._next("'}'")
                if not self.at_end():
                    raise self.error(self._at(), "text after the end of the class")
                break
            if self.at_end():
                if in_class is not None:
                    raise self.error(len(self.text), f"class {in_class!r} is never closed")
                break
            kind, word, offset = self._next("a block")
            if kind != "word":
                raise self.error(offset, f"expected 'net', 'node' or 'potential', found {word!r}")
            if in_class is not None and self._peek("="):
                self._next("'='")
                value = self._value(word, "class", None)
                if word in net_properties:
                    raise self.error(offset, f"class: attribute {word!r} is given twice")
                if word not in _CLASS_INTERFACE or value.text:
                    net_properties[word] = value.as_property()
            elif word == "net" and in_class is None:
                if seen_net:
                    raise self.error(offset, "a second 'net' block")
                seen_net = True
                attributes = self._attributes("net block")
                net_name = attributes.pop("name", None)
                if net_name is not None and net_name.text:
                    name = net_name.as_property()
                net_properties = {key: value.as_property() for key, value in attributes.items()}
            elif word == "potential":
                potentials.append(self.pos)
                self._skip_block()
            elif word in _OBJECT_ORIENTED:
                raise self.error(offset, f"{_OBJECT_ORIENTED[word]} is not read")
            else:
                spec = self._node(word, offset)
                if spec.name in specs:
                    first = specs[spec.name].where.line
                    raise self.error(
                        offset, f"node {spec.name!r} is declared twice (first on line {first})"
                    )
                specs[spec.name] = spec
        done: dict[str, int] = {}
        for start in potentials:
            self._seek(start)
            self._potential(specs, done)
        return build_network(name, specs.values(), properties=net_properties, path=self.path)

    def _class_header(self) -> str | None:
        """``class NAME {`` opening the file (the Hugin tools save a plain network so), and
        the class's name; ``None`` for a file of ``net``, ``node`` and ``potential`` blocks."""
        token = self._scan()
        if token is None or token[:2] != ("word", "class"):
            return None
        self._next("'class'")
        name, _ = self._name("the class name")
        self._expect("{", f"class {name!r}")
        return name

    def _node(self, word: str, offset: int) -> VariableSpec:
        """A node block, from its first word (``node`` or a node type) on."""
        types: list[str] = []
        while word != "node":
            if word in _REFUSED_NODES:
                raise self.error(offset, f"{_REFUSED_NODES[word]} is not read")
            if word not in _NODE_TYPES:
                raise self.error(
                    offset, f"expected 'net', 'node' or 'potential', found {word[:40]!r}"
                )
            types.append(word)
            kind, word, offset = self._next("'node'")
            if kind != "word":
                raise self.error(offset, f"expected 'node', found {word!r}")
        name, at = self._name("a node name")
        line = self.line(at)
        where = Location(self.path, line, f"node {name!r}")
        attributes = self._attributes(f"node {name!r}")
        states = self._states(name, types, attributes, at)
        if len(set(states)) != len(states):
            duplicated = sorted({s for s in states if states.count(s) > 1})
            raise self.error(at, f"node {name!r} lists state(s) {duplicated} twice")
        properties = {key: value.as_property() for key, value in attributes.items()}
        if properties.get("label") == name:
            del properties["label"]  # the writer's default, not information
        return VariableSpec(name, tuple(states), where, properties=properties)

    def _potential(self, specs: dict[str, VariableSpec], done: dict[str, int]) -> None:
        start = self._expect("(", "the potential's nodes")
        heads: list[str] = []
        parents: list[str] = []
        into = heads
        while not self._peek(")"):
            if self._peek("|"):
                if into is parents:
                    raise self.error(self._at(), "a second '|' in the potential's header")
                into = parents
                self._next("'|'")
                continue
            into.append(self._name("a node name in the potential's header")[0])
        self._next("')'")
        if len(heads) != 1:
            raise self.error(
                start,
                f"a potential must be over exactly one node (given its parents), found {heads}",
            )
        child = heads[0]
        element = f"potential of {child!r}"
        line = self.line(start)
        if child not in specs:
            raise self.error(start, f"{element}: node {child!r} is not declared")
        if child in done:
            raise self.error(start, f"a second {element} (first on line {done[child]})")
        for parent in parents:
            if parent not in specs:
                raise self.error(start, f"{element}: parent {parent!r} is not declared")
        if len(set(parents)) != len(parents) or child in parents:
            raise self.error(start, f"{element}: a node is listed twice in {[child, *parents]}")
        done[child] = line
        spec = specs[child]
        where = Location(self.path, line, element)
        attributes = self._attributes(element, numbers="data")
        for refused in ("model_nodes", "model_data"):
            if refused in attributes:
                raise self.error(
                    attributes[refused].offset,
                    f"{element}: a table given by expressions ({refused}) is not read; "
                    "write its numbers as 'data'",
                )
        if "data" not in attributes:
            raise self.error(start, f"{element} has no 'data'")
        cards = [len(specs[p].states) for p in parents]
        entries = self.budget.claim(child, len(spec.states), cards, where)
        data = attributes["data"]
        at = data.offset
        numbers = data.text.split()
        if len(numbers) != entries:
            raise self.error(
                at,
                f"{element}: 'data' has {len(numbers)} probabilities, expected {entries} "
                f"({len(spec.states)} states x {math.prod(cards)} parent combinations)",
            )
        values = probabilities(numbers, Location(self.path, line, element))
        # data: the parents in their order, the child fastest; a CPT: (child, *parents)
        cpt = np.moveaxis(values.reshape(*cards, len(spec.states)), -1, 0)
        # Hugin normalises each distribution itself (a table of counts or weights is a
        # valid NET table); rounding is left to the model's own policy
        sums = cpt.sum(axis=0, keepdims=True)
        if np.any(sums <= 0.0):
            raise self.error(at, f"{element}: a distribution in 'data' sums to 0 or less")
        spec.cpt = np.where(np.abs(sums - 1.0) > WARN_TOLERANCE, cpt / sums, cpt)
        spec.parents = tuple(parents)
        spec.cpt_where = where

    def _skip_block(self) -> None:
        """Pass over a potential's header and body (parsed once every node is known): one
        scan of the text for its braces, strings and comments."""
        depth = 0
        for match in _BLOCK_MARK.finditer(self.text, self.pos):
            mark = match.group()
            if mark == "{":
                depth += 1
            elif mark == "}":
                depth -= 1
                if depth <= 0:
                    self._seek(match.end())
                    return
            elif mark == '"':
                raise self.error(match.start(), "unterminated string (it must close on its line)")
        raise self.error(len(self.text), "the file ends inside a potential block")

    def _attributes(self, element: str, numbers: str | None = None) -> dict[str, _Value]:
        """``{ key = value; ... }``: each value (see :meth:`_value`) by its key."""
        self._expect("{", f"{element}'s attributes")
        attributes: dict[str, _Value] = {}
        while not self._peek("}"):
            key, at = self._name(f"an attribute name in the {element}")
            self._expect("=", f"after {key!r}")
            value = self._value(key, element, numbers)
            if key in attributes:
                raise self.error(at, f"{element}: attribute {key!r} is given twice")
            attributes[key] = value
        self._next("'}'")
        return attributes

    def _value(self, key: str, element: str, numbers: str | None) -> _Value:
        """An attribute's value after its ``=``, and the ``;`` that ends it: the value, where
        it starts and whether it is a list.

        A list keeps its items, strings unescaped, each after a ``\\x1f`` (strings may hold
        spaces); the attribute named ``numbers`` keeps only its words, separated by
        spaces, for :func:`~bayesmap.bn.io._common.probabilities`.
        """
        kind, text, offset = self._next(f"the value of {key!r}")
        if kind == "string":
            value = _Value(unescape(text[1:-1]), offset, False)
        elif kind == "word":
            value = _Value(text, offset, False)
        elif text == "(":
            items = self._list_items(offset, key, numbers_only=key == numbers)
            value = _Value(items, offset, True)
        else:
            raise self.error(offset, f"{element}: {key!r} has no value before {text!r}")
        self._expect(";", f"after the value of {key!r}")
        return value

    def _list_items(self, offset: int, key: str, *, numbers_only: bool) -> str:
        """The items of a list whose ``(`` was just read, to its matching ``)``."""
        if numbers_only:
            return self._numbers(offset, key)
        depth = 1
        items: list[str] = []
        while depth:
            kind, text, at = self._next(f"the ')' closing {key!r}")
            if kind == "punct":
                if text == "(":
                    depth += 1
                elif text == ")":
                    depth -= 1
                else:
                    raise self.error(at, f"{key!r}: unexpected {text!r} in a list")
            else:
                items.append(unescape(text[1:-1]) if kind == "string" else text)
        return "".join("\x1f" + item for item in items)

    def _numbers(self, offset: int, key: str) -> str:
        """A list of numbers (``data``), its grouping parentheses checked and dropped: one
        scan of the text for parentheses, comments and what may not stand in a list."""
        depth = 1
        for match in _DATA_MARK.finditer(self.text, self.pos):
            mark = match.group()
            if mark == "(":
                depth += 1
            elif mark == ")":
                depth -= 1
                if depth == 0:
                    body = _COMMENT.sub(" ", self.text[self.pos : match.start()])
                    self._seek(match.end())
                    return body.replace("(", " ").replace(")", " ")
            elif not mark.startswith("%"):
                raise self.error(match.start(), f"{key!r}: {mark[:40]!r} in a list of numbers")
        raise self.error(offset, f"{key!r}: the list opened here is never closed")

    def _states(
        self, name: str, types: list[str], attributes: dict[str, _Value], at: int
    ) -> list[str]:
        """A node's states: its ``states`` list; ``false``, ``true`` for a boolean node
        without one; and, where the labels are empty, names from its ``state_values``
        (an interval node's ``[a, b)``, a numbered node's numbers), as Hugin shows them."""
        value = attributes.pop("states", None)
        if value is None:
            if "boolean" not in types:
                raise self.error(at, f"node {name!r} has no 'states' list")
            return ["false", "true"]
        if not value.is_list:
            raise self.error(value.offset, f"states of {name!r}: expected a list ( ... )")
        states = value.items()
        if not states:
            raise self.error(at, f"node {name!r} has an empty 'states' list")
        given = attributes.get("state_values")
        if not all(states) and given is not None and given.is_list:
            values = given.items()
            if len(values) == len(states) + 1:  # interval bounds
                bounds = zip(values[:-1], values[1:], strict=True)
                states = [
                    label or f"[{a}, {b})" for label, (a, b) in zip(states, bounds, strict=True)
                ]
            elif len(values) == len(states):
                states = [label or v for label, v in zip(states, values, strict=True)]
        if not all(states):
            raise self.error(value.offset, f"states of {name!r}: an empty name")
        return states


class _Value(NamedTuple):
    """An attribute's value: its text (a list's items, each after a ``\\x1f``), where it
    starts, and whether it is a list."""

    text: str
    offset: int
    is_list: bool

    def items(self) -> list[str]:
        """A list's items."""
        return self.text.split("\x1f")[1:]

    def as_property(self) -> str:
        """The value as a property: a list as ``(a b c)``, as NET writes it."""
        return "(" + " ".join(self.items()) + ")" if self.is_list else self.text


# ---------------------------------------------------------------------------- writing
def write(net: BayesNet, path: str | Path) -> Path:
    """Write ``net`` as a Hugin NET file to ``path`` (gzipped if it ends in ``.gz``), atomically."""
    return write_output(path, dumps(net, path=str(path)))


def dumps(net: BayesNet, *, path: str | None = None) -> str:
    """``net`` as NET text.

    Raises
    ------
    FormatError
        A node name that is not a NET name, or a name or property the format cannot hold
        exactly.
    """
    out = ["net\n{\n", f"    name = {quoted(net.name or 'network')};\n"]
    out.extend(_attribute_lines(net.properties, "network", path))
    out.append("}\n")
    for name in net.variables:
        variable = net.variable(name)
        if not _NAME.fullmatch(name):
            raise FormatError(
                f"variable {name!r} is not a NET name (a letter or '_', then letters, digits "
                "or '_'); rename it, or write BIF or XMLBIF, which keep any name",
                path=path,
            )
        for state in variable.states:
            check_name(f"state of {name!r}", state, path=path)
        props = properties_with_kind(variable, path=path)
        label = props.pop("label", name)
        states = " ".join(quoted(s) for s in variable.states)
        out.append(f"\nnode {name}\n{{\n    label = {quoted(label)};\n    states = ({states});\n")
        out.extend(_attribute_lines(props, f"variable {name!r}", path))
        out.append("}\n")
    for name in net.variables:
        variable = net.variable(name)
        parents = variable.parents
        header = f"{name} | {' '.join(parents)}" if parents else name
        if parents:
            rows = np.moveaxis(variable.cpt, 0, -1).reshape(-1, variable.cpt.shape[0])
            data = "(" + "\n             ".join(f"({table_values(row)})" for row in rows) + ")"
        else:
            data = f"({table_values(variable.cpt)})"
        out.append(f"\npotential ({header})\n{{\n    data = {data};\n}}\n")
    return "".join(out)


def _attribute_lines(props: dict[str, str], owner: str, path: str | None) -> list[str]:
    lines = []
    for key, value in props.items():
        check_property(owner, key, value, path=path)
        if not _NAME.fullmatch(key) or key in ("name", "label", "states", "data"):
            raise FormatError(
                f"{owner}: property {key!r} cannot be a NET attribute (its name must be a "
                "NET name other than name, label, states and data); rename it",
                path=path,
            )
        if _NUMBER_LIST.fullmatch(value):
            text = "(" + " ".join(value[1:-1].replace(",", " ").split()) + ")"
        else:
            text = quoted(value)
        lines.append(f"    {key} = {text};\n")
    return lines
