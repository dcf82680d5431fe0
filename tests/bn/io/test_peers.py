"""Interoperability with pgmpy 1.1 and pyAgrum, in both directions."""

from __future__ import annotations

import gzip
import logging
import warnings

import numpy as np
import pyagrum as gum
import pytest
from hypothesis import HealthCheck, given, settings
from pgmpy.readwrite import BIFReader, BIFWriter, XBNReader, XMLBIFReader, XMLBIFWriter

from bayesmap.bn import io
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError

from .helpers import (
    BIF_EXAMPLES,
    SMALL,
    assert_matches_bif_reader,
    assert_matches_pgmpy,
    assert_matches_pyagrum,
    assert_same,
    example,
    networks,
    peer_names,
    plain_names,
)

logging.getLogger("pgmpy").setLevel(logging.ERROR)


def _bif_reader(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return BIFReader(string=gzip.open(path, "rt").read())


def _pgmpy_bif(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return _bif_reader(path).get_model()


def _stem(path) -> str:
    return path.name.removesuffix(".bif.gz")


@pytest.mark.parametrize("path", [p for p in BIF_EXAMPLES if _stem(p) in SMALL], ids=_stem)
def test_bnlearn_file_equals_pgmpy_reading(path) -> None:
    reader = _bif_reader(path)
    net = io.read(path)
    assert_matches_bif_reader(net, reader)
    assert_matches_pgmpy(net, reader.get_model())


@pytest.mark.slow
@pytest.mark.parametrize("path", [p for p in BIF_EXAMPLES if _stem(p) not in SMALL], ids=_stem)
def test_big_bnlearn_file_equals_pgmpy_reading(path) -> None:
    assert_matches_bif_reader(io.read(path), _bif_reader(path))


def test_every_example_is_tested() -> None:
    assert len(BIF_EXAMPLES) == 24


@pytest.mark.parametrize("name", ["child", "alarm"])
def test_files_written_by_pgmpy_load(tmp_path, name: str) -> None:
    model = _pgmpy_bif(example(name))
    BIFWriter(model).write(str(tmp_path / "p.bif"))
    assert_matches_pgmpy(io.read(tmp_path / "p.bif"), model)
    if name != "child":  # pgmpy's XMLBIF writer mangles child's state names (next test)
        XMLBIFWriter(model).write(str(tmp_path / "p.xml"))
        assert_matches_pgmpy(io.read(tmp_path / "p.xml"), model)


def test_pgmpy_xmlbif_writer_collapses_child_states_but_ours_keeps_them(tmp_path) -> None:
    net = io.read(example("child"))
    model = _pgmpy_bif(example("child"))
    XMLBIFWriter(model).write(str(tmp_path / "pgmpy.xml"))
    with pytest.raises(FormatError, match=r"CO2Report.*lists outcome\(s\) \['_7_5'\] twice"):
        io.read(tmp_path / "pgmpy.xml")  # pgmpy's bug, measured: '<7.5', '>=7.5' -> '_7_5'
    io.write(net, tmp_path / "ours.xml")
    text = (tmp_path / "ours.xml").read_text()
    assert "<OUTCOME>&lt;7.5</OUTCOME>" in text and "<OUTCOME>&gt;=7.5</OUTCOME>" in text
    back = XMLBIFReader(str(tmp_path / "ours.xml")).get_model()
    assert_matches_pgmpy(net, back)
    assert gum.loadBN(str(_copy(tmp_path / "ours.xml", tmp_path / "ours.bifxml"))).variable(
        "CO2Report"
    ).labels() == ("<7.5", ">=7.5")


def _copy(src, dst):
    dst.write_bytes(src.read_bytes())
    return dst


@pytest.mark.filterwarnings("ignore:.*renormalised")  # pyAgrum writes 6-digit tables
@pytest.mark.parametrize("name", ["asia", "alarm", "insurance", "hailfinder", "win95pts"])
def test_files_written_by_pyagrum_load(tmp_path, name: str) -> None:
    bn = gum.loadBN(str(_gunzip(example(name), tmp_path / f"{name}.bif")))
    gum.saveBN(bn, str(tmp_path / "g.bif"))
    gum.saveBN(bn, str(tmp_path / "g.bifxml"))
    gum.saveBN(bn, str(tmp_path / "g.net"))
    # pyAgrum's BIF reader keeps float32, so its tables are off by ~1e-8 from the file's.
    assert_matches_pyagrum(io.read(tmp_path / "g.bif"), bn, atol=1e-7)
    # pyAgrum writes BIFXML tables with 6 significant digits; compare at that precision.
    assert_matches_pyagrum(io.read(tmp_path / "g.bifxml"), bn, atol=1e-5)
    # NET (Hugin) tables: its float32 values, which our model renormalises
    assert_matches_pyagrum(io.read(tmp_path / "g.net"), bn, atol=1e-7)


def _gunzip(src, dst):
    dst.write_bytes(gzip.decompress(src.read_bytes()))
    return dst


@pytest.mark.parametrize(("suffix", "atol"), [(".bif", 1e-7), (".bifxml", 1e-12), (".net", 1e-7)])
@pytest.mark.parametrize("name", ["asia", "alarm", "insurance", "hailfinder", "win95pts"])
def test_pyagrum_loads_what_we_write(tmp_path, name: str, suffix: str, atol: float) -> None:
    net = io.read(example(name))
    path = io.write(net, tmp_path / f"ours{suffix}")
    assert_matches_pyagrum(net, gum.loadBN(str(path)), atol=atol)


@pytest.mark.parametrize("name", ["asia", "child"])
def test_pgmpy_loads_what_we_write(tmp_path, name: str) -> None:
    net = io.read(example(name))
    io.write(net, tmp_path / "ours.bif")
    io.write(net, tmp_path / "ours.xml")
    io.write(net, tmp_path / "ours.xbn")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert_matches_pgmpy(net, BIFReader(str(tmp_path / "ours.bif")).get_model())
        assert_matches_pgmpy(net, XMLBIFReader(str(tmp_path / "ours.xml")).get_model())
        model = XBNReader(str(tmp_path / "ours.xbn")).get_model()
    for variable in net.variables:  # pgmpy's XBN reader has no state names: compare arrays
        cpd = model.get_cpds(variable)
        assert list(cpd.variables[1:]) == list(net.parents(variable))
        np.testing.assert_allclose(
            cpd.get_values().reshape(net.cpt(variable).shape), net.cpt(variable), atol=1e-15
        )


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(net=networks(peer_names, kinds=True, properties=False, max_variables=4))
def test_pgmpy_reads_our_xmlbif_with_odd_state_names(tmp_path, net: BayesNet) -> None:
    io.write(net, tmp_path / "r.xml")
    assert_matches_pgmpy(net, XMLBIFReader(str(tmp_path / "r.xml")).get_model())


@settings(
    max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(net=networks(peer_names, kinds=True, properties=False, max_variables=4))
def test_pgmpy_reads_our_bif_with_odd_state_names(tmp_path, net: BayesNet) -> None:
    io.write(net, tmp_path / "r.bif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert_matches_pgmpy(net, BIFReader(str(tmp_path / "r.bif")).get_model())


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(net=networks(plain_names, kinds=True, properties=False, max_variables=4, min_states=2))
def test_pyagrum_reads_our_files(tmp_path, net: BayesNet) -> None:
    for suffix, atol in ((".bif", 1e-7), (".bifxml", 1e-12), (".net", 1e-7)):
        path = io.write(net, tmp_path / f"r{suffix}")
        assert_matches_pyagrum(net, gum.loadBN(str(path)), atol=atol)
        assert_same(net, io.read(path))


def test_we_read_child_which_pyagrum_cannot(tmp_path) -> None:
    path = _gunzip(example("child"), tmp_path / "child.bif")
    with pytest.raises(Exception):  # noqa: B017 - pyAgrum's own error type
        gum.loadBN(str(path))
    assert io.read(path).states("XrayReport")[-1] == "Asy/Patchy"
