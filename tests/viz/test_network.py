"""Network drawings: the layered layout's invariants, PNG/SVG output, DOT text, the CLI."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from PIL import Image
from tests.bn.helpers import random_net
from typer.testing import CliRunner

import bayesmap.bn as bn
from bayesmap.cli import app
from bayesmap.viz.network import KIND_COLOURS, layered_layout, layers, network_image, to_dot


@pytest.mark.parametrize("seed", range(8))
def test_every_edge_points_down_and_no_two_nodes_share_a_place(seed: int) -> None:
    net = random_net(seed, n_vars=12, max_parents=3)
    depth = layers(net)
    layout = layered_layout(net)
    for parent, child in net.edges():
        assert depth[parent] < depth[child]
        assert layout[parent][1] > layout[child][1]
    assert len(set(layout.values())) == len(net)


def kinds_net() -> bn.BayesNet:
    net = bn.BayesNet('rover "fragment"')
    net.add_variable("Reading", ["near", "far"], kind="B")
    net.add_variable("Map", ["free", "occupied"], kind="D")
    net.add_variable("Model", ["ok", "bad"], parents=["Reading"], kind="A")
    net.add_variable("Obstacle", ["no", "yes"], parents=["Model", "Map"], kind="C")
    return net


def test_png_and_svg_show_the_network() -> None:
    net = kinds_net()
    svg = network_image(net, ".svg").decode()
    assert svg.lstrip().startswith("<?xml") and "Obstacle" in svg
    png = network_image(net, ".png")
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_dot_text_has_every_node_coloured_and_every_edge() -> None:
    net = kinds_net()
    text = to_dot(net)
    assert text.startswith('digraph "rover \\"fragment\\"" {')
    assert f'"Map" [fillcolor="{KIND_COLOURS[bn.NodeKind.DATA]}"]' in text
    assert f'"Reading" [fillcolor="{KIND_COLOURS[bn.NodeKind.BUS]}"]' in text
    assert text.count("->") == len(net.edges())


def test_cli_draws_without_graphviz(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "net.xml"
    bn.write(kinds_net(), path)
    monkeypatch.setattr(shutil, "which", lambda _name: None)
    runner = CliRunner()
    result = runner.invoke(app, ["bn", "draw", str(path), "--out", str(tmp_path / "net.png")])
    assert result.exit_code == 0, result.output
    with Image.open(tmp_path / "net.png") as image:
        assert image.width > 100 and image.height > 100
    missing = runner.invoke(
        app, ["bn", "draw", str(path), "--out", str(tmp_path / "n.svg"), "--layout", "dot"]
    )
    assert missing.exit_code == 1 and "not on PATH" in missing.stderr
    wrong = runner.invoke(app, ["bn", "draw", str(path), "--out", str(tmp_path / "net.pdf")])
    assert wrong.exit_code == 2
