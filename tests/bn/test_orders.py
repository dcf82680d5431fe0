"""The compiled core of a pattern's first question (``bayesmap.bn._orders``) against plain
Python references written here: the elimination walk, the min-weight order and the small
sum-products, on random inputs, and what each does with inputs it does not take."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from bayesmap.bn import _orders, elimination

FAST = settings(max_examples=150, deadline=None)


@st.composite
def factor_scopes(draw: st.DrawFn) -> tuple[list[tuple[int, ...]], list[int]]:
    """Scopes of up to 12 factors over up to 10 variables (and sometimes the case axis −1),
    with the variables' sizes."""
    n_vars = draw(st.integers(1, 10))
    card = draw(st.lists(st.integers(1, 4), min_size=n_vars, max_size=n_vars))
    labels = st.integers(-1, n_vars - 1) if draw(st.booleans()) else st.integers(0, n_vars - 1)
    scopes = draw(
        st.lists(st.lists(labels, max_size=4, unique=True).map(tuple), min_size=1, max_size=12)
    )
    return scopes, card


Walked = tuple[list[tuple[int, ...]], list[tuple[int, ...]], list[tuple[int, tuple[int, ...]]], int]
"""An order walked: path, kept labels, each step's entries and labels, total."""


def reference_walk(
    scopes: list[tuple[int, ...]],
    labels: list[int],
    output: tuple[int, ...],
    size: dict[int, int],
    constant: list[bool] | None,
    limit: int | None,
) -> Walked | None:
    """What :func:`_orders.eliminate` documents, by the Python path reader: each label in turn
    summed with the operands holding it — passed over while one of them depends on the
    evidence, then summed after the rest — and what is left joined into ``output``."""
    walker = elimination.Walker(scopes, output)
    path: list[tuple[int, ...]] = []
    kept: list[tuple[int, ...]] = []
    records: list[tuple[int, tuple[int, ...]]] = []
    fixed = list(constant) if constant is not None else None
    deferred: list[int] = []
    rounds = [labels, deferred] if fixed is not None else [labels]
    total = 0
    for batch in rounds:
        for u in batch:
            chosen = tuple(walker.holders.get(u, ()))
            if not chosen:
                continue
            if fixed is not None:
                evidence_free = all(fixed[i] for i in chosen)
                if not evidence_free and batch is not deferred:
                    deferred.append(u)
                    continue
                fixed.append(evidence_free)
            step = walker.step(chosen)
            entries = math.prod(size[x] for x in step.union)
            total += entries
            if limit is not None and total > limit:
                return None
            path.append(chosen)
            kept.append(step.kept)
            records.append((entries, step.union))
    rest = tuple(walker.open)
    if len(rest) > 1 or not path:
        union = tuple(dict.fromkeys(x for i in rest for x in walker.live[i]))
        entries = math.prod(size[x] for x in union)
        total += entries
        if limit is not None and total > limit:
            return None
        path.append(rest)
        kept.append(output)
        records.append((entries, union))
    return path, kept, records, total


@FAST
@given(data=st.data(), drawn=factor_scopes())
def test_eliminate_walks_each_label_as_the_python_path_reader(
    data: st.DataObject, drawn: tuple[list[tuple[int, ...]], list[int]]
) -> None:
    scopes, card = drawn
    present = sorted({u for scope in scopes for u in scope})
    chosen = st.lists(st.sampled_from(present), unique=True, max_size=2) if present else st.just([])
    output = tuple(data.draw(chosen))
    labels = data.draw(st.permutations([u for u in present if u not in output]))
    constant = data.draw(
        st.none() | st.lists(st.booleans(), min_size=len(scopes), max_size=len(scopes))
    )
    limit = data.draw(st.none() | st.integers(-1, 300))
    size = {u: (card[u] if u >= 0 else 5) for u in present}
    walked = _orders.eliminate(scopes, labels, output, card, {-1: 5}, constant, limit)
    assert walked == reference_walk(scopes, list(labels), output, size, constant, limit)


def test_eliminate_reads_a_limit_past_any_count_as_no_limit() -> None:
    scopes = [(0, 1), (1, 2)]
    free = _orders.eliminate(scopes, [1], (0, 2), [2, 3, 4], None, None, None)
    assert _orders.eliminate(scopes, [1], (0, 2), [2, 3, 4], None, None, 1 << 80) == free
    assert _orders.eliminate(scopes, [1], (0, 2), [2, 3, 4], None, None, -(1 << 80)) is None


def reference_min_weight(
    scopes: list[tuple[int, ...]], output: tuple[int, ...], card: list[int]
) -> tuple[dict[int, int], int, dict[int, int]]:
    """Greedy min-weight elimination, each weight recounted from scratch: the label whose
    factor (itself and its neighbours) has the fewest entries, ties to the least label."""
    graph: dict[int, set[int]] = {}
    for scope in scopes:
        for u in scope:
            if u >= 0:
                graph.setdefault(u, set()).update(x for x in scope if x >= 0 and x != u)
    rank: dict[int, int] = {}
    weights: dict[int, int] = {}
    bound = 0
    while True:
        left = [u for u in graph if u not in rank and u not in output]
        if not left:
            return rank, bound, weights
        weight, u = min((card[u] * math.prod(card[x] for x in graph[u]), u) for u in left)
        rank[u] = len(rank)
        weights[u] = weight
        bound += weight
        around = graph.pop(u)
        for x in around:
            graph[x] |= around - {x}
            graph[x].discard(u)


@FAST
@given(data=st.data(), drawn=factor_scopes())
def test_min_weight_ranks_as_a_recounting_reference(
    data: st.DataObject, drawn: tuple[list[tuple[int, ...]], list[int]]
) -> None:
    scopes, card = drawn
    present = sorted({u for scope in scopes for u in scope if u >= 0})
    chosen = st.lists(st.sampled_from(present), unique=True, max_size=2) if present else st.just([])
    output = tuple(data.draw(chosen))
    weights: dict[int, int] = {}
    rank, bound = _orders.min_weight(scopes, output, card, weights)
    expected_rank, expected_bound, expected_weights = reference_min_weight(scopes, output, card)
    assert rank == expected_rank and list(rank) == list(expected_rank)
    assert bound == expected_bound
    assert weights == expected_weights


def test_min_weight_saturates_a_weight_past_64_bits() -> None:
    """70 four-state variables in one factor: each elimination weighs 4**70 > 2**64 at first;
    the counts stop at 2**64 − 1 and the order is still every label once."""
    rank, bound = _orders.min_weight([tuple(range(70))], (), [4] * 70, None)
    assert sorted(rank.values()) == list(range(70))
    assert bound == (1 << 64) - 1


@st.composite
def sum_products(draw: st.DrawFn) -> list[object]:
    """A sub-list ``einsum`` call: up to 4 float64 operands over up to 6 labels, some as
    strided or transposed views, and an output of some of their labels."""
    n_labels = draw(st.integers(1, 6))
    sizes = draw(st.lists(st.integers(1, 4), min_size=n_labels, max_size=n_labels))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    args: list[object] = []
    used: set[int] = set()
    for _ in range(draw(st.integers(1, 4))):
        labels = tuple(draw(st.lists(st.integers(0, n_labels - 1), unique=True, max_size=4)))
        shape = tuple(sizes[u] for u in labels)
        array = rng.random(shape)
        how = draw(st.sampled_from(["plain", "strided", "transposed"]))
        if how == "strided":
            every_other = tuple(slice(None, None, 2) for _ in shape)
            array = rng.random(tuple(2 * n for n in shape))[every_other]
        elif how == "transposed" and len(shape) > 1:
            array = np.ascontiguousarray(array.T).T
        args += [array, labels]
        used.update(labels)
    output = draw(st.permutations(sorted(used)).map(tuple))
    args.append(output[: draw(st.integers(0, len(output)))])
    return args


@settings(max_examples=300, deadline=None)
@given(args=sum_products())
@example(args=[np.ones((2, 3)), (0, 1), np.ones(3), (1,), ()])  # a scalar answer
def test_contract_sums_products_as_numpy_einsum(args: list[object]) -> None:
    ours = _orders.contract(*args)
    theirs = np.einsum(*args)
    assert type(ours) is type(theirs)
    assert np.shape(ours) == np.shape(theirs)
    np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=0)


def test_contract_hands_numpy_what_it_does_not_compute() -> None:
    """List sub-lists, and what goes to numpy — other dtypes, sub-lists that are neither
    tuples nor lists, diagonals, broadcast axes, implicit outputs, large products — give
    numpy's answers; a size mismatch numpy's error."""
    a = np.arange(6.0).reshape(2, 3)
    square = np.arange(9.0).reshape(3, 3)
    cases = [
        (a.astype(np.float32), (0, 1), (0,)),
        (a, [0, 1], [0]),
        (a, range(2), (0,)),
        (square, (0, 0), (0,)),
        (np.broadcast_to(np.arange(3.0), (2, 3)), (0, 1), (1,)),
        (a, (0, 1)),
        (np.ones((64, 128)), (0, 1), np.ones((128,)), (1,), (0,)),
    ]
    for args in cases:
        ours, theirs = _orders.contract(*args), np.einsum(*args)
        assert ours.dtype == theirs.dtype
        np.testing.assert_array_equal(ours, theirs)
    with pytest.raises(ValueError):
        _orders.contract(np.ones(2), (0,), np.ones(3), (0,), ())


def test_bad_input_is_a_python_error_not_a_crash() -> None:
    with pytest.raises(TypeError):
        _orders.eliminate([("a",)], [0], (), [2], None, None, None)
    with pytest.raises(IndexError):
        _orders.min_weight([(0, 5)], (), [2, 2], None)
    with pytest.raises(ValueError, match="2\\*\\*24"):
        _orders.eliminate([(0, 1 << 30)], [0], (), [2], None, None, None)
    with pytest.raises(TypeError):
        _orders.step([(None, 0)], (), (), False, None, [], 0, print)
