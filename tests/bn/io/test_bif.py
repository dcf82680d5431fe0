"""BIF reading: the format's variants, full precision, and located errors."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.bn.io import bif
from bayesmap.errors import FormatError

HEADER = """network test {
}
variable a {
  type discrete [ 2 ] { x, y };
}
variable b {
  type discrete [ 3 ] { p, q, r };
}
"""


def test_reads_comments_quotes_odd_states_and_properties() -> None:
    text = """// a comment with "quotes" and { braces
network "my net" { property author = "A. \\"B\\" C" ; }
/* block
   comment */
variable "smoke level" {
  type discrete [ 3 ] { <5, 5-12, "a, b" };   // trailing
  property kind = "A" ;
  property "position = (1, 2)" ;
}
variable Asy/Patch {
  type discrete [ 2 ] { yes no };
}
probability ( "smoke level" ) { table 0.2 0.3 0.5; }
probability ( Asy/Patch | "smoke level" ) {
  ( <5 ) 0.1, 0.9;
  ( "a, b" ) 0.3 0.7;
  default 0.5, 0.5;
}
"""
    net = bif.loads(text)
    assert net.name == "my net"
    assert net.properties == {"author": 'A. "B" C'}
    assert net.states("smoke level") == ("<5", "5-12", "a, b")
    assert net.states("Asy/Patch") == ("yes", "no")
    assert net.kind("smoke level").value == "A"
    assert net.variable("smoke level").properties == {"position": "(1, 2)"}
    np.testing.assert_array_equal(net.cpt("Asy/Patch"), [[0.1, 0.5, 0.3], [0.9, 0.5, 0.7]])


def test_table_with_parents_is_child_major_like_pgmpy_and_pyagrum() -> None:
    net = bif.loads(
        HEADER
        + """variable c { type discrete [ 2 ] { u, v }; }
probability ( a ) { table 0.2, 0.8; }
probability ( b ) { table 0.2, 0.3, 0.5; }
probability ( c | a, b ) { table 0.1 0.2 0.3 0.4 0.5 0.6 0.9 0.8 0.7 0.6 0.5 0.4; }
"""
    )
    assert net.cpt("c")[0, 1, 0] == 0.4  # c=u | a=y, b=p
    assert net.cpt("c")[1, 0, 2] == 0.7


def test_old_style_header_without_bar() -> None:
    net = bif.loads(
        HEADER
        + """probability ( a ) { table 0.5 0.5; }
probability ( b a ) { (x) 0.2 0.3 0.5; (y) 0.1 0.1 0.8; }
"""
    )
    assert net.parents("b") == ("a",)


def test_javabayes_lists_of_quoted_names_need_no_commas() -> None:
    # JavaBayes' BIF 0.15 writes quoted names one after another, without commas, in the
    # states and in old-style headers (as in its classic "Dog-Problem" example).
    net = bif.loads(
        """// Produced by BayesianNetworks package in JavaBayes
network "Dog-Problem" { //3 variables and 3 probability distributions
	property "credal-set constant-density-bounded 1.1" ;
}
variable  "family-out" { //2 values
	type discrete[2] {  "true"  "false" };
	property "position = (257, 99)" ;
}
variable  "light-on" { //2 values
	type discrete[2] {  "true"  "false" };
}
variable "hear-bark" { type discrete[2] {"true""false"}; }
probability (  "light-on"  "family-out" ) { //2 variable(s) and 4 values
	table 0.6 0.05 0.4 0.95 ;
}
probability (  "family-out" ) { //1 variable(s) and 2 values
	table 0.15 0.85 ;
}
probability ( "hear-bark" "light-on" ) { table 0.7 0.01 0.3 0.99 ; }
"""
    )
    assert net.states("light-on") == ("true", "false")
    assert net.states("hear-bark") == ("true", "false")
    assert net.parents("light-on") == ("family-out",)
    assert net.cpt("light-on")[0].tolist() == [0.6, 0.05]  # P(on | out), P(on | not out)
    on = 0.15 * 0.6 + 0.85 * 0.05
    assert net.posterior("light-on")["true"] == pytest.approx(on)
    assert net.posterior("family-out", {"light-on": "true"})["true"] == pytest.approx(0.09 / on)
    with pytest.raises(FormatError, match="list of names"):
        bif.loads(HEADER.replace("{ x, y }", '{ "x" y }'))


def test_keeps_full_double_precision() -> None:
    value = 0.123456789012345678
    net = bif.loads(
        HEADER + f"probability ( a ) {{ table {value!r}, {1 - value!r}; }}\n"
        "probability ( b ) { table 0.2, 0.3, 0.5; }\n"
    )
    assert net.cpt("a")[0] == value


def test_variable_order_does_not_matter() -> None:
    text = """probability ( b | a ) { (x) 0.2 0.3 0.5; (y) 0.1 0.1 0.8; }
variable b { type discrete [ 3 ] { p, q, r }; }
probability ( a ) { table 0.5 0.5; }
variable a { type discrete [ 2 ] { x, y }; }
"""
    net = bif.loads(text)
    assert net.variables == ("a", "b")


GOOD_TAIL = (
    "probability ( a ) { table 0.5, 0.5; }\n"
    "probability ( b | a ) {\n  (x) 0.2, 0.3, 0.5;\n  (y) 0.1, 0.1, 0.8;\n}\n"
)


@pytest.mark.parametrize(
    ("tail", "line", "words"),
    [
        (GOOD_TAIL.replace("(y) 0.1, 0.1, 0.8", "(z) 0.1, 0.1, 0.8"), 12, "no state 'z'"),
        (GOOD_TAIL.replace("0.2, 0.3, 0.5", "0.2, 0.8"), 11, "2 probabilities, expected 3"),
        (GOOD_TAIL.replace("(y) 0.1, 0.1, 0.8;", ""), 10, "no probabilities for a=y"),
        (GOOD_TAIL.replace("(y)", "(x)"), 12, "already given"),
        (GOOD_TAIL.replace("b | a", "b | c"), 10, "parent 'c' is not declared"),
        (GOOD_TAIL.replace("0.1, 0.1, 0.8", "0.1, x1, 0.8"), 12, "'x1' is not a number"),
        (GOOD_TAIL.replace("0.1, 0.1, 0.8", "0.5, 0.5, 0.8"), 10, "sums to 1.8"),
        (GOOD_TAIL.replace("0.5, 0.5;", "0.5, 0.5"), 9, "without a closing ';'"),
        (GOOD_TAIL + "probability ( a ) { table 0.5, 0.5; }\n", 14, "a second probability block"),
        (GOOD_TAIL + "variable a { type discrete [ 2 ] { x, y }; }\n", 14, "declared twice"),
        (GOOD_TAIL + "oops\n", 14, "found 'oops'"),
        (
            GOOD_TAIL.replace("probability ( a ) { table 0.5, 0.5; }\n", ""),
            3,
            "no probability table",
        ),
        (GOOD_TAIL.rstrip("}\n") + "\n", 10, "never closed"),
    ],
)
def test_malformed_files_name_the_line(tail: str, line: int, words: str) -> None:
    with pytest.raises(FormatError) as caught:
        bif.loads(HEADER + tail, path="bad.bif")
    assert caught.value.path == "bad.bif"
    assert caught.value.line == line, str(caught.value)
    assert words in str(caught.value)
    assert str(caught.value).startswith(f"bad.bif, line {line}")


def test_cycle_is_a_format_error() -> None:
    text = (
        HEADER
        + """probability ( a | b ) { (p) 0.5 0.5; (q) 0.5 0.5; (r) 0.5 0.5; }
probability ( b | a ) { (x) 0.2 0.3 0.5; (y) 0.1 0.1 0.8; }
"""
    )
    with pytest.raises(FormatError, match="cycle"):
        bif.loads(text)


def test_an_empty_file_is_not_a_network() -> None:
    with pytest.raises(FormatError, match="empty.bif: the file is empty"):
        bif.loads(" \n", path="empty.bif")


def test_a_cycle_is_named_without_the_variables_below_it() -> None:
    lines = ["network n {}"]
    lines += [f"variable {v} {{ type discrete [ 2 ] {{ x, y }}; }}" for v in "ABCD"]
    lines += [
        f"probability ( {child} | {parent} ) {{ default 0.5, 0.5; }}"
        for child, parent in [("A", "B"), ("B", "A"), ("C", "A"), ("D", "C")]
    ]
    with pytest.raises(FormatError, match=r"cycle through \['A', 'B'\]$"):
        bif.loads("\n".join(lines))


def test_state_count_must_match_declaration() -> None:
    with pytest.raises(FormatError, match="declares 3 states but lists 2") as caught:
        bif.loads("variable a {\n  type discrete [ 3 ] { x, y };\n}\n")
    assert caught.value.line == 2


def test_writer_quotes_what_is_not_an_identifier() -> None:
    net = bif.loads(HEADER + GOOD_TAIL)
    text = bif.dumps(net)
    assert "variable a {" in text and "{ x, y }" in text
    from bayesmap.bn.model import BayesNet

    odd = BayesNet("n")
    odd.add_variable('say "hi"\\', ["<5", "a b"], cpt=[0.5, 0.5])
    out = bif.dumps(odd)
    assert 'variable "say \\"hi\\"\\\\" {' in out
    assert '{ "<5", "a b" }' in out
    assert bif.loads(out).states('say "hi"\\') == ("<5", "a b")


def test_writer_refuses_names_with_surrounding_whitespace() -> None:
    from bayesmap.bn.model import BayesNet

    net = BayesNet("n")
    net.add_variable("a", [" x", "y"], cpt=[0.5, 0.5])
    with pytest.raises(FormatError, match="whitespace"):
        bif.dumps(net)
