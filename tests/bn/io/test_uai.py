"""UAI reading and writing: the evaluation format's layout, round trips, peers, located errors."""

from __future__ import annotations

import numpy as np
import pyagrum as gum
import pytest
from hypothesis import HealthCheck, given, settings

from bayesmap.bn import io
from bayesmap.bn.io import uai
from bayesmap.bn.model import BayesNet
from bayesmap.errors import FormatError
from bayesmap.limits import ReadLimits

from .helpers import networks, plain_names

TEXT = """c a sprinkler network, written by hand
BAYES
3
2 2 3
3
1 0
2 0 1
3 0 1 2   # rain, sprinkler, then the wet grass: the child last

2
 0.8 0.2
4
 0.6 0.4
 0.99 0.01
12
 1.0 0.0 0.0   0.1 0.6 0.3
 0.2 0.5 0.3   0.01 0.09 0.9
"""


def test_reads_the_layout_with_the_last_variable_of_a_scope_fastest() -> None:
    net = uai.loads(TEXT, path="sprinkler.uai")
    assert net.name == "sprinkler" and net.variables == ("0", "1", "2")
    assert net.states("2") == ("0", "1", "2")
    assert net.parents("2") == ("0", "1")
    np.testing.assert_array_equal(net.cpt("2")[:, 0, 1], [0.1, 0.6, 0.3])  # no rain, on
    np.testing.assert_array_equal(net.cpt("2")[:, 1, 0], [0.2, 0.5, 0.3])  # rain, off
    # P(grass = 2) by hand: Σ P(r) P(s | r) P(2 | r, s)
    by_hand = 0.8 * (0.6 * 0.0 + 0.4 * 0.3) + 0.2 * (0.99 * 0.3 + 0.01 * 0.9)
    assert net.posterior("2")["2"] == pytest.approx(by_hand)


def _renamed(net: BayesNet) -> BayesNet:
    """``net`` as UAI names it: variable ``i`` is ``i``, its states ``0``, ``1``, ..."""
    index = {name: str(i) for i, name in enumerate(net.variables)}
    out = BayesNet("n")
    for name in net.variables:
        out.add_variable(
            index[name],
            [str(k) for k in range(len(net.states(name)))],
            parents=[index[p] for p in net.parents(name)],
            cpt=net.cpt(name),
        )
    return out


def _same_tables(a: BayesNet, b: BayesNet, atol: float = 0.0) -> None:
    assert a.variables == b.variables
    for name in a.variables:
        assert a.parents(name) == b.parents(name), name
        assert a.states(name) == b.states(name), name
        np.testing.assert_allclose(a.cpt(name), b.cpt(name), rtol=0, atol=atol, err_msg=name)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(net=networks(plain_names, properties=False))
def test_text_round_trip_keeps_structure_and_tables_exactly(net: BayesNet) -> None:
    _same_tables(_renamed(net), uai.loads(uai.dumps(net)))


def _tree(seed: int) -> BayesNet:
    """A random network in which every variable has at most one parent: the tables of
    such a network have one layout whatever order a reader gives the parents."""
    rng = np.random.default_rng(seed)
    net = BayesNet("tree")
    for i in range(8):
        states = [f"s{k}" for k in range(int(rng.integers(2, 5)))]
        parents = [] if i == 0 else [str(int(rng.integers(0, i)))]
        shape = (len(states), *(len(net.states(p)) for p in parents))
        table = rng.dirichlet(np.ones(len(states)), size=shape[1:]).reshape(*shape[1:], -1)
        net.add_variable(str(i), states, parents=parents, cpt=np.moveaxis(table, -1, 0))
    return net


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pyagrum_reads_what_we_write_and_we_read_what_it_writes(tmp_path, seed: int) -> None:
    net = _tree(seed)
    bn = gum.loadBN(str(io.write(net, tmp_path / "ours.uai")))  # pyAgrum keeps float32
    engine = gum.LazyPropagation(bn)
    engine.makeInference()
    for name in net.variables:
        ours = list(net.posterior(name).values())
        np.testing.assert_allclose(engine.posterior(name).tolist(), ours, rtol=0, atol=1e-7)
    gum.saveBN(bn, str(tmp_path / "theirs.uai"))
    _same_tables(_renamed(net), io.read(tmp_path / "theirs.uai"), atol=1e-5)  # 6 digits


def test_a_file_is_known_by_its_content(tmp_path) -> None:
    path = tmp_path / "model.txt"
    path.write_text(TEXT)
    assert io.read(path).parents("2") == ("0", "1")


def _with(old: str, new: str) -> str:
    assert old in TEXT
    return TEXT.replace(old, new, 1)


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        (_with("BAYES", "MARKOV"), "a MARKOV network", 2),
        (_with("BAYES", "ERGO"), "starts with BAYES, not 'ERGO'", 2),
        (_with("3\n1 0", "2\n1 0"), "2 functions for 3 variables", 5),
        (_with("2 0 1\n", "2 0 7\n"), "is 7, but there are only 3", 7),
        (_with("2 0 1\n", "2 1 1\n"), "lists a variable twice", 7),
        (_with("2 0 1\n", "2 1 0\n"), "functions 0 and 1 both end with variable 0", 7),
        (_with("12\n", "11\n"), "has 11 entries, its scope [0, 1, 2] needs 12", 15),
        (_with("0.8 0.2", "0.8 nan"), "'nan' is not a number", 11),
        (_with("2 2 3", "2 x 3"), "must be a whole number, got 'x'", 4),
        (TEXT + "7\n", "text after the last table", 18),
        (TEXT[: TEXT.index("12\n") + 10], "the file ends inside table 2", None),
        ("", "the file ends where the network type", None),
    ],
)
def test_malformed_files_name_the_line(text: str, message: str, line: int | None) -> None:
    with pytest.raises(FormatError, match=message.replace("[", r"\[").replace("]", r"\]")) as info:
        uai.loads(text, path="s.uai")
    if line is not None:
        assert info.value.line == line
    assert "s.uai" in str(info.value)


def test_table_sizes_are_checked_before_they_are_read() -> None:
    with pytest.raises(FormatError, match="entries in the table of '2'.*max_table_entries"):
        uai.loads(TEXT, limits=ReadLimits(max_table_entries=11))
    assert len(uai.loads(TEXT, limits=ReadLimits(max_table_entries=12))) == 3


def test_a_huge_number_of_states_is_refused_before_anything_is_made() -> None:
    text = TEXT.replace("2 2 3", "2 2 27777777777777777777777", 1)
    with pytest.raises(FormatError, match="states of variable 2.*max_table_entries") as info:
        uai.loads(text)
    assert info.value.line == 4
