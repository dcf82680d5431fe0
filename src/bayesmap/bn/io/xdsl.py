"""GeNIe's XDSL (``.xdsl``): the XML network format of BayesFusion's GeNIe and SMILE.

::

    <smile version="1.0" id="rain" numsamples="10000" discsamples="10000">
      <nodes>
        <cpt id="Rain">
          <state id="no" />
          <state id="yes" />
          <probabilities>0.8 0.2</probabilities>
          <property id="kind">B</property>
        </cpt>
        <cpt id="Wet">
          <state id="dry" />
          <state id="wet" />
          <parents>Rain</parents>
          <probabilities>0.9 0.1 0.2 0.8</probabilities>
        </cpt>
      </nodes>
      <extensions>
        <genie version="1.0" app="bayesmap" name="rain">
          <node id="Rain"><name>Rain</name><position>50 40 122 88</position></node>
          ...
        </genie>
      </extensions>
    </smile>

Reading
    The ``<smile>`` root's ``id`` names the network (the ``name`` of its ``<genie>``
    extension, when there is one, wins: it keeps what an identifier cannot). Each child of
    ``<nodes>`` is a node: a ``<cpt>`` lists its ``<state id>``\\ s, its ``<parents>`` (ids,
    space-separated) and its ``<probabilities>``, for each parent configuration (the last
    parent fastest) the node's distribution — C order of a ``(*parents, node)`` array, as
    in XMLBIF; a ``<deterministic>`` node lists instead, per parent configuration, its
    ``<resultingstates>``, read as a table of zeros and ones. ``<property id="k">v</property>``
    children become the node's properties (``kind`` its node kind, Post et al. 2016
    §3.4). The ``<name>`` GeNIe shows for a node (in ``<extensions>``, possibly inside
    ``<submodel>``\\ s) becomes its ``label`` property when it differs from the id, and the
    ``<property>`` children of the root's ``<properties>`` the network's properties; the rest
    of the extensions (positions, colours, text boxes) is layout and passed over. What a
    Bayesian network of discrete chance nodes cannot hold is refused with its line:
    decision, utility and equation (continuous) nodes, and the parametric noisy-MAX and
    noisy-adder nodes (GeNIe can turn one into a plain CPT before saving).
Writing
    Node and state names must be SMILE identifiers (a letter, then letters, digits or
    ``_``); anything else is refused, since the format has no other way to name them. Every
    node is a ``<cpt>`` with its properties as ``<property>`` children, and gets a place in
    the ``<genie>`` extension: its ``label`` property (else its id) as the name GeNIe shows,
    and a position in rows by depth in the graph; the network's properties go to
    ``<properties>``. The network's id is its name with every
    character an identifier cannot hold replaced by ``_``; the name itself goes to the
    extension. Probabilities are written with the shortest text that gives back the same
    double.

Every problem raises :class:`~bayesmap.errors.FormatError` naming the file, line and element.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from lxml import etree

from bayesmap.bn.io import _xml
from bayesmap.bn.io._common import (
    Location,
    TableBudget,
    VariableSpec,
    build_network,
    check_property,
    probabilities,
    properties_with_kind,
    read_source,
    table_values,
    write_output,
)
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["dumps", "loads", "read", "write"]

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
"""A SMILE identifier: what a node, a state and a network id may be."""
_TABLE_NODES = {"CPT", "DETERMINISTIC"}
_OTHER_NODES = {
    "NOISYMAX": "a noisy-MAX node",
    "NOISYADDER": "a noisy-adder node",
    "DECISION": "a decision node",
    "UTILITY": "a utility node",
    "MAU": "a multi-attribute utility node",
    "EQUATION": "an equation (continuous) node",
}
_NODE_SIZE = (72, 48)
"""Width and height [px] of a node's box in GeNIe's layout, and the gap between boxes."""


def read(path: str | Path, *, limits: ReadLimits | None = None) -> BayesNet:
    """Read an XDSL file (``.xdsl``, optionally ``.gz``).

    Raises
    ------
    FormatError
        Unreadable, malformed or inconsistent file, a node type a Bayesian network of
        discrete chance nodes cannot hold, or a file past a :class:`ReadLimits` limit; the
        message names file, line and element.
    """
    return loads(read_source(path, limits), path=str(path), limits=limits)


def loads(
    text: str | bytes, *, path: str | None = None, limits: ReadLimits | None = None
) -> BayesNet:
    """Parse XDSL text; ``path`` only names the source in error messages."""
    root = _xml.parse(text, path)
    if _xml.tag(root) != "SMILE":
        raise _xml.error(root, path, "the root element must be <smile> (GeNIe's XDSL)")
    genie = _genie(root)
    labels = {} if genie is None else _labels(genie)
    budget = TableBudget(limits)
    specs: list[VariableSpec] = []
    elements = list(_xml.child(root, "NODES", path, "<smile>"))
    states = {
        _id(element, path): _states(element, path) for element in elements if _is_node(element)
    }
    for element in elements:
        if not _is_node(element):
            continue
        spec = _node(element, states, budget, path)
        label = labels.get(spec.name)
        if label and label != spec.name:
            spec.properties.setdefault("label", label)
        specs.append(spec)
    name = _xml.optional_attribute(root, "ID") or "network"
    if genie is not None:
        name = _xml.optional_attribute(genie, "NAME") or name
    properties: dict[str, str] = {}
    for listed in _xml.children(root, "PROPERTIES"):
        properties.update(_properties(listed, "the network", path))
    return build_network(name, specs, properties=properties, path=path)


def _is_node(element: etree._Element) -> bool:
    """Whether ``element`` (a child of ``<nodes>``) is a node: any element but comments."""
    return isinstance(element.tag, str)


def _id(element: etree._Element, path: str | None) -> str:
    node_id = _xml.attribute(element, "ID", path, "a node")
    if not node_id:
        raise _xml.error(element, path, f"<{_xml.tag(element).lower()}> with an empty id")
    return node_id


def _located(element: etree._Element, path: str | None, message: str, owner: str) -> FormatError:
    return FormatError(
        message,
        path=path,
        line=element.sourceline,
        element=f"<{_xml.tag(element).lower()}> of {owner!r}",
    )


def _states(element: etree._Element, path: str | None) -> tuple[str, ...]:
    """The ``<state id>``\\ s of a node (any kind: the refusal of other kinds comes later)."""
    name = _id(element, path)
    states = tuple(
        _xml.attribute(s, "ID", path, f"a state of {name!r}")
        for s in _xml.children(element, "STATE")
    )
    if _xml.tag(element) not in _TABLE_NODES:
        return states
    if not states:
        raise _located(element, path, f"node {name!r} has no <state>", name)
    if any(not state for state in states):
        raise _located(element, path, f"node {name!r} has a <state> with an empty name (id)", name)
    if len(set(states)) != len(states):
        twice = sorted({s for s in states if states.count(s) > 1})
        raise _located(element, path, f"node {name!r} lists state(s) {twice} twice", name)
    return states


def _node(
    element: etree._Element,
    states: dict[str, tuple[str, ...]],
    budget: TableBudget,
    path: str | None,
) -> VariableSpec:
    """A ``<cpt>`` or ``<deterministic>`` node as a variable; any other kind is refused."""
    kind = _xml.tag(element)
    name = _id(element, path)
    if kind not in _TABLE_NODES:
        what = _OTHER_NODES.get(kind, f"a <{kind.lower()}> node")
        raise _located(
            element,
            path,
            f"node {name!r} is {what}; bayesmap reads discrete chance nodes with tables "
            "(<cpt>, <deterministic>): in GeNIe, change its type to a general chance node",
            name,
        )
    parent_elements = _xml.children(element, "PARENTS")
    if len(parent_elements) > 1:
        raise _located(element, path, f"node {name!r} has {len(parent_elements)} <parents>", name)
    parents = tuple(_xml.text(parent_elements[0]).split()) if parent_elements else ()
    for parent in parents:
        if parent not in states:
            raise _located(element, path, f"parent {parent!r} of {name!r} is not a node", name)
    if len(set(parents)) != len(parents):
        raise _located(element, path, f"a parent is listed twice in {list(parents)}", name)
    own = states[name]
    where = Location(path, element.sourceline, f"<{kind.lower()}> of {name!r}")
    cards = tuple(len(states[p]) for p in parents)
    expected = budget.claim(name, len(own), cards, where)
    if kind == "CPT":
        table = _table(element, name, expected, (*cards, len(own)), path)
    else:
        table = _deterministic(element, name, own, cards, path)
    return VariableSpec(
        name,
        own,
        Location(path, element.sourceline, f"<{kind.lower()}> {name!r}"),
        parents=parents,
        cpt=np.moveaxis(table, -1, 0),
        cpt_where=where,
        properties=_properties(element, name, path),
    )


def _table(
    element: etree._Element, name: str, expected: int, shape: tuple[int, ...], path: str | None
) -> np.ndarray:
    table = _xml.child(element, "PROBABILITIES", path, f"<cpt> of {name!r}")
    tokens = _xml.text(table).split()
    if len(tokens) != expected:
        raise _located(
            table,
            path,
            f"<probabilities> has {len(tokens)} numbers, expected {expected} "
            f"({shape[-1]} states x {expected // shape[-1]} parent configurations)",
            name,
        )
    return probabilities(
        tokens, Location(path, table.sourceline, f"<probabilities> of {name!r}")
    ).reshape(shape)


def _deterministic(
    element: etree._Element,
    name: str,
    own: tuple[str, ...],
    cards: tuple[int, ...],
    path: str | None,
) -> np.ndarray:
    """The 0/1 table of a deterministic node: per parent configuration, its resulting state."""
    listed = _xml.child(element, "RESULTINGSTATES", path, f"<deterministic> of {name!r}")
    results = _xml.text(listed).split()
    configurations = int(np.prod(cards, dtype=np.int64))
    if len(results) != configurations:
        raise _located(
            listed,
            path,
            f"<resultingstates> lists {len(results)} states, expected one per parent "
            f"configuration ({configurations})",
            name,
        )
    index = {state: k for k, state in enumerate(own)}
    unknown = next((r for r in results if r not in index), None)
    if unknown is not None:
        raise _located(listed, path, f"{unknown[:40]!r} is not a state of {name!r}", name)
    table = np.zeros((configurations, len(own)))
    table[np.arange(configurations), [index[r] for r in results]] = 1.0
    return table.reshape((*cards, len(own)))


def _properties(element: etree._Element, owner: str, path: str | None) -> dict[str, str]:
    props: dict[str, str] = {}
    for prop in _xml.children(element, "PROPERTY"):
        key = _xml.attribute(prop, "ID", path, f"a property of {owner!r}")
        if not key:
            raise _xml.error(prop, path, f"a <property> of {owner!r} with an empty id")
        props[key] = _xml.text(prop)
    return props


def _genie(root: etree._Element) -> etree._Element | None:
    """The ``<genie>`` element of ``<extensions>``, if any."""
    for extensions in _xml.children(root, "EXTENSIONS"):
        for genie in _xml.children(extensions, "GENIE"):
            return genie
    return None


def _labels(genie: etree._Element) -> dict[str, str]:
    """The name GeNIe shows for each node, by id (``<node>``\\ s at any depth of submodels)."""
    labels: dict[str, str] = {}
    for node in genie.iter():
        if _xml.tag(node) == "NODE":
            node_id = _xml.optional_attribute(node, "ID")
            names = _xml.children(node, "NAME")
            if node_id and names:
                labels[node_id] = _xml.text(names[0])
    return labels


def write(net: BayesNet, path: str | Path) -> Path:
    """Write ``net`` as XDSL to ``path`` (gzipped if it ends in ``.gz``), atomically."""
    return write_output(path, dumps(net, path=str(path)))


def dumps(net: BayesNet, *, path: str | None = None) -> str:
    """``net`` as XDSL text.

    Raises
    ------
    FormatError
        A node or state name that is not a SMILE identifier, or a property XML cannot hold.
    """
    name = net.name or "network"
    network_id = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not _IDENTIFIER.fullmatch(network_id):
        network_id = f"n_{network_id}"
    root = etree.Element(
        "smile", version="1.0", id=network_id, numsamples="10000", discsamples="10000"
    )
    if net.properties:
        listed = _xml.sub(root, "properties")
        for key, value in net.properties.items():
            check_property("network", key, value, path=path)
            _xml.sub(listed, "property", value, path, id=key)
    nodes = _xml.sub(root, "nodes")
    labels: dict[str, str] = {}
    for variable_name in net.variables:
        variable = net.variable(variable_name)
        _check_identifier("node", variable_name, path)
        element = _xml.sub(nodes, "cpt", id=variable_name)
        for state in variable.states:
            _check_identifier(f"state of {variable_name!r}", state, path)
            _xml.sub(element, "state", id=state)
        if variable.parents:
            _xml.sub(element, "parents", " ".join(variable.parents), path)
        _xml.sub(element, "probabilities", table_values(np.moveaxis(variable.cpt, 0, -1)), path)
        props = properties_with_kind(variable, path=path)
        labels[variable_name] = props.pop("label", variable_name)
        for key, value in props.items():
            check_property(f"variable {variable_name!r}", key, value, path=path)
            _xml.sub(element, "property", value, path, id=key)
    extensions = _xml.sub(root, "extensions")
    genie = _xml.sub(extensions, "genie", version="1.0", app="bayesmap", name=name)
    for variable_name, (left, top) in _positions(net):
        node = _xml.sub(genie, "node", id=variable_name)
        _xml.sub(node, "name", labels[variable_name], path)
        width, height = _NODE_SIZE
        _xml.sub(node, "position", f"{left} {top} {left + width} {top + height}")
    return _xml.serialise(root)


def _check_identifier(what: str, name: str, path: str | None) -> None:
    if not _IDENTIFIER.fullmatch(name):
        raise FormatError(
            f"{what} {name!r} is not a SMILE identifier (a letter, then letters, digits or "
            "'_'), which XDSL needs; rename it, or write BIF or XMLBIF, which keep any name",
            path=path,
        )


def _positions(net: BayesNet) -> Iterator[tuple[str, tuple[int, int]]]:
    """Each node's top-left corner [px] in GeNIe: one row per depth in the graph (roots on
    top), nodes side by side in the network's order."""
    depth: dict[str, int] = {}
    placed: dict[int, int] = {}
    width, height = _NODE_SIZE
    for name in net.variables:  # parents come first
        level = depth[name] = 1 + max((depth[p] for p in net.variable(name).parents), default=-1)
        column = placed[level] = placed.get(level, -1) + 1
        yield name, (width // 2 + column * 2 * width, height // 2 + level * 2 * height)
