"""read(write(net)) == net for every format, on random networks with odd names."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from bayesmap.bn import io
from bayesmap.bn.io import bif, xbn, xmlbif
from bayesmap.bn.model import BayesNet

from .helpers import assert_same, example, networks

MODULES = [bif, xmlbif, xbn]


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__.rsplit(".", 1)[-1])
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(net=networks())
def test_text_round_trip_is_exact(module, net: BayesNet) -> None:
    back = module.loads(module.dumps(net))
    assert_same(net, back)  # atol=0: every double comes back bit for bit


@pytest.mark.parametrize(
    "suffix", [".bif", ".bif.gz", ".xml", ".xmlbif", ".bifxml.gz", ".xbn", ".xbn.gz"]
)
@settings(
    max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(net=networks(max_variables=3))
def test_file_round_trip_by_extension(tmp_path, suffix: str, net: BayesNet) -> None:
    path = tmp_path / f"net{suffix}"
    io.write(net, path)
    assert_same(net, io.read(path))


@pytest.mark.parametrize("name", ["alarm", "child", "insurance"])
@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__.rsplit(".", 1)[-1])
def test_bnlearn_networks_survive_every_format(module, name: str) -> None:
    net = io.read(example(name))
    assert_same(net, module.loads(module.dumps(net)))


def test_conversion_chain_keeps_everything() -> None:
    net = io.read(example("child"))
    net.set_kind("Disease", "C")
    net.variable("Disease").properties["note"] = 'a < b & c > "d"'
    text = xbn.dumps(xmlbif.loads(xmlbif.dumps(bif.loads(bif.dumps(net)))))
    assert_same(net, xbn.loads(text))
