"""The cold path of exact inference: contraction orders, batch memo, pruned evidence checks."""

from __future__ import annotations

import gc
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.bn.helpers import brute_posterior, random_net, sample_evidence

from bayesmap.bn import BayesNet, elimination, plans
from bayesmap.bn.tuning import Tuning
from bayesmap.errors import InputError

SEEDS = st.integers(0, 2**31 - 1)
FAST = settings(max_examples=40, deadline=None)


def _sliced_factors(
    net: BayesNet, rng: np.random.Generator
) -> tuple[list[tuple[int, ...]], list[np.ndarray], tuple[int, ...]]:
    """Random factors of a network with a random output (CPTs, some axes summed away)."""
    compiled = net._engine.compiled
    scopes: list[tuple[int, ...]] = []
    arrays: list[np.ndarray] = []
    for v in range(len(compiled.names)):
        scope = (v, *compiled.parents[v])
        arrays.append(compiled.cpts[v])
        scopes.append(scope)
    labels = sorted({u for scope in scopes for u in scope})
    k = int(rng.integers(0, min(3, len(labels)) + 1))
    output = tuple(int(u) for u in rng.choice(labels, size=k, replace=False))
    return scopes, arrays, output


@FAST
@given(seed=SEEDS, force_greedy=st.booleans(), force_pairwise=st.booleans())
def test_order_and_program_contract_exactly(
    seed: int, force_greedy: bool, force_pairwise: bool
) -> None:
    """The plan's greedy elimination order (or the opt_einsum fallback), buckets contracted at once
    or pairwise through opt_einsum, gives einsum's exact answer."""
    net = random_net(seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    scopes, arrays, output = _sliced_factors(net, rng)
    compiled = net._engine.compiled
    tuning = Tuning()
    if force_greedy:
        tuning = replace(tuning, greedy_above=-1, greedy_per_factor=-1)
    if force_pairwise:
        tuning = replace(tuning, split_above=-1, blas_above=-1)
    path, cost = plans.order(compiled, scopes, output, tuning=tuning)
    assert cost > 0
    used = sorted(k for step in path for k in step)
    assert used == list(range(len(scopes) + len(path) - 1))  # each operand used once
    n_inputs = int(rng.integers(0, len(scopes) + 1))  # the first few supplied per call
    specs = [a.shape if k < n_inputs else a for k, a in enumerate(arrays)]
    program = elimination.SumProgram(scopes, output, specs, path, tuning=tuning)
    got = program(*arrays[:n_inputs])
    args: list[object] = []
    for array, scope in zip(arrays, scopes, strict=True):
        args += [array, list(scope)]
    np.testing.assert_allclose(got, np.einsum(*args, list(output)), rtol=1e-12, atol=1e-15)


@FAST
@given(seed=SEEDS)
def test_kept_labels_and_constant_memo_contract_exactly(seed: int) -> None:
    """Programs given the order's kept labels (per-call and constant operands mixed), with
    evidence-independent results memoised across programs, give einsum's exact answer."""
    net = random_net(seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    scopes, arrays, output = _sliced_factors(net, rng)
    compiled = net._engine.compiled
    constant = [bool(c) for c in rng.integers(0, 2, size=len(scopes))]
    path, kept, _ = plans.order_steps(compiled, scopes, output)
    used = sorted(k for step in path for k in step)
    assert used == list(range(len(scopes) + len(path) - 1))  # each operand used once
    if kept is not None:
        assert [set(k) for k in kept[:-1]] == [
            set(step.kept) for step in elimination.walk(scopes, output, path)[:-1]
        ]
    specs = [a if c else a.shape for a, c in zip(arrays, constant, strict=True)]
    inputs = [a for a, c in zip(arrays, constant, strict=True) if not c]
    memo = elimination.ConstantMemo()
    args: list[object] = []
    for array, scope in zip(arrays, scopes, strict=True):
        args += [array, list(scope)]
    expected = np.einsum(*args, list(output))
    for _ in range(2):  # the second program reuses the first one's constant steps
        program = elimination.SumProgram(scopes, output, specs, path, kept, memo=memo)
        got = program(*inputs)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)


def _two_parts() -> BayesNet:
    """A → B, B a copy of A, P(A=1) = 0; and an unrelated C → D."""
    net = BayesNet("two-parts")
    net.add_variable("A", ["0", "1"], cpt=[1.0, 0.0])
    net.add_variable("B", ["0", "1"], parents=["A"], cpt=[[1.0, 0.0], [0.0, 1.0]])
    net.add_variable("C", ["0", "1"], cpt=[0.3, 0.7])
    net.add_variable("D", ["0", "1"], parents=["C"], cpt=[[0.9, 0.2], [0.1, 0.8]])
    return net


@given(seed=SEEDS)
@FAST
def test_the_engines_einsum_agrees_with_numpys(seed: int) -> None:
    """``elimination.einsum`` (small products summed in the compiled core, the rest by numpy's
    C function without dispatch) answers as ``np.einsum``, to rounding, for sub-list
    contractions of random tables, summing any labels."""
    rng = np.random.default_rng(seed)
    sizes = rng.integers(1, 5, size=4)
    args: list[object] = []
    used: set[int] = set()
    for _ in range(int(rng.integers(1, 4))):
        labels = sorted(rng.choice(4, size=int(rng.integers(1, 4)), replace=False).tolist())
        args += [rng.random(tuple(sizes[labels])), labels]
        used.update(labels)
    args.append(sorted(used)[: int(rng.integers(0, len(used) + 1))])
    np.testing.assert_allclose(elimination.einsum(*args), np.einsum(*args), rtol=1e-13, atol=0)


def test_impossible_evidence_in_a_pruned_part_is_reported() -> None:
    net = _two_parts()
    with pytest.raises(InputError, match="probability zero"):
        net.posterior("D", {"B": "1"})
    with pytest.raises(InputError, match="probability zero"):
        net.joint_posterior(["C", "D"], {"B": "1"})
    with pytest.raises(InputError, match="case 2: .*probability zero"):
        net.posterior_batch("D", np.array([[0], [0], [1], [1]]), columns=["B"])
    # possible evidence there changes nothing
    assert net.posterior("D", {"B": "0"}) == pytest.approx(net.posterior("D"))


def test_a_zero_combination_in_a_pruned_part_is_a_documented_limit() -> None:
    """Each observed state is possible, their combination is not: only P(e) sees it."""
    net = _two_parts()
    net.set_cpt("A", [0.5, 0.5])
    net.add_variable("B2", ["0", "1"], parents=["A"], cpt=[[1.0, 0.0], [0.0, 1.0]])
    evidence = {"B": "0", "B2": "1"}  # both copies of A, which is unobserved
    with pytest.raises(InputError):
        net.probability_of_evidence(evidence)
    assert net.posterior("D", evidence) == pytest.approx(net.posterior("D"))


def test_pruned_evidence_below_a_data_node_is_not_checked_but_still_answers() -> None:
    net = _two_parts()
    net.set_source("B", lambda evidence: [[1.0, 0.0], [0.0, 1.0]])
    assert net.posterior("D", {"B": "0"}) == pytest.approx(net.posterior("D"))


@FAST
@given(seed=SEEDS, force_joint=st.booleans(), sizes=st.lists(st.integers(1, 90), max_size=3))
def test_batches_of_any_size_equal_looped_queries(
    seed: int, force_joint: bool, sizes: list[int]
) -> None:
    """Deduplicated, memoised and joint-filled batch answers equal one query per case."""
    net = random_net(seed, n_vars=7, zero_fraction=0.2)
    rng = np.random.default_rng(seed)
    names = list(net.variables)
    target, *columns = (str(v) for v in rng.choice(names, size=3, replace=False))
    if force_joint:
        net.tuning = Tuning(joint_above=-1)
    for n in [*sizes, 5]:
        cases = [sample_evidence(net, rng, len(net)) for _ in range(n)]
        table = np.array([[net.states(c).index(case[c]) for c in columns] for case in cases])
        got = net.posterior_batch(target, table, columns=columns)
        for row, case in zip(got, cases, strict=True):
            evidence = {c: case[c] for c in columns}
            want = brute_posterior(net, [target], evidence)
            np.testing.assert_allclose(row, want, atol=1e-12)


@pytest.mark.parametrize("force_joint", [False, True])
def test_batch_memo_reports_impossible_cases_and_follows_network_changes(
    force_joint: bool,
) -> None:
    net = BayesNet("memo", tuning=Tuning(joint_above=-1) if force_joint else Tuning())
    net.add_variable("R", ["no", "yes"], cpt=[0.8, 0.2])
    net.add_variable("S", ["off", "on"], parents=["R"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    wet = np.array([[[1.0, 0.1], [0.2, 0.01]], [[0.0, 0.9], [0.8, 0.99]]])
    net.add_variable("W", ["no", "yes"], parents=["R", "S"], cpt=wet)
    net.add_variable("L", ["no", "yes"], parents=["W"], cpt=[[0.9, 0.3], [0.1, 0.7]])
    columns = ["R", "S", "W"]
    good = np.array([[0, 1, 1], [1, 0, 0], [0, 1, 1]] * 4)
    first = net.posterior_batch("L", good, columns=columns)
    np.testing.assert_allclose(net.posterior_batch("L", good, columns=columns), first)
    bad = good.copy()
    bad[7] = [0, 0, 1]  # no rain, sprinkler off, yet wet: probability zero
    with pytest.raises(InputError, match="case 7: .*probability zero"):
        net.posterior_batch("L", bad, columns=columns)
    net.set_cpt("L", [[0.5, 0.5], [0.5, 0.5]])
    np.testing.assert_allclose(net.posterior_batch("L", good, columns=columns), 0.5)


def test_elimination_rank_sums_every_other_label_once_leaves_before_the_hub() -> None:
    """A star: the hub (label 0) links every leaf; min-weight sums the leaves out first."""
    scopes = [(0, leaf) for leaf in range(1, 6)] + [(0,)]
    card = [4, 2, 2, 2, 2, 2]
    rank, _ = plans.elimination_rank(scopes, (5,), card)
    assert sorted(rank) == [0, 1, 2, 3, 4]  # every label but the output, once
    assert sorted(rank.values()) == list(range(5))
    assert rank[0] == 4  # the hub, whose factor is the largest, goes last


def test_elimination_rank_leaves_the_case_axis_out_of_the_graph() -> None:
    rank, _ = plans.elimination_rank([(-1, 0), (0, 1), (1, 2)], (-1, 2), [3, 2, 2])
    assert sorted(rank) == [0, 1]  # the variables, not the case axis
    assert rank[1] > rank[0]  # 0 (with 1 only) before 1 (between 0 and 2)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.lists(st.integers(0, 11), min_size=1, max_size=4, unique=True),
        min_size=1,
        max_size=14,
    ),
    st.lists(st.integers(2, 4), min_size=12, max_size=12),
    st.sets(st.integers(0, 11), max_size=2),
)
def test_elimination_rank_always_sums_out_a_label_of_least_weight(scopes, card, output):
    """Replayed from scratch, each label the order sums out has, among those left, the
    fewest entries in its factor (itself and its current neighbours): the weights the order
    updates as labels go are the weights recounted."""
    rank, bound = plans.elimination_rank(scopes, tuple(output), card)
    labels = {u for scope in scopes for u in scope}
    assert set(rank) == labels - output
    summed = 0
    neighbours = {u: set() for u in labels}
    for scope in scopes:
        for u in scope:
            neighbours[u].update(w for w in scope if w != u)

    def weight(u: int) -> int:
        return card[u] * int(np.prod([card[w] for w in neighbours[u]]))

    for u in sorted(rank, key=rank.__getitem__):
        left = [v for v in neighbours if v not in output]
        assert weight(u) == min(weight(v) for v in left)
        summed += weight(u)
        around = neighbours.pop(u)
        for x in around:
            neighbours[x] |= around - {x}
            neighbours[x].discard(u)
    assert bound == summed


@FAST
@given(seed=SEEDS, force_greedy=st.booleans(), force_pairwise=st.booleans())
def test_order_and_program_built_in_one_pass_equal_the_two_passes(
    seed: int, force_greedy: bool, force_pairwise: bool
) -> None:
    """A program given its steps as the order is chosen (``emit``) has the same order, the
    same einsum steps and the same answer, bit for bit, as one compiled from the finished
    order; where the opt_einsum search may replace the order, the steps come after it."""
    net = random_net(seed, n_vars=8, max_card=3)
    rng = np.random.default_rng(seed)
    scopes, arrays, output = _sliced_factors(net, rng)
    compiled = net._engine.compiled
    tuning = Tuning()
    if force_greedy:
        tuning = replace(tuning, greedy_above=-1, greedy_per_factor=-1)
    if force_pairwise:
        tuning = replace(tuning, split_above=-1, blas_above=-1)
    constant = [bool(c) for c in rng.integers(0, 2, size=len(scopes))]
    specs = [a if c else a.shape for a, c in zip(arrays, constant, strict=True)]
    inputs = [a for a, c in zip(arrays, constant, strict=True) if not c]
    path, kept, cost = plans.order_steps(compiled, scopes, output, tuning=tuning)
    _, bound = plans.elimination_rank(scopes, output, compiled.card)
    if kept is not None:  # the min-weight order: its cost within the bound of its weights
        assert cost <= bound + int(np.prod([compiled.card[v] for v in output]))
    two = elimination.SumProgram(scopes, output, specs, path, kept, tuning=tuning)
    one = elimination.SumProgram(scopes, output, specs, None, tuning=tuning)
    assert plans.order_steps(compiled, scopes, output, emit=one.extend, tuning=tuning) == (
        path,
        kept,
        cost,
    )
    one.finish()
    assert repr(one.steps) == repr(two.steps)
    assert np.array_equal(one(*inputs), two(*inputs))
    args: list[object] = []
    for array, scope in zip(arrays, scopes, strict=True):
        args += [array, list(scope)]
    np.testing.assert_allclose(one(*inputs), np.einsum(*args, list(output)), rtol=1e-12)


def _diamond() -> BayesNet:
    """A → B, A → C, (B, C) → D (D's parents share A); E → F (F's one parent)."""
    net = BayesNet("diamond")
    net.add_variable("A", ["0", "1"], cpt=[0.3, 0.7])
    net.add_variable("B", ["0", "1"], parents=["A"], cpt=[[0.9, 0.2], [0.1, 0.8]])
    net.add_variable("C", ["0", "1"], parents=["A"], cpt=[[0.6, 0.3], [0.4, 0.7]])
    d = [[[0.9, 0.5], [0.4, 0.2]], [[0.1, 0.5], [0.6, 0.8]]]
    net.add_variable("D", ["0", "1"], parents=["B", "C"], cpt=d)
    net.add_variable("E", ["0", "1"], cpt=[0.5, 0.5])
    net.add_variable(
        "G",
        ["0", "1"],
        parents=["E", "A"],
        cpt=[[[0.9, 0.5], [0.4, 0.2]], [[0.1, 0.5], [0.6, 0.8]]],
    )
    return net


def test_independent_parents_means_no_shared_ancestor() -> None:
    compiled = _diamond()._engine.compiled
    independent = {name: compiled.independent_parents(compiled.id(name)) for name in "ABCDEG"}
    assert independent == {"A": True, "B": True, "C": True, "D": False, "E": True, "G": True}


@FAST
@given(seed=SEEDS)
def test_every_prior_equals_brute_force(seed: int) -> None:
    """Priors, by one einsum over independent parents' priors or by a plan, are exact."""
    net = random_net(seed, n_vars=7, max_card=3)
    engine = net._engine
    for name in reversed(net.topological_order()):  # children first: priors computed lazily
        got = engine.prior(engine.compiled.id(name))
        np.testing.assert_allclose(got, brute_posterior(net, [name], {}), rtol=1e-10, atol=1e-13)


def test_a_first_question_computes_only_the_priors_it_uses() -> None:
    net = _two_parts()
    net.posterior("B", {"A": "0", "D": "1"})  # D's part is d-separated: only its prior check
    computed = {net._engine.compiled.names[v] for v in net._engine.priors}
    assert computed <= {"C", "D"}
    assert "A" not in computed and "B" not in computed


def test_a_target_no_evidence_reaches_is_answered_by_its_prior() -> None:
    """P(B | D) = P(B) when B and D share no ancestor: the plan is B's prior alone, and the
    evidence is still checked (dropped: by its prior; every variable observed: as a check)."""
    net = _two_parts()
    engine = net._engine
    b, d = engine.compiled.id("B"), engine.compiled.id("D")
    np.testing.assert_allclose(
        list(net.posterior("B", {"D": "1"}).values()), brute_posterior(net, ["B"], {})
    )
    plan = engine.plan(plans.QueryKind.MARGINAL, (b,), frozenset({d}))
    assert [f.var for f in plan.factors] == [b] and plan.factors[0].array is engine.priors[b]
    assert plan.dropped == (d,) and not plan.checks
    with pytest.raises(InputError, match="probability zero"):
        net.posterior("D", {"A": "1", "B": "1"})  # P(A=1) = 0: a check, no contraction
    net.add_variable("E", ["0", "1"], parents=["B"], cpt=[[0.5, 0.5], [0.5, 0.5]])
    np.testing.assert_allclose(
        list(net.posterior("E", {"D": "1"}).values()), brute_posterior(net, ["E"], {"D": "1"})
    )  # a network changed after the question: its new variable answers from its own prior


@FAST
@given(seed=SEEDS)
def test_a_prior_plan_equals_brute_force_and_the_pruned_plan(seed: int) -> None:
    """Every single-target question answers as by enumeration, whether its plan is the
    target's prior (no shared ancestor with the evidence) or a pruned contraction."""
    net = random_net(seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    names = list(net.variables)
    for _ in range(4):
        evidence = sample_evidence(net, rng, int(rng.integers(1, 3)))
        target = str(rng.choice([n for n in names if n not in evidence]))
        np.testing.assert_allclose(
            list(net.posterior(target, evidence).values()),
            brute_posterior(net, [target], evidence),
            rtol=1e-9,
            atol=1e-12,
        )


def test_a_long_chain_computes_its_priors_without_recursion() -> None:
    """P(X_n = 0) = 1/2 + (a − 1/2)(1 − 2f)^n on a chain whose links flip with probability f."""
    n, a, f = 3000, 0.9, 0.001
    net = BayesNet("chain")
    net.add_variable("X0", ["0", "1"], cpt=[a, 1 - a])
    for k in range(1, n + 1):
        net.add_variable(f"X{k}", ["0", "1"], parents=[f"X{k - 1}"], cpt=[[1 - f, f], [f, 1 - f]])
    expected = 0.5 + (a - 0.5) * (1 - 2 * f) ** n
    assert net.posterior(f"X{n}")["0"] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("constant", [True, False])
def test_one_pass_program_puts_the_last_steps_labels_in_the_outputs_order(constant: bool) -> None:
    """The last elimination step keeps the output's labels in the order the operands hold
    them ((0, 2) here); the program built in one pass answers in the output's order (2, 0),
    transposing a constant result or writing a per-call step's output subscripts so."""
    net = random_net(3, n_vars=3, max_card=3)
    compiled = net._engine.compiled
    rng = np.random.default_rng(3)
    scopes = [(0, 1), (1, 2)]
    card = compiled.card
    arrays = [rng.random((card[0], card[1])), rng.random((card[1], card[2]))]
    specs = [a if constant else a.shape for a in arrays]
    program = elimination.SumProgram(scopes, (2, 0), specs, None)
    path, kept, _ = plans.order_steps(compiled, scopes, (2, 0), emit=program.extend)
    program.finish()
    assert path == [(0, 1)] and kept == [(0, 2)]
    got = program() if constant else program(*arrays)
    np.testing.assert_array_equal(got, np.einsum("ab,bc->ca", *arrays))


@FAST
@given(seed=SEEDS, always=st.booleans())
def test_the_network_order_restricted_to_a_plan_contracts_exactly(seed: int, always: bool) -> None:
    """The network-wide order restricted to a plan (kept whatever it costs, or only where
    its arithmetic is negligible) gives einsum's answer, and its evidence-free steps come
    before every step that joins evidence."""
    net = random_net(seed, n_vars=9, max_card=3)
    rng = np.random.default_rng(seed)
    scopes, arrays, output = _sliced_factors(net, rng)
    compiled = net._engine.compiled
    tuning = replace(Tuning(), network_order_per_factor=1 << 62) if always else Tuning()
    constant = [bool(c) for c in rng.integers(0, 2, size=len(scopes))]
    program = elimination.SumProgram(
        scopes, output, [a if c else a.shape for a, c in zip(arrays, constant, strict=True)], None
    )
    path, kept, _ = plans.order_steps(
        compiled, scopes, output, emit=program.extend, network=constant, tuning=tuning
    )
    program.finish()
    args: list[object] = []
    for array, scope in zip(arrays, scopes, strict=True):
        args += [array, list(scope)]
    inputs = [a for a, c in zip(arrays, constant, strict=True) if not c]
    np.testing.assert_allclose(program(*inputs), np.einsum(*args, list(output)), rtol=1e-12)
    if always and kept is not None:
        joined = constant.copy()
        for step in path:
            joined.append(all(joined[k] for k in step))
        steps = joined[len(scopes) : -1]  # the last step multiplies what is left
        assert steps == sorted(steps, reverse=True)  # evidence-free steps first


def test_a_cached_program_leaves_nothing_for_the_cyclic_collector_to_rescan() -> None:
    """A cold question's compiled program keeps only its steps, made of tuples of arrays,
    ints and ``None`` that the collector stops tracking; its building state is gone (each
    tracked container a plan keeps makes every later full collection longer)."""
    net = BayesNet("chain", tuning=replace(Tuning(), one_step=0))  # ordered, never one call
    net.add_variable("X0", ["0", "1"], cpt=[0.3, 0.7])
    for k in range(1, 6):
        net.add_variable(f"X{k}", ["0", "1"], parents=[f"X{k - 1}"], cpt=[[0.9, 0.2], [0.1, 0.8]])
    net.posterior("X0", {"X5": "1", "X3": "0"})
    compiled = net._engine.compiled
    plan = net._engine.plan(
        plans.QueryKind.MARGINAL, (0,), frozenset(map(compiled.id, ["X3", "X5"]))
    )
    assert plan.cache.single is not None
    program, _ = plan.cache.single
    assert isinstance(program, elimination.SumProgram) and program.steps
    for _ in range(3):  # a tuple is untracked once what it holds is: a pass per nesting level
        gc.collect()
    assert not any(gc.is_tracked(step) for step in program.steps)
    with pytest.raises(AttributeError):
        program.add((0, 1), ())  # its operands were released by finish()


def test_a_costly_network_order_gives_way_to_the_plans_own() -> None:
    """Where the restricted order's arithmetic would pass the bound, or its network-wide
    weights say it would, the plan's own min-weight order is used; within it, the
    restricted order (no ranking)."""
    net = random_net(3, n_vars=12, max_card=4)
    compiled = net._engine.compiled
    scopes = [(v, *compiled.parents[v]) for v in range(len(compiled.names))]
    flags = [True] * len(scopes)
    own = plans.order_steps(compiled, scopes, (0,))
    never = replace(Tuning(), network_order_per_factor=-1)
    assert plans.order_steps(compiled, scopes, (0,), network=flags, tuning=never) == own
    ready = replace(Tuning(), network_order_per_factor=1 << 62)
    dense = replace(ready, network_order_slack=0)  # the network-wide weights exceed any limit
    assert plans.order_steps(compiled, scopes, (0,), network=flags, tuning=dense) == own
    restricted = plans.order_steps(compiled, scopes, (0,), network=flags, tuning=ready)
    positions, _ = plans.network_order(compiled)
    labels = sorted({u for scope in scopes for u in scope} - {0}, key=positions.__getitem__)
    walker = elimination.Walker(scopes, (0,))
    steps = [walker.step(tuple(walker.holders[u])) for u in labels if walker.holders[u]]
    if len(walker.open) > 1 or not steps:  # the last step joins what is left into (0,)
        steps.append(walker.step(tuple(walker.open)))
    cost = sum(math.prod(compiled.card[u] for u in step.union) for step in steps)
    assert restricted == ([step.inputs for step in steps], [step.kept for step in steps], cost)


@FAST
@given(seed=SEEDS, k=st.integers(0, 4))
def test_a_plans_factors_carry_the_shape_and_spec_of_their_slice(seed: int, k: int) -> None:
    """Each factor's ``shape`` is its sliced table's and its ``spec`` (what a compiled
    contraction is given) that shape where it depends on the evidence, else the array."""
    net = random_net(seed, n_vars=7, max_card=3)
    rng = np.random.default_rng(seed)
    evidence = sample_evidence(net, rng, k)
    target = next(v for v in net.variables if v not in evidence)
    net.posterior(target, evidence)
    engine = net._engine
    compiled = engine.compiled
    ev = engine.evidence_ids(evidence)
    plan = engine.plan(plans.QueryKind.MARGINAL, (compiled.id(target),), frozenset(ev))
    ev_idx = [ev[v] for v in plan.evidence]
    for factor in (*plan.factors, *plan.checks):
        assert factor.shape == tuple(compiled.card[v] for v in factor.free)
        assert factor.array is not None
        sliced = factor.array[factor.pick(ev_idx)] if factor.pick is not None else factor.array
        assert sliced.shape == factor.shape
        assert factor.spec is (factor.shape if factor.observed else factor.array)
