"""XBN, Microsoft Research's XML Belief Network format (MSBN, 1999) — the format Post et al.
2016 (§3.4, ref. [26]) call the most current interchange standard.

::

    <ANALYSISNOTEBOOK NAME="Notebook.rover" ROOT="rover">
      <BNMODEL NAME="rover">
        <STATICPROPERTIES>
          <FORMAT VALUE="MSR DTAS XML"/> <VERSION VALUE="1.0"/> <CREATOR VALUE="bayesmap"/>
        </STATICPROPERTIES>
        <DYNAMICPROPERTIES>
          <PROPERTYTYPE NAME="kind" TYPE="string"><COMMENT>...</COMMENT></PROPERTYTYPE>
          <PROPERTY NAME="author"><PROPVALUE>me</PROPVALUE></PROPERTY>
        </DYNAMICPROPERTIES>
        <VARIABLES>
          <VAR NAME="IR" TYPE="discrete">
            <DESCRIPTION>infrared range</DESCRIPTION>
            <STATENAME>near</STATENAME> <STATENAME>far</STATENAME>
            <PROPERTY NAME="kind"><PROPVALUE>B</PROPVALUE></PROPERTY>
          </VAR>
        </VARIABLES>
        <STRUCTURE> <ARC PARENT="IR" CHILD="Obstacle"/> </STRUCTURE>
        <DISTRIBUTIONS>
          <DIST TYPE="discrete">
            <CONDSET> <CONDELEM NAME="IR"/> </CONDSET>
            <PRIVATE NAME="Obstacle"/>
            <DPIS> <DPI INDEXES="0">0.9 0.1</DPI> <DPI INDEXES="1">0.2 0.8</DPI> </DPIS>
          </DIST>
        </DISTRIBUTIONS>
      </BNMODEL>
    </ANALYSISNOTEBOOK>

Each ``<DPI>`` is the distribution of the ``<PRIVATE>`` variable for the parent states whose
indices ``INDEXES`` lists in ``<CONDSET>`` order (a ``<DPI>`` without ``INDEXES`` takes the next
configuration, last parent fastest). The node kind is the ``kind`` property; a
``<DESCRIPTION>`` is read into, and written from, the ``description`` property.
"""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np
from lxml import etree

from bayesmap._typing import FloatArray
from bayesmap.bn.io import _xml
from bayesmap.bn.io._common import (
    KIND_PROPERTY,
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
    table_values,
    write_output,
)
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

__all__ = ["dumps", "loads", "read", "write"]

_INDEX = re.compile(r"[0-9]{1,18}")
DESCRIPTION_PROPERTY = "description"
"""Property that holds a variable's XBN ``<DESCRIPTION>``."""


def read(path: str | Path, *, limits: ReadLimits | None = None) -> BayesNet:
    """Read an XBN file (``.xbn`` or ``.xbn.gz``) into a new :class:`BayesNet`.

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
    """Parse XBN text; ``path`` only names the source in error messages."""
    root = _xml.parse(text, path)
    budget = TableBudget(limits)
    if _xml.tag(root) == "BNMODEL":
        model = root
    elif _xml.tag(root) == "ANALYSISNOTEBOOK":
        models = _xml.children(root, "BNMODEL")
        if not models:
            raise _xml.error(root, path, "<ANALYSISNOTEBOOK> holds no <BNMODEL>")
        model = models[0]
    else:
        raise _xml.error(root, path, "the root element must be <ANALYSISNOTEBOOK> (XBN)")
    name = _model_name(model, root)
    specs: dict[str, VariableSpec] = {}
    for variables in _xml.children(model, "VARIABLES"):
        for var in _xml.children(variables, "VAR"):
            spec = _variable(var, path)
            if spec.name in specs:
                raise _located(
                    var,
                    path,
                    f"variable {spec.name!r} is declared twice "
                    f"(first on line {specs[spec.name].where.line})",
                    spec.name,
                )
            specs[spec.name] = spec
    arcs = _arcs(model, specs, path)
    defined: set[str] = set()
    for distributions in _xml.children(model, "DISTRIBUTIONS"):
        for dist in _xml.children(distributions, "DIST"):
            _distribution(dist, specs, defined, path, budget)
    for child, parents in arcs.items():
        declared = set(specs[child].parents)
        if child in defined and parents != declared:
            where = specs[child].cpt_where or specs[child].where
            raise where.error(
                f"<STRUCTURE> gives {child!r} the parents {sorted(parents)} but its <CONDSET> "
                f"lists {sorted(declared)}"
            )
    for child in defined:
        if specs[child].parents and child not in arcs:
            raise (specs[child].cpt_where or specs[child].where).error(
                f"<CONDSET> of {child!r} lists parents {list(specs[child].parents)} that "
                "<STRUCTURE> has no <ARC> for"
            )
    return build_network(
        name, specs.values(), properties=_dynamic_properties(model, path), path=path
    )


def _model_name(model: etree._Element, root: etree._Element) -> str:
    name = _xml.optional_attribute(model, "NAME")
    if name:
        return name
    elements = _xml.children(model, "NAME")
    if elements and _xml.text(elements[0]):
        return _xml.text(elements[0])
    return _xml.optional_attribute(root, "ROOT") or "network"


def _located(element: etree._Element, path: str | None, message: str, owner: str) -> FormatError:
    return FormatError(
        message, path=path, line=element.sourceline, element=f"<{_xml.tag(element)}> of {owner!r}"
    )


def _property_values(element: etree._Element, path: str | None) -> dict[str, str]:
    props: dict[str, str] = {}
    for prop in _xml.children(element, "PROPERTY"):
        key = _xml.attribute(prop, "NAME", path, "<PROPERTY>")
        values = _xml.children(prop, "PROPVALUE")
        props[key] = " ".join(_xml.text(v) for v in values) if values else _xml.text(prop)
    return props


def _dynamic_properties(model: etree._Element, path: str | None) -> dict[str, str]:
    props: dict[str, str] = {}
    for dynamic in _xml.children(model, "DYNAMICPROPERTIES"):
        props.update(_property_values(dynamic, path))
    return props


def _variable(element: etree._Element, path: str | None) -> VariableSpec:
    name = _xml.attribute(element, "NAME", path, "<VAR>")
    if not name:
        raise _xml.error(element, path, "<VAR> with an empty NAME")
    kind = _xml.optional_attribute(element, "TYPE")
    if kind and kind.lower() != "discrete":
        raise _located(
            element,
            path,
            f"variable {name!r} has TYPE={kind!r}; only discrete variables are supported",
            name,
        )
    states = tuple(_xml.text(s) for s in _xml.children(element, "STATENAME"))
    if not states:
        raise _located(element, path, f"variable {name!r} has no <STATENAME>", name)
    where = Location(path, element.sourceline, f"<VAR> {name!r}")
    check_names(f"<STATENAME> of {name!r}", states, where)
    if len(set(states)) != len(states):
        dup = sorted({s for s in states if states.count(s) > 1})
        raise _located(element, path, f"variable {name!r} lists state(s) {dup} twice", name)
    props = _property_values(element, path)
    descriptions = _xml.children(element, "DESCRIPTION")
    if descriptions and _xml.text(descriptions[0]):
        props.setdefault(DESCRIPTION_PROPERTY, _xml.text(descriptions[0]))
    return VariableSpec(name, states, where, properties=props)


def _arcs(
    model: etree._Element, specs: dict[str, VariableSpec], path: str | None
) -> dict[str, set[str]]:
    arcs: dict[str, set[str]] = {}
    for structure in _xml.children(model, "STRUCTURE"):
        for arc in _xml.children(structure, "ARC"):
            parent = _xml.attribute(arc, "PARENT", path, "<ARC>")
            child = _xml.attribute(arc, "CHILD", path, "<ARC>")
            for end in (parent, child):
                if end not in specs:
                    raise _xml.error(
                        arc, path, f"<ARC> {parent!r} -> {child!r}: {end!r} is not a declared <VAR>"
                    )
            arcs.setdefault(child, set()).add(parent)
    return arcs


def _distribution(
    element: etree._Element,
    specs: dict[str, VariableSpec],
    defined: set[str],
    path: str | None,
    budget: TableBudget,
) -> None:
    name = _xml.attribute(_xml.child(element, "PRIVATE", path, "<DIST>"), "NAME", path, "<PRIVATE>")
    if name not in specs:
        raise _located(
            element, path, f"<PRIVATE> names {name!r}, which is not a declared <VAR>", name
        )
    if name in defined:
        raise _located(element, path, f"a second <DIST> for {name!r}", name)
    defined.add(name)
    kind = _xml.optional_attribute(element, "TYPE")
    if kind and kind.lower() != "discrete":
        raise _located(
            element,
            path,
            f"<DIST> of {name!r} has TYPE={kind!r}; only 'discrete' is supported",
            name,
        )
    parents: tuple[str, ...] = ()
    for condset in _xml.children(element, "CONDSET"):
        parents += tuple(
            _xml.attribute(c, "NAME", path, "<CONDELEM>")
            for c in _xml.children(condset, "CONDELEM")
        )
    for parent in parents:
        if parent not in specs:
            raise _located(element, path, f"<CONDELEM> {parent!r} is not a declared <VAR>", name)
    if len(set(parents)) != len(parents):
        raise _located(element, path, f"a <CONDELEM> is listed twice in {list(parents)}", name)
    spec = specs[name]
    spec.parents = parents
    spec.cpt_where = Location(path, element.sourceline, f"<DIST> of {name!r}")
    dpis = _xml.child(element, "DPIS", path, f"<DIST> of {name!r}")
    budget.claim(name, len(spec.states), [len(specs[p].states) for p in parents], spec.cpt_where)
    spec.cpt = _table(dpis, spec, [specs[p].states for p in parents], path)


def _table(
    dpis: etree._Element, spec: VariableSpec, parent_states: list[tuple[str, ...]], path: str | None
) -> FloatArray:
    cards = [len(s) for s in parent_states]
    n_columns = math.prod(cards)
    n_child = len(spec.states)
    matrix = np.empty((n_columns, n_child))
    given = np.zeros(n_columns, dtype=bool)
    for position, dpi in enumerate(_xml.children(dpis, "DPI")):
        indexes = _xml.optional_attribute(dpi, "INDEXES")
        if indexes is None:
            column = position
        else:
            column = _column(dpi, indexes, cards, spec, path)
        if column >= n_columns:
            raise _located(
                dpi, path, f"more <DPI> rows than the {n_columns} parent configurations", spec.name
            )
        if given[column]:
            raise _located(
                dpi, path, f"parent configuration {indexes or position} is given twice", spec.name
            )
        tokens = _xml.text(dpi).split()
        if len(tokens) != n_child:
            raise _located(
                dpi,
                path,
                f"<DPI> has {len(tokens)} probabilities, expected {n_child} "
                f"(one per state of {spec.name!r})",
                spec.name,
            )
        row_at = Location(path, dpi.sourceline, f"<DPI> of {spec.name!r}")
        matrix[column] = probabilities(tokens, row_at)
        given[column] = True
    missing = np.flatnonzero(~given)
    if missing.size:
        where = np.unravel_index(int(missing[0]), cards) if cards else ()
        raise _located(
            dpis,
            path,
            f"no <DPI> for parent state indexes {[int(i) for i in where]} "
            f"({missing.size} configuration(s) missing)",
            spec.name,
        )
    return np.moveaxis(matrix.reshape((*cards, n_child)), -1, 0)


def _column(
    dpi: etree._Element, indexes: str, cards: list[int], spec: VariableSpec, path: str | None
) -> int:
    tokens = indexes.split()
    if not all(_INDEX.fullmatch(t) for t in tokens):
        raise _located(dpi, path, f"INDEXES={indexes!r} is not a list of integers", spec.name)
    index = [int(t) for t in tokens]
    if len(index) != len(cards) or any(not 0 <= i < c for i, c in zip(index, cards, strict=False)):
        raise _located(
            dpi,
            path,
            f"INDEXES={indexes!r} does not fit parents {list(spec.parents)} with {cards} states",
            spec.name,
        )
    column = 0
    for i, card in zip(index, cards, strict=True):
        column = column * card + i
    return column


def write(net: BayesNet, path: str | Path) -> Path:
    """Write ``net`` as XBN to ``path`` (gzipped if it ends in ``.gz``), atomically."""
    return write_output(path, dumps(net, path=str(path)))


def dumps(net: BayesNet, *, path: str | None = None) -> str:
    """``net`` as XBN text.

    Raises
    ------
    FormatError
        A name or property XML cannot hold exactly.
    """
    root = etree.Element("ANALYSISNOTEBOOK")
    root.set("NAME", f"Notebook.{net.name}")
    root.set("ROOT", net.name)
    model = _xml.sub(root, "BNMODEL", path=path, NAME=net.name)
    static = _xml.sub(model, "STATICPROPERTIES")
    for key, value in (("FORMAT", "MSR DTAS XML"), ("VERSION", "1.0"), ("CREATOR", "bayesmap")):
        _xml.sub(static, key, VALUE=value)
    dynamic = _xml.sub(model, "DYNAMICPROPERTIES")
    all_props = [properties_with_kind(net.variable(n), path=path) for n in net.variables]
    names = dict.fromkeys(itertools.chain(net.properties, *all_props))
    names.pop(DESCRIPTION_PROPERTY, None)
    for key in names:
        check_property("network", key, "", path=path)
        declared = _xml.sub(dynamic, "PROPERTYTYPE", path=path, NAME=key, TYPE="string")
        if key == KIND_PROPERTY:
            _xml.sub(
                declared,
                "COMMENT",
                "Node kind (Post et al. 2016, section 3.4): A ability, "
                "B bus, C classification, D data",
            )
    _write_properties(dynamic, net.properties, "network", path)
    variables = _xml.sub(model, "VARIABLES")
    for name, props in zip(net.variables, all_props, strict=True):
        check_name("variable name", name, path=path)
        var = _xml.sub(variables, "VAR", path=path, NAME=name, TYPE="discrete")
        description = props.pop(DESCRIPTION_PROPERTY, "")
        check_property(f"variable {name!r}", DESCRIPTION_PROPERTY, description, path=path)
        _xml.sub(var, "DESCRIPTION", description, path)
        for state in net.states(name):
            check_name(f"state of {name!r}", state, path=path)
            _xml.sub(var, "STATENAME", state, path)
        _write_properties(var, props, f"variable {name!r}", path)
    structure = _xml.sub(model, "STRUCTURE")
    for parent, child in net.edges():
        _xml.sub(structure, "ARC", path=path, PARENT=parent, CHILD=child)
    distributions = _xml.sub(model, "DISTRIBUTIONS")
    for name in net.variables:
        variable = net.variable(name)
        dist = _xml.sub(distributions, "DIST", TYPE="discrete")
        if variable.parents:
            condset = _xml.sub(dist, "CONDSET")
            for parent in variable.parents:
                _xml.sub(condset, "CONDELEM", path=path, NAME=parent)
        _xml.sub(dist, "PRIVATE", path=path, NAME=name)
        dpis = _xml.sub(dist, "DPIS")
        rows = np.moveaxis(variable.cpt, 0, -1).reshape(-1, variable.cardinality)
        if not variable.parents:
            _xml.sub(dpis, "DPI", table_values(rows[0]), path)
            continue
        configurations = itertools.product(*(range(net.cardinality(p)) for p in variable.parents))
        for config, row in zip(configurations, rows, strict=True):
            _xml.sub(dpis, "DPI", table_values(row), path, INDEXES=" ".join(map(str, config)))
    return _xml.serialise(root)


def _write_properties(
    element: etree._Element, props: dict[str, str], owner: str, path: str | None
) -> None:
    for key, value in props.items():
        check_property(owner, key, value, path=path)
        prop = _xml.sub(element, "PROPERTY", path=path, NAME=key)
        _xml.sub(prop, "PROPVALUE", value, path)
