"""The model: CPT layout (eq. 29), run-time changes, validation and normalisation policy."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.bn import BayesNet, NodeKind, cpt_from_flat
from bayesmap.bn.model import CPTNormalisationWarning
from bayesmap.errors import ModelError


def two_parent_net() -> BayesNet:
    net = BayesNet("t")
    net.add_variable("A", ["a0", "a1"], cpt=[0.3, 0.7])
    net.add_variable("B", ["b0", "b1", "b2"], cpt=[0.2, 0.3, 0.5])
    table = np.arange(1, 1 + 4 * 2 * 3, dtype=float).reshape(4, 2, 3)
    net.add_variable("C", ["c0", "c1", "c2", "c3"], parents=["A", "B"], cpt=table / table.sum(0))
    return net


def test_flat_cpt_follows_eq_29_child_fastest() -> None:
    net = two_parent_net()
    flat = net.flat_cpt("C")
    table = net.cpt("C")
    for m1 in range(4):
        for m2 in range(2):
            for m3 in range(3):
                assert flat[m1 + m2 * 4 + m3 * 4 * 2] == table[m1, m2, m3]
    assert np.array_equal(cpt_from_flat(flat, table.shape), table)


def test_add_parent_repeats_the_old_table_and_keeps_answers() -> None:
    net = two_parent_net()
    before = net.posterior("C")
    net.add_variable("D", ["d0", "d1"], cpt=[0.5, 0.5])
    old_flat = net.flat_cpt("C")
    net.add_parent("C", "D")
    assert net.parents("C") == ("A", "B", "D")
    flat = net.flat_cpt("C")
    assert np.array_equal(flat[: old_flat.size], old_flat)
    assert np.array_equal(flat[old_flat.size :], old_flat)
    assert net.posterior("C") == pytest.approx(before)
    assert net.posterior("C", {"D": "d1"}) == pytest.approx(before)


def test_changes_invalidate_cached_answers() -> None:
    net = two_parent_net()
    first = net.posterior("A", {"C": "c0"})
    table = np.array(net.cpt("C"))
    table[:, 0, :] = table[::-1, 0, :]
    net.set_cpt("C", table)
    assert net.posterior("A", {"C": "c0"}) != pytest.approx(first)


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"parents": ["Nope"]}, "'Nope' is not in the network"),
        ({"parents": ["A"], "cpt": [[0.5, 0.2], [0.5, 0.2]]}, "A=a1"),
        ({"parents": ["A"], "cpt": [0.5, 0.5]}, "expected (2, 2)"),
        ({"cpt": [-0.5, 1.5]}, "negative probability at state 'x0'"),
    ],
)
def test_bad_variables_raise_model_error_naming_the_node(kwargs: dict, needle: str) -> None:
    net = two_parent_net()
    with pytest.raises(ModelError, match="'X'") as info:
        net.add_variable("X", ["x0", "x1"], **kwargs)
    assert needle in str(info.value)


def test_cycle_is_refused() -> None:
    net = two_parent_net()
    with pytest.raises(ModelError, match="cycle"):
        net.add_parent("A", "C")


def test_rows_slightly_off_are_renormalised_with_a_warning() -> None:
    net = BayesNet()
    with pytest.warns(CPTNormalisationWarning, match="'R'"):
        net.add_variable("R", ["r0", "r1"], cpt=[0.3, 0.7001])
    assert net.cpt("R").sum() == pytest.approx(1.0, abs=1e-15)


def test_kinds_are_metadata() -> None:
    net = two_parent_net()
    net.set_kind("C", "C")
    assert net.kind("C") is NodeKind.CLASSIFICATION
    with pytest.raises(ModelError, match="unknown node kind"):
        net.set_kind("C", "Z")


@pytest.mark.parametrize("seed", range(5))
def test_ancestors_are_every_variable_with_a_directed_path_in(seed: int) -> None:
    """Checked against reachability along reversed edges, on random DAGs."""
    rng = np.random.default_rng(seed)
    n = 12
    net = BayesNet("dag")
    for k in range(n):
        chosen = [f"V{j}" for j in range(k) if rng.random() < 0.25][:3]
        shape = (2, *([2] * len(chosen)))
        cpt = np.full(shape, 0.5)
        net.add_variable(f"V{k}", ["s0", "s1"], parents=chosen, cpt=cpt)
    reach = np.eye(n, dtype=bool)  # reach[a, b]: a directed path from a to b (or a == b)
    for k in range(n):
        for parent in net.parents(f"V{k}"):
            reach[:, k] |= reach[:, int(parent[1:])]
    for k in range(n):
        want = {f"V{a}" for a in range(n) if reach[a, k] and a != k}
        assert net.ancestors([f"V{k}"]) == want
    union = net.ancestors(["V3", "V11"])
    assert union == net.ancestors(["V3"]) | net.ancestors(["V11"])
    with pytest.raises(ModelError):
        net.ancestors(["nowhere"])
