"""Hugin NET reading and writing: the format's variants, round trips, and located errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayesmap.bn import io
from bayesmap.bn.io import net as hugin
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError

from .helpers import assert_same, example, networks, plain_names

TEXT = """% written by hand, in the layouts the Hugin tools and pyAgrum write
net
{
    name = "wet grass";
    node_size = (80 40);
    HR_Note = "a \\"quoted\\" note";
}

discrete labelled node Rain
{
    label = "Did it rain?";
    position = (100 50);
    states = ("no" "yes");
}

node Sprinkler { states = ("off" "on"); kind = "A"; }   % the node kind, as BIF stores it

boolean node Wet { label = "Wet"; }                       % states false, true

numbered node Puddles { states = (0 1 2); }

potential (Rain) { data = (0.8 0.2); }
potential (Sprinkler | Rain) { data = ((0.6 0.4) (0.99 0.01)); }
potential ( Wet | Rain Sprinkler )
{
    data = (((1.0 0.0)      % Rain = no,  Sprinkler = off
             (0.1 0.9))     % Rain = no,  Sprinkler = on
            ((0.2 0.8)      % Rain = yes, Sprinkler = off
             (0.01 0.99))); % Rain = yes, Sprinkler = on
    experience = ((1 1) (1 1));
}
potential (Puddles | Wet) { data = ((0.9 0.1 0.0) (0.2 0.5 0.3)); }
"""


def test_reads_node_types_attributes_and_nested_data() -> None:
    net = hugin.loads(TEXT)
    assert net.name == "wet grass"
    assert net.properties == {"node_size": "(80 40)", "HR_Note": 'a "quoted" note'}
    assert net.states("Rain") == ("no", "yes")
    assert net.states("Wet") == ("false", "true")
    assert net.states("Puddles") == ("0", "1", "2")
    assert net.variable("Rain").properties == {"label": "Did it rain?", "position": "(100 50)"}
    assert net.variable("Wet").properties == {}  # a label equal to the name says nothing
    assert net.kind("Sprinkler").value == "A"
    assert net.parents("Wet") == ("Rain", "Sprinkler")
    # the first parent slowest, the child fastest: a CPT (child, *parents)
    np.testing.assert_array_equal(net.cpt("Wet")[:, 0, 1], [0.1, 0.9])  # no rain, on
    np.testing.assert_array_equal(net.cpt("Wet")[:, 1, 0], [0.2, 0.8])  # rain, off
    np.testing.assert_array_equal(net.cpt("Sprinkler")[:, 1], [0.99, 0.01])


def test_what_is_written_reads_back_and_keeps_the_attributes() -> None:
    net = hugin.loads(TEXT)
    text = hugin.dumps(net)
    assert "position = (100 50);" in text and 'label = "Did it rain?";' in text
    assert_same(net, hugin.loads(text))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(net=networks(plain_names, properties=False))
def test_text_round_trip_is_exact(net: BayesNet) -> None:
    assert_same(net, hugin.loads(hugin.dumps(net)))  # atol=0: every double bit for bit


@settings(
    max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    net=networks(plain_names, properties=False, max_variables=3),
    suffix=st.sampled_from([".net", ".net.gz"]),
)
def test_file_round_trip_by_extension(tmp_path, net: BayesNet, suffix: str) -> None:
    path = tmp_path / f"n{suffix}"
    io.write(net, path)
    assert_same(net, io.read(path))


@pytest.mark.parametrize("name", ["alarm", "insurance", "hailfinder"])
def test_bnlearn_networks_survive(name: str) -> None:
    net = io.read(example(name))
    assert_same(net, hugin.loads(hugin.dumps(net)))


def _with(old: str, new: str) -> str:
    assert old in TEXT
    return TEXT.replace(old, new, 1)


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        (_with("boolean node Wet", "decision Wet"), "a decision node", 18),
        (_with("boolean node Wet", "utility Wet"), "a utility node", 18),
        (_with("boolean node Wet", "continuous node Wet"), "a continuous node", 18),
        ("class Wet {\n instance Rain : Weather (); }", "an instance of a class", 2),
        ('class Wet { node A { states = ("x"); } potential (A) { data = (1); }', "never closed", 1),
        ("class Wet { } class Dry { }", "text after the end of the class", 1),
        (_with("potential (Rain) {", "potential (Rain Sprinkler) {"), "exactly one node", 22),
        (_with("data = (0.8 0.2);", "model_nodes = (); model_data = (1);"), "expressions", 22),
        (_with("data = (0.8 0.2);", "data = (0.8 0.1 0.1);"), "3 probabilities, expected 2", 22),
        (_with("data = (0.8 0.2);", "data = (0.8 nan);"), "'nan' is not a number", 22),
        (_with("data = (0.8 0.2);", 'data = (0.8 "0.2");'), "in a list of numbers", 22),
        (_with("data = (0.8 0.2);", "data = ((0.8 0.2);"), "';' in a list of numbers", 22),
        (_with("(Puddles | Wet)", "(Puddles | Rain2)"), "parent 'Rain2' is not declared", 32),
        (_with('states = ("off" "on");', 'states = ("off" "off");'), "twice", 16),
        (_with('states = ("off" "on");', 'states = ("off" "on);'), "unterminated string", 16),
        (_with("numbered node Puddles { states = (0 1 2); }", ""), "'Puddles' is not declared", 32),
        (
            _with("position = (100 50);", "position = (100 50); label = 1;"),
            "'label' is given twice",
            12,
        ),
        (_with("potential (Rain) {", "potential (Rain) { data = (0.5 0.5);"), "given twice", 22),
        (TEXT + "potential (Rain) { data = (0.5 0.5); }", "a second potential", 33),
        (_with("(Sprinkler | Rain)", "(Sprinkler | | Rain)"), "a second '|'", 23),
        (_with("node Sprinkler { states", "node 9lives { states"), "a node name", 16),
        ("", "empty", None),
    ],
)
def test_malformed_files_name_the_line(text: str, message: str, line: int | None) -> None:
    with pytest.raises(FormatError, match=message) as caught:
        hugin.loads(text, path="n.net")
    assert caught.value.path == "n.net" and caught.value.line == line


def test_a_plain_network_saved_as_a_class_reads_as_the_network() -> None:
    # The Hugin tools save a network as a class with an empty interface; labels may be
    # empty, tables unnormalised (Hugin normalises them), and interval nodes may name their
    # states only by their bounds.
    net = hugin.loads(
        """class Survey
{
    inputs = ();
    outputs = ();
    HR_Grid_X = "40";

    node Age
    {
	label = "";
	states = ("" "" "");
	subtype = interval;
	state_values = (0 18 65 120);
    }

    node Count { states = ("" ""); subtype = number; state_values = (1 2); }

    potential (Age) { data = ( 1 2 1 ); }
    potential (Count | Age) { data = ((1 0) (0.5 0.5) (0 1)); }
} % class Survey
"""
    )
    assert net.name == "Survey"
    assert net.properties == {"HR_Grid_X": "40"}  # the empty interface lists say nothing
    assert net.states("Age") == ("[0, 18)", "[18, 65)", "[65, 120)")
    assert net.states("Count") == ("1", "2")
    assert net.variable("Age").properties["label"] == ""
    np.testing.assert_allclose(net.cpt("Age"), [0.25, 0.5, 0.25])


def test_a_node_without_a_table_is_named() -> None:
    with pytest.raises(FormatError, match="'Puddles' has no probability table"):
        hugin.loads(
            _with("potential (Puddles | Wet) { data = ((0.9 0.1 0.0) (0.2 0.5 0.3)); }", "")
        )


def test_the_writer_refuses_what_net_cannot_name() -> None:
    net = BayesNet("n")
    net.add_variable("smoke level", ["low", "high"], cpt=[0.5, 0.5])
    with pytest.raises(FormatError, match="'smoke level' is not a NET name"):
        hugin.dumps(net)
    net = BayesNet("n")
    net.add_variable("smoke", ["low", "high"], cpt=[0.5, 0.5], properties={"data": "x"})
    with pytest.raises(FormatError, match="cannot be a NET attribute"):
        hugin.dumps(net)


def test_a_net_file_is_known_by_its_content(tmp_path) -> None:
    path = tmp_path / "grass.hugin"
    path.write_text(TEXT)
    assert io.sniff(TEXT.encode()) is io.FORMATS["net"]
    assert io.sniff(b"% saved by Hugin\nclass Survey\n{") is io.FORMATS["net"]
    assert io.sniff(b"classes { }") is None
    assert io.read(path).name == "wet grass"
