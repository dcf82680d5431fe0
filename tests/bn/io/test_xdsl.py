"""GeNIe XDSL reading and writing: GeNIe's layout, round trips, peers, and located errors."""

from __future__ import annotations

import logging
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pgmpy.readwrite import XDSLReader, XDSLWriter

from bayesmap.bn import io
from bayesmap.bn.io import xdsl
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError

from .helpers import assert_matches_pgmpy, assert_same, example, networks, plain_names

logging.getLogger("pgmpy").setLevel(logging.ERROR)

# Laid out as GeNIe saves a network: diagnosis attributes, state labels, a submodel in the
# layout extension. The numbers are the Asia network's (Lauritzen & Spiegelhalter 1988).
TEXT = """<?xml version="1.0" encoding="UTF-8"?>
<!-- This network was created in GeNIe -->
<smile version="1.0" id="Asia" numsamples="10000" discsamples="10000">
  <properties>
    <property id="source">Lauritzen and Spiegelhalter 1988</property>
  </properties>
  <nodes>
    <cpt id="either" diagtype="auxiliary">
      <state id="Nothing" />
      <state id="CancerORTuberculosis" />
      <probabilities>0.9 0.1</probabilities>
    </cpt>
    <cpt id="bronc" diagtype="target">
      <state id="Absent" label="F15" />
      <state id="Present" label="F16" fault="true" />
      <probabilities>0.55 0.45</probabilities>
      <property id="kind">C</property>
    </cpt>
    <cpt id="dysp" diagtype="observation" ranked="true">
      <state id="Absent" />
      <state id="Present" />
      <parents>either bronc</parents>
      <probabilities>0.9 0.1 0.2 0.8 0.3 0.7 0.1 0.9</probabilities>
    </cpt>
    <deterministic id="alarm">
      <state id="quiet" />
      <state id="ringing" />
      <parents>dysp</parents>
      <resultingstates>quiet ringing</resultingstates>
    </deterministic>
  </nodes>
  <extensions>
    <genie version="1.0" app="GeNIe 2.0" name="Asia network">
      <node id="either">
        <name>Tuberculosis or cancer</name>
        <interior color="e5f6f7" />
        <position>56 128 148 176</position>
      </node>
      <submodel id="Symptoms">
        <name>Symptoms</name>
        <node id="dysp">
          <name>dysp</name>
          <position>10 10 82 58</position>
        </node>
      </submodel>
      <textbox><caption>A note</caption><position>0 0 10 10</position></textbox>
    </genie>
  </extensions>
</smile>
"""


def test_reads_genie_layout_names_and_tables() -> None:
    net = xdsl.loads(TEXT)
    assert net.name == "Asia network"  # the extension's name: the id is an identifier
    assert net.properties == {"source": "Lauritzen and Spiegelhalter 1988"}
    assert net.states("bronc") == ("Absent", "Present")
    assert net.parents("dysp") == ("either", "bronc")
    assert net.variable("either").properties == {"label": "Tuberculosis or cancer"}
    assert net.variable("dysp").properties == {}  # a name equal to the id says nothing
    assert net.kind("bronc").value == "C"
    # the last parent fastest, the node's own states fastest of all: Asia's dyspnoea is
    # 0.8 likely with bronchitis alone and 0.7 with tuberculosis or cancer alone
    cpt = net.cpt("dysp")
    np.testing.assert_array_equal(cpt[:, 0, 1], [0.2, 0.8])
    np.testing.assert_array_equal(cpt[:, 1, 0], [0.3, 0.7])
    posterior = net.posterior("dysp", {"either": "Nothing", "bronc": "Present"})
    assert posterior["Present"] == pytest.approx(0.8)


def test_a_deterministic_node_reads_as_a_table_of_zeros_and_ones() -> None:
    np.testing.assert_array_equal(xdsl.loads(TEXT).cpt("alarm"), [[1.0, 0.0], [0.0, 1.0]])


def test_what_is_written_reads_back_with_names_kinds_and_layout() -> None:
    net = xdsl.loads(TEXT)
    text = xdsl.dumps(net)
    assert '<smile version="1.0" id="Asia_network"' in text
    assert "<name>Tuberculosis or cancer</name>" in text
    assert '<property id="kind">C</property>' in text and "<position>" in text
    assert_same(net, xdsl.loads(text))


identifiers = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,5}", fullmatch=True)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(net=networks(identifiers, kinds=True))
def test_text_round_trip_is_exact(net: BayesNet) -> None:
    assert_same(net, xdsl.loads(xdsl.dumps(net)))  # atol=0: every double bit for bit


@settings(
    max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    net=networks(plain_names, properties=False, max_variables=3),
    suffix=st.sampled_from([".xdsl", ".xdsl.gz"]),
)
def test_file_round_trip_by_extension(tmp_path, net: BayesNet, suffix: str) -> None:
    path = tmp_path / f"n{suffix}"
    io.write(net, path)
    assert_same(net, io.read(path))


@pytest.mark.parametrize("name", ["asia", "alarm", "insurance", "hailfinder", "win95pts"])
def test_pgmpy_reads_what_we_write_and_we_read_what_it_writes(tmp_path, name: str) -> None:
    net = io.read(example(name))
    ours = io.write(net, tmp_path / "ours.xdsl")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = XDSLReader(str(ours)).get_model()
        assert_matches_pgmpy(net, model)
        XDSLWriter(model, network_id=name).write_xdsl(str(tmp_path / "theirs.xdsl"))
    assert_same(net, io.read(tmp_path / "theirs.xdsl"), atol=1e-15, names=False)


def test_a_file_is_known_by_its_content(tmp_path) -> None:
    path = tmp_path / "model.txt"
    path.write_text(TEXT)
    assert io.read(path).name == "Asia network"


def _with(old: str, new: str) -> str:
    assert old in TEXT
    return TEXT.replace(old, new, 1)


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        (_with('<deterministic id="alarm">', '<noisymax id="alarm">').replace(
            "</deterministic>", "</noisymax>"), "'alarm' is a noisy-MAX node", 25),
        (_with('<cpt id="either" diagtype="auxiliary">', '<decision id="either">').replace(
            "</cpt>", "</decision>", 1), "a decision node", 8),
        (_with('<cpt id="either" diagtype="auxiliary">', '<equation id="either">').replace(
            "</cpt>", "</equation>", 1), "an equation (continuous) node", 8),
        (_with("<parents>either bronc</parents>", "<parents>either smoke</parents>"),
         "parent 'smoke' of 'dysp' is not a node", 19),
        (_with("<parents>either bronc</parents>", "<parents>bronc bronc</parents>"),
         "listed twice", 19),
        (_with("0.9 0.1 0.2 0.8 0.3 0.7 0.1 0.9", "0.9 0.1 0.2 0.8"),
         "4 numbers, expected 8", 23),
        (_with("<probabilities>0.9 0.1</probabilities>",
               "<probabilities>0.9 nan</probabilities>"), "'nan' is not a number", 11),
        (_with('<state id="Present" />', '<state id="Absent" />'), "twice", 19),
        (_with("<resultingstates>quiet ringing</resultingstates>",
               "<resultingstates>quiet loud</resultingstates>"), "'loud' is not a state", 29),
        (_with("<resultingstates>quiet ringing</resultingstates>",
               "<resultingstates>quiet</resultingstates>"), "lists 1 states, expected", 29),
        (_with('<cpt id="bronc" diagtype="target">', '<cpt id="" diagtype="target">'),
         "empty id", 13),
        (TEXT.replace("smile", "bif"), "the root element must be <smile>", 3),
        ("<smile", "not well-formed XML", 1),
    ],
)  # fmt: skip
def test_malformed_files_name_the_line(text: str, message: str, line: int | None) -> None:
    with pytest.raises(FormatError, match=message.replace("(", r"\(").replace(")", r"\)")) as info:
        xdsl.loads(text, path="asia.xdsl")
    assert info.value.line == line and "asia.xdsl" in str(info.value)


def test_the_writer_refuses_what_xdsl_cannot_name() -> None:
    net = BayesNet("odd")
    net.add_variable("ok", ["<0.5m", ">=0.5m"], cpt=[0.5, 0.5])
    with pytest.raises(FormatError, match="state of 'ok' '<0.5m' is not a SMILE identifier"):
        xdsl.dumps(net)
    net = BayesNet("odd")
    net.add_variable("_hidden", ["a", "b"], cpt=[0.5, 0.5])
    with pytest.raises(FormatError, match="node '_hidden' is not a SMILE identifier"):
        xdsl.dumps(net)
