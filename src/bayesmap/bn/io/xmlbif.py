"""XMLBIF 0.3 (Cozman's XML Interchange Format), with node kinds as ``<PROPERTY>`` entries.

::

    <BIF VERSION="0.3">
    <NETWORK>
      <NAME>rover</NAME>
      <PROPERTY>author = me</PROPERTY>
      <VARIABLE TYPE="nature">
        <NAME>IR</NAME>
        <OUTCOME>&lt;0.5m</OUTCOME>
        <OUTCOME>&gt;=0.5m</OUTCOME>
        <PROPERTY>kind = B</PROPERTY>
      </VARIABLE>
      <DEFINITION>
        <FOR>Obstacle</FOR>
        <GIVEN>IR</GIVEN>
        <TABLE>0.9 0.1 0.2 0.8</TABLE>
      </DEFINITION>
    </NETWORK>
    </BIF>

``<TABLE>`` lists, for each configuration of the ``<GIVEN>`` parents (last parent fastest),
the distribution of the ``<FOR>`` variable: C order of a ``(*parents, child)`` array.
Post et al. 2016 (§3.4) store node kinds with "additional XML tags"; here the kind is a
``<PROPERTY>kind = A</PROPERTY>`` entry, which pgmpy and pyAgrum read as an ordinary
property or ignore. Every state name is written exactly (XML-escaped), unlike pgmpy's
writer, which rewrites ``<7.5`` and ``>=7.5`` both to ``_7_5``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from lxml import etree

from bayesmap._typing import FloatArray
from bayesmap.bn.io import _xml
from bayesmap.bn.io._common import (
    Location,
    TableBudget,
    VariableSpec,
    build_network,
    check_name,
    check_names,
    check_property,
    probabilities,
    properties_with_kind,
    read_source,
    split_property,
    table_values,
    write_output,
)
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["dumps", "loads", "read", "write"]


def read(path: str | Path, *, limits: ReadLimits | None = None) -> BayesNet:
    """Read an XMLBIF file (``.xml``, ``.xmlbif``, ``.bifxml``, optionally ``.gz``).

    Raises
    ------
    FormatError
        Unreadable, malformed or inconsistent file, or one past a :class:`ReadLimits`
        limit; the message names file, line and element.
    """
    return loads(read_source(path, limits), path=str(path), limits=limits)


def loads(
    text: str | bytes, *, path: str | None = None, limits: ReadLimits | None = None
) -> BayesNet:
    """Parse XMLBIF text; ``path`` only names the source in error messages."""
    root = _xml.parse(text, path)
    budget = TableBudget(limits)
    if _xml.tag(root) == "NETWORK":
        network = root
    elif _xml.tag(root) == "BIF":
        network = _xml.child(root, "NETWORK", path, "<BIF>")
    else:
        raise _xml.error(root, path, "the root element must be <BIF> (XMLBIF 0.3)")
    name_elements = _xml.children(network, "NAME")
    name = _xml.text(name_elements[0]) if name_elements else "network"
    specs: dict[str, VariableSpec] = {}
    for variable in _xml.children(network, "VARIABLE"):
        spec = _variable(variable, path)
        if spec.name in specs:
            raise _located(
                variable,
                path,
                f"variable {spec.name!r} is declared twice "
                f"(first on line {specs[spec.name].where.line})",
                spec.name,
            )
        specs[spec.name] = spec
    defined: set[str] = set()
    for definition in _xml.children(network, "DEFINITION"):
        _definition(definition, specs, defined, path, budget)
    properties = _properties(network, path)
    return build_network(name, specs.values(), properties=properties, path=path)


def _located(element: etree._Element, path: str | None, message: str, owner: str) -> FormatError:
    return FormatError(
        message, path=path, line=element.sourceline, element=f"<{_xml.tag(element)}> of {owner!r}"
    )


def _properties(element: etree._Element, path: str | None) -> dict[str, str]:
    props: dict[str, str] = {}
    for prop in _xml.children(element, "PROPERTY"):
        content = _xml.text(prop)
        if content:
            key, value = split_property(content)
            if not key:
                raise _xml.error(prop, path, f"property {content[:60]!r} has no name before '='")
            props[key] = value
    return props


def _variable(element: etree._Element, path: str | None) -> VariableSpec:
    name = _xml.text(_xml.child(element, "NAME", path, "<VARIABLE>"))
    if not name:
        raise _xml.error(element, path, "<VARIABLE> with an empty <NAME>")
    kind = _xml.optional_attribute(element, "TYPE")
    if kind is not None and kind.lower() != "nature":
        raise _located(
            element,
            path,
            f"variable {name!r} has TYPE={kind!r}; only chance ('nature') variables are supported",
            name,
        )
    states = tuple(_xml.text(outcome) for outcome in _xml.children(element, "OUTCOME"))
    if not states:
        raise _located(element, path, f"variable {name!r} has no <OUTCOME>", name)
    where = Location(path, element.sourceline, f"<VARIABLE> {name!r}")
    check_names(f"<OUTCOME> of {name!r}", states, where)
    if len(set(states)) != len(states):
        dup = sorted({s for s in states if states.count(s) > 1})
        raise _located(element, path, f"variable {name!r} lists outcome(s) {dup} twice", name)
    return VariableSpec(name, states, where, properties=_properties(element, path))


def _definition(
    element: etree._Element,
    specs: dict[str, VariableSpec],
    defined: set[str],
    path: str | None,
    budget: TableBudget,
) -> None:
    name = _xml.text(_xml.child(element, "FOR", path, "<DEFINITION>"))
    if name not in specs:
        raise _located(
            element, path, f"<FOR> names {name!r}, which is not a declared <VARIABLE>", name
        )
    if name in defined:
        raise _located(element, path, f"a second <DEFINITION> for {name!r}", name)
    defined.add(name)
    parents = tuple(_xml.text(given) for given in _xml.children(element, "GIVEN"))
    for parent in parents:
        if parent not in specs:
            raise _located(element, path, f"<GIVEN> {parent!r} is not a declared <VARIABLE>", name)
    if len(set(parents)) != len(parents):
        raise _located(element, path, f"a <GIVEN> parent is listed twice in {list(parents)}", name)
    table = _xml.child(element, "TABLE", path, f"<DEFINITION> of {name!r}")
    spec = specs[name]
    shape = (*(len(specs[p].states) for p in parents), len(spec.states))
    spec.parents = parents
    spec.cpt_where = Location(path, element.sourceline, f"<DEFINITION> of {name!r}")
    expected = budget.claim(name, shape[-1], shape[:-1], spec.cpt_where)
    spec.cpt = np.moveaxis(_numbers(table, shape, expected, path, name), -1, 0)


def _numbers(
    table: etree._Element, shape: tuple[int, ...], expected: int, path: str | None, name: str
) -> FloatArray:
    tokens = _xml.text(table).split()
    if len(tokens) != expected:
        raise _located(
            table,
            path,
            f"<TABLE> has {len(tokens)} probabilities, expected {expected} "
            f"({shape[-1]} states x {expected // shape[-1]} parent configurations)",
            name,
        )
    where = Location(path, table.sourceline, f"<TABLE> of {name!r}")
    return probabilities(tokens, where).reshape(shape)


def write(net: BayesNet, path: str | Path) -> Path:
    """Write ``net`` as XMLBIF 0.3 to ``path`` (gzipped if it ends in ``.gz``), atomically."""
    return write_output(path, dumps(net, path=str(path)))


def dumps(net: BayesNet, *, path: str | None = None) -> str:
    """``net`` as XMLBIF 0.3 text.

    Raises
    ------
    FormatError
        A name or property XML cannot hold exactly (control characters, surrounding
        whitespace, ``=`` in a property name).
    """
    root = etree.Element("BIF", VERSION="0.3")
    network = _xml.sub(root, "NETWORK")
    _xml.sub(network, "NAME", net.name, path)
    _write_properties(network, net.properties, "network", path)
    for name in net.variables:
        variable = net.variable(name)
        check_name("variable name", name, path=path)
        element = _xml.sub(network, "VARIABLE", TYPE="nature")
        _xml.sub(element, "NAME", name, path)
        for state in variable.states:
            check_name(f"state of {name!r}", state, path=path)
            _xml.sub(element, "OUTCOME", state, path)
        _write_properties(
            element, properties_with_kind(variable, path=path), f"variable {name!r}", path
        )
    for name in net.variables:
        variable = net.variable(name)
        definition = _xml.sub(network, "DEFINITION")
        _xml.sub(definition, "FOR", name, path)
        for parent in variable.parents:
            _xml.sub(definition, "GIVEN", parent, path)
        _xml.sub(definition, "TABLE", table_values(np.moveaxis(variable.cpt, 0, -1)), path)
    return _xml.serialise(root)


def _write_properties(
    element: etree._Element, props: dict[str, str], owner: str, path: str | None
) -> None:
    for key, value in props.items():
        check_property(owner, key, value, path=path)
        _xml.sub(element, "PROPERTY", f"{key} = {value}", path)
