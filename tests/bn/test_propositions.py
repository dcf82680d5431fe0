"""Propositions (§2.4): parser fuzzing and probabilities against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.bn.helpers import condition, joint, random_net, sample_evidence

from bayesmap.bn import V, parse
from bayesmap.bn.propositions import And, Is, Not, Or, Proposition
from bayesmap.errors import InputError

NAMES = st.text(min_size=1, max_size=6).filter(lambda s: s.strip() == s and s.strip())


def propositions(
    names: st.SearchStrategy[str], states: st.SearchStrategy[str]
) -> st.SearchStrategy[Proposition]:
    atoms = st.builds(Is, names, states)
    return st.recursive(
        atoms,
        lambda inner: st.one_of(
            st.builds(And, inner, inner), st.builds(Or, inner, inner), st.builds(Not, inner)
        ),
        max_leaves=6,
    )


@settings(max_examples=200, deadline=None)
@given(prop=propositions(NAMES, NAMES))
def test_printing_then_parsing_gives_the_same_tree(prop: Proposition) -> None:
    assert parse(str(prop)) == prop


@settings(max_examples=300, deadline=None)
@given(text=st.text(max_size=30))
def test_parser_never_crashes_with_anything_but_input_error(text: str) -> None:
    try:
        parse(text)
    except InputError:
        pass


@pytest.mark.parametrize(
    "text",
    [
        "A=yes & !(B=no)",
        "A == yes and not B = no",
        "A=yes ∧ ¬(B=no)",
        "(A=yes) && ~B=no",
        "A=yes & B!=no",
    ],
)
def test_spellings_of_the_same_proposition(text: str) -> None:
    assert parse(text) == (V("A") == "yes") & ~(V("B") == "no")


def test_precedence_not_and_or() -> None:
    assert parse("a=1 | b=2 & !c=3") == Or(Is("a", "1"), And(Is("b", "2"), Not(Is("c", "3"))))


@pytest.mark.parametrize("text", ["", "A", "A=", "A=1 &", "(A=1", "A=1)", "& A=1", "A=1 B=2"])
def test_malformed_propositions_raise_input_error(text: str) -> None:
    with pytest.raises(InputError):
        parse(text)


def brute_probability(net, prop: Proposition, evidence: dict[str, str]) -> float:
    table = condition(net, joint(net), evidence)
    names = list(net.variables)
    grids = dict(zip(names, np.indices(table.shape), strict=True))
    mask = prop.holds(grids, lambda var, state: net.states(var).index(state))
    return float(table[mask].sum() / table.sum())


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), data=st.data())
def test_probability_matches_brute_force_and_the_rules(seed: int, data: st.DataObject) -> None:
    net = random_net(seed, n_vars=5)
    names = list(net.variables)
    atom = st.sampled_from(names).flatmap(
        lambda n: st.sampled_from(net.states(n)).map(lambda s: Is(n, s))
    )
    prop = data.draw(
        st.recursive(
            atom,
            lambda inner: st.one_of(
                st.builds(And, inner, inner), st.builds(Or, inner, inner), st.builds(Not, inner)
            ),
            max_leaves=5,
        )
    )
    evidence = sample_evidence(net, np.random.default_rng(seed), data.draw(st.integers(0, 2)))
    p = net.probability(prop, evidence)
    assert p == pytest.approx(brute_probability(net, prop, evidence), abs=1e-12)
    assert net.probability(~prop, evidence) == pytest.approx(1 - p, abs=1e-12)  # negation
    other = data.draw(atom)
    both = net.probability(prop & other, evidence)
    either = net.probability(prop | other, evidence)
    assert either == pytest.approx(p + net.probability(other, evidence) - both, abs=1e-12)
    assert net.probability(str(prop), evidence) == pytest.approx(p, abs=1e-15)


def test_probability_of_unknown_state_is_an_error() -> None:
    net = random_net(1, n_vars=3)
    with pytest.raises(InputError, match="no state"):
        net.probability("X0=nope")
