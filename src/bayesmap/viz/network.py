"""Drawings of Bayesian networks, coloured by the node kinds of Post et al. 2016 (Figs. 6, 8).

Ability nodes are green, bus nodes red, classification nodes blue, data nodes yellow (§3.4),
plain variables grey. :func:`to_dot` writes Graphviz DOT for the ``dot`` program;
:func:`layered_layout` is the pure-Python fallback: a layered (Sugiyama-style) drawing with
each variable one layer below its deepest parent and the order within layers improved by
barycentre sweeps; :func:`network_figure` draws it with matplotlib.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from matplotlib.figure import Figure
from matplotlib.patches import Patch

from bayesmap.bn import BayesNet, NodeKind
from bayesmap.viz.render import figure_png

KIND_COLOURS: Mapping[NodeKind | None, str] = {
    NodeKind.ABILITY: "#8fd18f",
    NodeKind.BUS: "#f08c8c",
    NodeKind.CLASSIFICATION: "#8fb4f0",
    NodeKind.DATA: "#f5e07a",
    None: "#d9d9d9",
}
"""Fill colour of each node kind (``None``: a plain variable)."""

_SWEEPS = 8
"""Barycentre sweeps (down then up) of :func:`layered_layout`."""


def layers(net: BayesNet) -> dict[str, int]:
    """Layer of each variable: one more than its deepest parent; a root sits just above its
    highest child (so that a root's edges stay short)."""
    depth: dict[str, int] = {}
    for name in net.topological_order():
        depth[name] = 1 + max((depth[p] for p in net.parents(name)), default=-1)
    for name in net.variables:
        children = net.children(name)
        if not net.parents(name) and children:
            depth[name] = min(depth[c] for c in children) - 1
    return depth


def layered_layout(net: BayesNet) -> dict[str, tuple[float, float]]:
    """``{variable: (x, y)}``: layers top to bottom (``y = −layer``), each layer centred.

    Within a layer, variables are ordered by the mean position of their parents (sweeping
    down) and of their children (sweeping up), which removes most edge crossings.
    """
    depth = layers(net)
    rows: list[list[str]] = [[] for _ in range(1 + max(depth.values(), default=-1))]
    for name in net.variables:
        rows[depth[name]].append(name)
    position = {name: float(i) for row in rows for i, name in enumerate(row)}
    children = {name: net.children(name) for name in net.variables}
    for sweep in range(_SWEEPS):
        downward = sweep % 2 == 0
        for row in rows[1:] if downward else rows[-2::-1]:
            linked = {n: net.parents(n) if downward else children[n] for n in row}
            centre = {
                n: sum(position[m] for m in linked[n]) / len(linked[n])
                if linked[n]
                else position[n]
                for n in row
            }
            row.sort(key=lambda n: (centre[n], position[n]))
            for i, name in enumerate(row):
                position[name] = float(i)
    width = max((len(row) for row in rows), default=1)
    return {
        name: (i - (len(row) - 1) / 2 + (width - 1) / 2, -float(k))
        for k, row in enumerate(rows)
        for i, name in enumerate(row)
    }


def network_figure(net: BayesNet) -> Figure:
    """The network drawn with :func:`layered_layout`, nodes coloured by kind, with a legend."""
    layout = layered_layout(net)
    width = 1 + max((x for x, _ in layout.values()), default=0.0)
    height = 1 - min((y for _, y in layout.values()), default=0.0)
    scale = 1.0 if len(net) <= 60 else max(0.3, math.sqrt(60 / len(net)))
    figure = Figure(figsize=(min(2 + 1.6 * width * scale, 60), min(1.5 + 1.1 * height, 60)))
    ax = figure.add_subplot()
    font = max(4.0, 9.0 * scale)
    for parent, child in net.edges():
        (x0, y0), (x1, y1) = layout[parent], layout[child]
        ax.annotate(
            "",
            xy=(x1, y1 + 0.18),
            xytext=(x0, y0 - 0.18),
            arrowprops={
                "arrowstyle": "-|>",
                "color": "#555555",
                "lw": 0.7,
                "shrinkA": 0,
                "shrinkB": 0,
            },
        )
    for name, (x, y) in layout.items():
        ax.text(
            x,
            y,
            name,
            ha="center",
            va="center",
            fontsize=font,
            bbox={
                "boxstyle": "round,pad=0.35",
                "fc": KIND_COLOURS[net.kind(name)],
                "ec": "#333333",
                "lw": 0.6,
            },
        )
    ax.set_xlim(-0.8, width - 0.2)
    ax.set_ylim(-height + 0.4, 0.6)
    ax.set_axis_off()
    kinds = [
        (NodeKind.ABILITY, "ability (A)"),
        (NodeKind.BUS, "bus (B)"),
        (NodeKind.CLASSIFICATION, "classification (C)"),
        (NodeKind.DATA, "data (D)"),
        (None, "plain"),
    ]
    present = {net.kind(name) for name in net.variables}
    ax.legend(
        handles=[
            Patch(fc=KIND_COLOURS[k], ec="#333333", label=label)
            for k, label in kinds
            if k in present
        ],
        loc="upper left",
        bbox_to_anchor=(1.0, 1.0),
        fontsize=8,
        frameon=False,
    )
    ax.set_title(f"{net.name}: {len(net)} variables, {len(net.edges())} edges", fontsize=10)
    figure.tight_layout()
    return figure


def network_image(net: BayesNet, suffix: str) -> bytes:
    """:func:`network_figure` as ``.png`` or ``.svg`` bytes."""
    return figure_png(network_figure(net), 150, tight=False, format=suffix.lstrip("."))


def to_dot(net: BayesNet) -> str:
    """Graphviz DOT of the network, nodes filled by kind, for ``dot -Tsvg`` or ``-Tpng``."""

    def quoted(text: str) -> str:
        return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'

    lines = [
        f"digraph {quoted(net.name)} {{",
        '  node [shape=box, style="rounded,filled", fontname="Helvetica", fontsize=11];',
        '  edge [color="#555555"];',
    ]
    for name in net.variables:
        lines.append(f'  {quoted(name)} [fillcolor="{KIND_COLOURS[net.kind(name)]}"];')
    for parent, child in net.edges():
        lines.append(f"  {quoted(parent)} -> {quoted(child)};")
    lines.append("}")
    return "\n".join(lines) + "\n"
