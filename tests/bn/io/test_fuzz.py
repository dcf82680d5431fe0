"""Corrupted files raise FormatError and nothing else, and never give a half-built network."""

from __future__ import annotations

import gzip
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _fuzzing import FUZZ, mutated, read_within_budget
from bayesmap.bn import io
from bayesmap.bn.io import bif, uai, xbn, xdsl, xmlbif
from bayesmap.bn.io import net as hugin
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError

from .helpers import example


def _seed_network() -> BayesNet:
    net = io.read(example("asia"))
    net.properties["author"] = 'x "y" <z>'
    net.set_kind("smoke", "B")
    net.variable("either").properties["note"] = "a; b } c"
    return net


SEEDS = {
    module.__name__.rsplit(".", 1)[-1]: module.dumps(_seed_network())
    for module in (bif, xmlbif, xbn, hugin, xdsl, uai)
}
MODULES = {"bif": bif, "xmlbif": xmlbif, "xbn": xbn, "net": hugin, "xdsl": xdsl, "uai": uai}
SPECIAL = st.sampled_from(
    list('{}()[];,|"=\\<>/&*\n\t 0123456789.-eabcxyz')
    + [
        "table",
        "default",
        "property",
        "variable",
        "probability",
        "network",
        "potential",
        "node",
        "data",
        "states",
        "%",
        "//",
        "/*",
        "*/",
        "<GIVEN>a</GIVEN>",
        "<DPI>0.5 0.5</DPI>",
        'INDEXES="0 0"',
        "&amp;",
        "&bogus;",
        "<!--",
        "]]>",
    ]
)


@st.composite
def mutations(draw: st.DrawFn, text: str) -> str:
    """``text`` with a few deletions, insertions, duplications and swaps."""
    for _ in range(draw(st.integers(1, 4))):
        n = len(text)
        op = draw(st.sampled_from(["delete", "insert", "duplicate", "replace"]))
        i = draw(st.integers(0, n))
        j = min(n, i + draw(st.integers(0, 40)))
        if op == "delete":
            text = text[:i] + text[j:]
        elif op == "insert":
            text = text[:i] + draw(SPECIAL) + text[i:]
        elif op == "duplicate":
            text = text[:j] + text[i:j] + text[j:]
        else:
            text = text[:i] + draw(SPECIAL) + text[j:]
    return text


def _check(module, text: str | bytes) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            net = module.loads(text, path="fuzz")
        except FormatError as error:
            assert error.path == "fuzz"
            return
    # A network came back: it must be whole.
    assert isinstance(net, BayesNet)
    for name in net.variables:
        shape = (net.cardinality(name), *(net.cardinality(p) for p in net.parents(name)))
        assert net.cpt(name).shape == shape
        np.testing.assert_allclose(net.cpt(name).sum(axis=0), 1.0, atol=1e-9)
    net.topological_order()


@pytest.mark.parametrize("fmt", sorted(SEEDS))
@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_mutated_files_raise_only_format_error(fmt: str, data: st.DataObject) -> None:
    _check(MODULES[fmt], data.draw(mutations(SEEDS[fmt])))


@pytest.mark.parametrize("fmt", sorted(SEEDS))
@FUZZ
@given(data=st.data())
def test_byte_mutations_stay_within_the_budget(fmt: str, data: st.DataObject) -> None:
    module = MODULES[fmt]
    blob = data.draw(mutated([SEEDS[fmt].encode()]))
    outcome = read_within_budget(lambda: module.loads(blob, path="fuzz"))
    assert isinstance(outcome, (BayesNet, FormatError))


@FUZZ
@given(data=st.data())
def test_mutated_gzip_files_stay_within_the_budget(tmp_path_factory, data: st.DataObject) -> None:
    path = tmp_path_factory.mktemp("gz") / "net.bif.gz"
    path.write_bytes(data.draw(mutated([gzip.compress(SEEDS["bif"].encode())])))
    outcome = read_within_budget(lambda: io.read(path))
    assert isinstance(outcome, (BayesNet, FormatError))


@pytest.mark.parametrize("module", MODULES.values(), ids=list(MODULES))
@settings(max_examples=60, deadline=None)
@given(blob=st.binary(max_size=200) | st.text(max_size=200))
def test_arbitrary_input_raises_only_format_error(module, blob: bytes | str) -> None:
    _check(module, blob)


def test_unknown_extension_and_missing_file(tmp_path) -> None:
    with pytest.raises(FormatError, match="extension"):
        io.read(tmp_path / "net.json")
    with pytest.raises(FormatError, match="cannot open") as caught:
        io.read(tmp_path / "missing.bif")
    assert caught.value.path == str(tmp_path / "missing.bif")
    (tmp_path / "broken.bif.gz").write_bytes(b"not gzip")
    with pytest.raises(FormatError, match="not a valid gzip"):
        io.read(tmp_path / "broken.bif.gz")


def test_failed_write_leaves_no_file(tmp_path) -> None:
    net = BayesNet("n")
    net.add_variable("a", ["x\x00", "y"], cpt=[0.5, 0.5])
    with pytest.raises(FormatError):
        io.write(net, tmp_path / "n.xml")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("name", "fmt"),
    [
        ("a.xml", "xmlbif"),
        ("a.XMLBIF", "xmlbif"),
        ("a.bifxml.gz", "xmlbif"),
        ("a.xbif", "xmlbif"),
        ("a.bif", "bif"),
        ("a.bif.gz", "bif"),
        ("a.xbn", "xbn"),
        ("a.xbn.GZ", "xbn"),
        ("a.net", "net"),
        ("a.NET.gz", "net"),
        ("a.xdsl", "xdsl"),
        ("a.XDSL.gz", "xdsl"),
        ("a.uai", "uai"),
    ],
)
def test_extensions_choose_the_format(name: str, fmt: str) -> None:
    assert io.format_of(name).name == fmt


@pytest.mark.parametrize("fmt", ["xmlbif", "bif", "xbn", "net", "xdsl", "uai"])
def test_a_file_whose_extension_names_no_format_is_read_by_its_content(tmp_path, fmt) -> None:
    text = SEEDS[fmt]
    if fmt == "xmlbif":  # as JavaBayes writes it: a comment and a DTD before the root
        text = text.replace(
            "<BIF",
            "<!-- by <JavaBayes> -->\n<!DOCTYPE BIF [\n  <!ELEMENT BIF ( NETWORK )*>\n]>\n<BIF",
            1,
        )
    if fmt == "bif":
        text = "// exported\n/* a <note> */\n" + text
    if fmt == "net":
        text = "% exported by Hugin\n\n" + text
    (tmp_path / "net.txt").write_text(text)
    (tmp_path / "net.dat.gz").write_bytes(gzip.compress(text.encode()))
    expected = io.loads(SEEDS[fmt], fmt)
    for name in ("net.txt", "net.dat.gz"):
        net = io.read(tmp_path / name)
        assert list(net.variables) == list(expected.variables)
        for name in expected.variables:
            assert np.array_equal(net.cpt(name), expected.cpt(name))
    assert io.sniff(text.encode()) is io.FORMATS[fmt]


@pytest.mark.parametrize(
    "text",
    [
        "// ~->[DNET-1]->~\nbnet x { }",  # Netica
        "<graphml/>",  # a graph without tables
        "",
        "networks are fun",
        "<?xml version='1.0'?>",
        "nets { }",
    ],
)
def test_content_no_format_matches_is_refused_with_the_extensions(tmp_path, text) -> None:
    (tmp_path / "model.dne").write_text(text)
    with pytest.raises(FormatError, match=r"model\.dne.*file name or its content.*\.xbif"):
        io.read(tmp_path / "model.dne")
    with pytest.raises(FormatError, match="from the file name;"):
        io.write(io.loads(SEEDS["bif"], "bif"), tmp_path / "out.dne")
