"""XMLBIF and XBN: what they store, kinds as properties, and located errors."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.bn.io import xbn, xmlbif
from bayesmap.bn.model import BayesNet, NodeKind
from bayesmap.errors import FormatError

from .helpers import assert_same


def _rover() -> BayesNet:
    net = BayesNet("rover")
    net.properties["author"] = "Post & Lee"
    net.add_variable("IR", ["<0.5m", ">=0.5m"], cpt=[0.3, 0.7], kind="B", properties={"unit": "m"})
    net.add_variable(
        "Obstacle", ["no", "yes"], parents=["IR"], cpt=[[0.2, 0.9], [0.8, 0.1]], kind="C"
    )
    return net


def test_xmlbif_stores_kinds_as_properties_and_escapes_names() -> None:
    text = xmlbif.dumps(_rover())
    assert "<PROPERTY>kind = B</PROPERTY>" in text
    assert "<OUTCOME>&lt;0.5m</OUTCOME>" in text and "<OUTCOME>&gt;=0.5m</OUTCOME>" in text
    assert "<PROPERTY>author = Post &amp; Lee</PROPERTY>" in text
    # TABLE: for each parent state, the child's distribution
    assert "<TABLE>0.2 0.8 0.9 0.1</TABLE>" in text
    back = xmlbif.loads(text)
    assert back.kind("IR") is NodeKind.BUS and back.variable("IR").properties == {"unit": "m"}
    assert_same(_rover(), back)


def test_xbn_layout_and_round_trip() -> None:
    text = xbn.dumps(_rover())
    for piece in (
        '<BNMODEL NAME="rover">',
        '<VAR NAME="IR" TYPE="discrete">',
        "<STATENAME>&lt;0.5m</STATENAME>",
        '<ARC PARENT="IR" CHILD="Obstacle"/>',
        '<CONDELEM NAME="IR"/>',
        '<DPI INDEXES="1">0.9 0.1</DPI>',
        '<PROPERTY NAME="kind">',
    ):
        assert piece in text, piece
    assert_same(_rover(), xbn.loads(text))


PGMPY_XBN = """<ANALYSISNOTEBOOK NAME="Notebook.Cancer Example From Neapolitan" ROOT="Cancer">
  <BNMODEL NAME="Cancer">
    <STATICPROPERTIES><FORMAT VALUE="MSR DTAS XML"/><VERSION VALUE="0.2"/></STATICPROPERTIES>
    <VARIABLES>
      <VAR NAME="a" TYPE="discrete" XPOS="13495" YPOS="10465">
        <DESCRIPTION>(a) Metastatic Cancer</DESCRIPTION>
        <STATENAME>Present</STATENAME><STATENAME>Absent</STATENAME>
      </VAR>
      <VAR NAME="b" TYPE="discrete"><DESCRIPTION>(b)</DESCRIPTION>
        <STATENAME>Present</STATENAME><STATENAME>Absent</STATENAME></VAR>
      <VAR NAME="c" TYPE="discrete"><STATENAME>Present</STATENAME>
        <STATENAME>Absent</STATENAME></VAR>
      <VAR NAME="d" TYPE="discrete"><STATENAME>Present</STATENAME>
        <STATENAME>Absent</STATENAME></VAR>
    </VARIABLES>
    <STRUCTURE>
      <ARC PARENT="a" CHILD="b"/><ARC PARENT="a" CHILD="c"/>
      <ARC PARENT="b" CHILD="d"/><ARC PARENT="c" CHILD="d"/>
    </STRUCTURE>
    <DISTRIBUTIONS>
      <DIST TYPE="discrete"><PRIVATE NAME="a"/><DPIS><DPI> 0.2 0.8</DPI></DPIS></DIST>
      <DIST TYPE="discrete"><CONDSET><CONDELEM NAME="a"/></CONDSET><PRIVATE NAME="b"/>
        <DPIS><DPI INDEXES=" 0 "> 0.8 0.2</DPI><DPI INDEXES=" 1 "> 0.2 0.8</DPI></DPIS></DIST>
      <DIST TYPE="discrete"><CONDSET><CONDELEM NAME="a"/></CONDSET><PRIVATE NAME="c"/>
        <DPIS><DPI INDEXES=" 1 "> 0.05 0.95</DPI><DPI INDEXES=" 0 "> 0.2 0.8</DPI></DPIS></DIST>
      <DIST TYPE="discrete"><CONDSET><CONDELEM NAME="b"/><CONDELEM NAME="c"/></CONDSET>
        <PRIVATE NAME="d"/>
        <DPIS>
          <DPI INDEXES=" 0 0 "> 0.8 0.2</DPI><DPI INDEXES=" 0 1 "> 0.9 0.1</DPI>
          <DPI INDEXES=" 1 0 "> 0.7 0.3</DPI><DPI INDEXES=" 1 1 "> 0.05 0.95</DPI>
        </DPIS></DIST>
    </DISTRIBUTIONS>
  </BNMODEL>
</ANALYSISNOTEBOOK>"""


def test_reads_the_msr_cancer_example() -> None:
    net = xbn.loads(PGMPY_XBN)
    assert net.name == "Cancer"
    assert net.parents("d") == ("b", "c")
    np.testing.assert_array_equal(net.cpt("c"), [[0.2, 0.05], [0.8, 0.95]])
    assert net.cpt("d")[0, 1, 0] == 0.7
    assert net.variable("a").properties == {"description": "(a) Metastatic Cancer"}


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (('INDEXES=" 1 1 "', 'INDEXES=" 0 0 "'), "given twice"),
        (('INDEXES=" 1 1 "', 'INDEXES=" 1 2 "'), "does not fit"),
        (("> 0.05 0.95</DPI>\n", "> 0.05</DPI>\n"), "1 probabilities, expected 2"),
        (('<ARC PARENT="c" CHILD="d"/>', ""), "STRUCTURE> gives 'd' the parents ['b']"),
        (
            ('<CONDELEM NAME="c"/></CONDSET>', '<CONDELEM NAME="e"/></CONDSET>'),
            "'e' is not a declared",
        ),
        (('<PRIVATE NAME="a"/>', '<PRIVATE NAME="b"/>'), "a second <DIST>"),
        (("<DPI> 0.2 0.8</DPI>", "<DPI> 0.2 zz</DPI>"), "not a number"),
        (("</VARIABLES>", "</VARIABLE>"), "not well-formed"),
    ],
)
def test_malformed_xbn_names_the_element(change: tuple[str, str], words: str) -> None:
    old, new = change
    assert old in PGMPY_XBN
    with pytest.raises(FormatError) as caught:
        xbn.loads(PGMPY_XBN.replace(old, new, 1), path="bad.xbn")
    assert words in str(caught.value), str(caught.value)
    assert caught.value.path == "bad.xbn" and caught.value.line is not None


XMLBIF = """<?xml version="1.0"?>
<BIF VERSION="0.3">
<NETWORK>
<NAME>n</NAME>
<VARIABLE TYPE="nature"><NAME>a</NAME><OUTCOME>x</OUTCOME><OUTCOME>y</OUTCOME></VARIABLE>
<VARIABLE TYPE="nature"><NAME>b</NAME><OUTCOME>p</OUTCOME><OUTCOME>q</OUTCOME></VARIABLE>
<DEFINITION><FOR>a</FOR><TABLE>0.3 0.7</TABLE></DEFINITION>
<DEFINITION>
  <FOR>b</FOR>
  <GIVEN>a</GIVEN>
  <TABLE>0.1 0.9 0.4 0.6</TABLE>
</DEFINITION>
</NETWORK>
</BIF>
"""


@pytest.mark.parametrize(
    ("old", "new", "line", "words"),
    [
        ("0.1 0.9 0.4 0.6", "0.1 0.9 0.4", 11, "3 probabilities, expected 4"),
        ("<GIVEN>a</GIVEN>", "<GIVEN>c</GIVEN>", 8, "<GIVEN> 'c' is not a declared"),
        (
            "<FOR>a</FOR><TABLE>0.3 0.7",
            "<FOR>a</FOR><GIVEN>b</GIVEN><TABLE>0.3 0.7 0.5 0.5",
            7,
            "cycle",
        ),
        ("<OUTCOME>p</OUTCOME><OUTCOME>q", "<OUTCOME>p</OUTCOME><OUTCOME>p", 6, "twice"),
        ("0.1 0.9 0.4 0.6", "0.1 0.9 0.4 0.9", 8, "sums to 1.3"),
        ("0.3 0.7", "0.3 seven", 7, "'seven' is not a number"),
        (
            '<VARIABLE TYPE="nature"><NAME>b',
            '<VARIABLE TYPE="decision"><NAME>b',
            6,
            "TYPE='decision'",
        ),
        ("</NETWORK>", "", 14, "not well-formed"),
    ],
)
def test_malformed_xmlbif_names_line_and_element(old: str, new: str, line: int, words: str) -> None:
    assert old in XMLBIF
    with pytest.raises(FormatError) as caught:
        xmlbif.loads(XMLBIF.replace(old, new), path="bad.xml")
    assert words in str(caught.value), str(caught.value)
    assert caught.value.line == line, str(caught.value)


def test_reads_xml_text_with_and_without_declaration() -> None:
    assert xmlbif.loads(XMLBIF).cpt("b")[1, 1] == 0.6
    assert xmlbif.loads(XMLBIF.split("\n", 1)[1].encode()).cpt("b")[1, 1] == 0.6


def test_writer_refuses_what_xml_cannot_hold() -> None:
    net = BayesNet("n")
    net.add_variable("a", ["x\x01", "y"], cpt=[0.5, 0.5])
    with pytest.raises(FormatError):
        xmlbif.dumps(net)
    with pytest.raises(FormatError):
        xbn.dumps(net)


def test_kind_property_clash_is_refused() -> None:
    net = BayesNet("n")
    net.add_variable("a", ["x", "y"], cpt=[0.5, 0.5], properties={"kind": "B"})
    with pytest.raises(FormatError, match="rename it"):
        xmlbif.dumps(net)
