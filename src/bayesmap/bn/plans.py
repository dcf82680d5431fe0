"""Query plans: the pruned factor list of a question, built once per evidence pattern.

A plan depends on the network version, the queried variables and *which* variables are
observed — never on the observed values — so it is cached and reused every sensor cycle.
Building one:

0. **Unreachable evidence**: a single target that shares no ancestor with any evidence
   variable (and has no data node among its ancestors) has its prior as its answer; its
   plan is that one factor, with the evidence's checks, and no pruning, order or
   contraction is needed.
1. **Barren nodes** (Post et al. 2016 §3.2: only ancestors matter): keep the targets, the
   evidence and their ancestors; every other CPT sums to 1 and drops out.
2. **Evidence-free sub-networks**: an ancestral sub-network with no target, evidence or
   data node that meets the rest only through one variable ``Y`` is replaced by the prior
   ``P(Y)`` (:func:`replaced_roots`).
3. **d-separation**: factors link the remaining free variables; connected components
   that hold no target are independent of the targets given the evidence and are dropped
   (their factors only scale the answer). Factors whose every variable is observed become
   scalar checks (a zero means impossible evidence).
4. **Evidence slicing**: each CPT is transposed so its observed axes come first, so that
   ``table[e1, e2]`` (one case) or ``table[cols1, cols2]`` (a batch, giving a leading case
   axis) selects the evidence rows without copying the rest.
5. **Contraction order** (:func:`order_steps`): for a one-case question, the network-wide
   min-weight elimination order (:func:`network_order`, computed once per network)
   restricted to the plan's variables, evidence-free sub-trees first — no search per
   pattern; where that order's arithmetic is not negligible, and for batches, a greedy
   min-weight order of the plan's own (pruned, sliced) factors (:func:`elimination_rank`),
   the cheaper kept; when an order would build a large intermediate, opt_einsum's greedy
   search on the plan is asked too and the cheapest is used.
   :class:`~bayesmap.bn.elimination.SumProgram` replays it with every evidence-independent
   sub-tree pre-contracted once.

Variable sets are bit masks (bit ``i`` = variable id ``i``), precomputed per network
version; steps 0–3 run in compiled code over them as rows of 64-bit words
(``csrc/prune.c``), and so do the order walks of step 5 — a few word operations per relevant
variable and step, where a new pattern in Python paid thousands of interpreter steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from itertools import chain
from operator import itemgetter
from typing import TYPE_CHECKING, Any

from bayesmap._lazy import lazy_module
from bayesmap._typing import FloatArray
from bayesmap.bn import _orders
from bayesmap.bn.compiled import Compiled
from bayesmap.bn.elimination import Walker, walk
from bayesmap.bn.tuning import TUNING, Tuning

opt_einsum = lazy_module("opt_einsum")  # loads on first use: keeps ``import bayesmap.bn`` lean

if TYPE_CHECKING:
    from bayesmap.bn.elimination import Path, SumProgram
    from bayesmap.bn.marginals import TwoPass

BATCH = "a"  # opt_einsum.get_symbol(0), spelt out so that importing does not load opt_einsum
"""The einsum index of the case axis of batched queries."""


def symbol(var: int) -> str:
    """Einsum index of variable id ``var`` (index 0 is the case axis)."""
    return str(opt_einsum.get_symbol(var + 1))


@dataclass(slots=True)
class Factor:
    """One CPT of a plan, transposed so that its observed axes come first.

    Attributes
    ----------
    var
        Id of the variable whose CPT this is.
    array
        The transposed CPT (for a data node: ``None``, asked at query time).
    perm
        Axis permutation from ``(child, *parents)`` to ``(observed..., free...)``.
    ev_pos
        Position in the plan's evidence tuple of each observed axis.
    free
        Ids of the free variables, in axis order after the observed ones.
    shape
        Number of states of each free variable: the shape of the sliced factor.
    """

    var: int
    array: FloatArray | None
    perm: tuple[int, ...]
    ev_pos: tuple[int, ...]
    free: tuple[int, ...]
    shape: tuple[int, ...]
    pick: Any = None
    observed: bool = False
    """Whether the factor depends on evidence values (observed axes or a data node)."""
    spec: Any = None
    """What a compiled contraction is given for it: its shape if it depends on the evidence
    (an operand supplied per call), else its array (a constant)."""

    def __post_init__(self) -> None:
        if self.ev_pos:
            self.pick = itemgetter(*self.ev_pos)
        self.observed = bool(self.ev_pos) or self.array is None
        self.spec = self.shape if self.observed else self.array

    @property
    def term(self) -> str:
        """Einsum indices of the sliced factor (one case)."""
        return "".join(symbol(v) for v in self.free)


class QueryKind(Enum):
    """Which factors a question's plan keeps (:func:`build`)."""

    MARGINAL = "marginal"
    """Sum over the non-targets: barren variables and target-free components dropped,
    evidence-free ancestral sub-networks replaced by priors (posteriors, marginal MAP,
    propositions)."""
    EVIDENCE = "evidence"
    """No targets, every component kept: the probability of the evidence (eq. 24's Σ)."""
    WHOLE = "whole"
    """Nothing pruned: MAP over all variables (eq. 13) and every posterior at once."""

    # members are singletons compared by identity: hash them by identity too (a C call;
    # Enum's own hash is Python code, paid on every plan lookup of a warm question)
    __hash__ = object.__hash__


Layout = tuple[
    FloatArray | None,
    tuple[int, ...],
    tuple[int, ...],
    tuple[int, ...],
    dict[tuple[int, ...], Factor],
]
"""A CPT laid out for a set of observed family members (:func:`_layout`): array, permutation,
observed ids, free ids, and the factors made of it, by evidence positions (factors are
never changed once made, so plans share them)."""


BatchOrder = tuple[
    list[tuple[int, ...]], tuple[int, ...], list[Any], list[tuple[int, ...]], Any, int
]
"""A batch contraction: scopes, output, operand specs, SSA path, kept labels and cost."""


@dataclass
class PlanCache:
    """What a plan's questions compute once and reuse (all empty until first asked).

    Attributes
    ----------
    ancestral
        For :attr:`QueryKind.MARGINAL` plans: the order of the paper's recursion (eq. 27)
        where it is exact for this question, else ``None``.
    checkable
        The plan's dropped observed variables that have a cached prior to check.
    single
        The one-case sum-product program and its per-call factors (or a constant result).
    single_order
        The one-case contraction order: path, kept labels, multiply-adds.
    batch
        Batch sum-product programs, by size class of the number of cases.
    batch_order
        Batch contraction orders, by size class.
    two_pass_pays
        Whether one two-pass contraction beats one question per variable.
    two_pass_order
        Two-pass scopes, path and cost, by ``(output labels, cases)``.
    two_pass
        Compiled two-pass programs and their wanted ``(factor, variable)`` pairs, by
        ``(output labels, cases)``.
    indicators
        Indicator-batch two-pass programs, by ``(observed, targets, size class)``.
    scalar_path
        Order of contracting every factor to a scalar (MAP's max-product, fixed-point P(e)).
    groups
        Marginal MAP's sum groups: factor indices and the query labels each group keeps.
    group_paths
        Fixed-point sum order of each marginal-MAP group, by group number.
    fixed_path
        Order of the one-case fixed-point sum-product (the generated C code replays it).
    fixed_batch_path
        Order of the batched fixed-point sum-product.
    """

    ancestral: list[int] | None = None
    checkable: tuple[int, ...] | None = None
    single: tuple[Any, list[Factor]] | None = None
    single_order: tuple[list[tuple[int, ...]], list[tuple[int, ...]] | None, int] | None = None
    batch: dict[int, SumProgram] = field(default_factory=dict)
    batch_order: dict[int, BatchOrder] = field(default_factory=dict)
    two_pass_pays: bool | None = None
    two_pass_order: dict[
        tuple[tuple[int, ...], int], tuple[list[tuple[int, ...]], list[tuple[int, ...]], int]
    ] = field(default_factory=dict)
    two_pass: dict[tuple[tuple[int, ...], int], tuple[TwoPass, list[tuple[int, int]]]] = field(
        default_factory=dict
    )
    indicators: dict[tuple[tuple[int, ...], tuple[int, ...], int], TwoPass] = field(
        default_factory=dict
    )
    scalar_path: Path | None = None
    groups: list[tuple[list[int], str | None]] | None = None
    group_paths: dict[int, Path] = field(default_factory=dict)
    fixed_path: Path | None = None
    fixed_batch_path: Path | None = None


@dataclass
class Plan:
    """Pruned, sliced factors of one question for one pattern of observed variables.

    Attributes
    ----------
    targets
        Ids of the free queried variables, in output order.
    evidence
        Ids of the observed variables, in the order evidence index lists use.
    factors
        Factors with at least one free variable (in the kept components).
    checks
        Factors whose every variable is observed: scalar probabilities of the evidence.
    dropped
        Observed variables whose own CPT was left out (it lies in a component without a
        target, d-separated from the targets): the contraction does not see whether their
        values are possible; :meth:`~bayesmap.bn.inference.Engine.check_dropped` checks their
        prior marginals instead.
    """

    targets: tuple[int, ...]
    evidence: tuple[int, ...]
    factors: list[Factor]
    checks: tuple[Factor, ...]
    dropped: tuple[int, ...] = ()
    cache: PlanCache = field(default_factory=PlanCache)

    @property
    def output(self) -> str:
        """Einsum indices of the (one-case) result."""
        return "".join(symbol(v) for v in self.targets)


_KINDS = {QueryKind.MARGINAL: 0, QueryKind.EVIDENCE: 1, QueryKind.WHOLE: 2}
"""How the compiled pruning (``_orders.prune``) numbers the kinds of question."""


def build(
    compiled: Compiled,
    kind: QueryKind,
    targets: Sequence[int],
    evidence: Sequence[int],
    *,
    prior: Callable[[int], FloatArray] | None = None,
) -> Plan:
    """Build the plan of a question about ``targets`` given evidence on ``evidence``.

    Parameters
    ----------
    compiled
        The network.
    kind
        Which factors the question needs: :attr:`QueryKind.MARGINAL` drops the variables
        that are neither targets, evidence nor their ancestors and the components without
        a target; :attr:`QueryKind.EVIDENCE` and :attr:`QueryKind.WHOLE` keep every
        component (the probability of the evidence), and ``WHOLE`` every variable (MAP
        over all variables).
    targets
        Free variables the answer is over (none: probability of the evidence).
    evidence
        Observed variables (ids), disjoint from ``targets``.
    prior
        Gives the (cached) prior marginal of a variable; with it, every evidence-free
        ancestral sub-network that meets the rest only through one variable ``Y`` is
        replaced by ``P(Y)`` (see :func:`replaced_roots`), and a :attr:`QueryKind.MARGINAL`
        question about one target the evidence cannot reach is its prior: when no evidence
        variable shares an ancestor (or itself) with the target and no data node is among
        the target and its ancestors, the pruned plan would have no factor that depends on
        the evidence — the target's component is the target and its ancestors, whose CPTs
        multiply to ``P(target)`` — and, conversely, a shared ancestor links the target to
        some evidence through a factor that holds an observed variable. That plan is the
        prior alone, with the evidence's own CPTs as checks (every variable observed) or
        dropped (in a component without the target).

    Which CPTs stay (steps 0–3 of the module's list) is decided by compiled code over the
    network's bit rows (:attr:`Compiled.mask_table`, ``_orders.prune``): a few word
    operations per relevant variable.
    """
    ev = tuple(evidence)
    kept, replaced, dropped = _orders.prune(
        compiled.mask_table, targets, ev, _KINDS[kind], prior is not None
    )
    return _plan(compiled, targets, ev, kept, replaced, dropped, prior)


def replaced_roots(compiled: Compiled, var: int) -> list[int]:
    """The variables ``Y`` whose priors stand for evidence-free ancestral sub-networks in
    the plan of ``P(var)`` (no evidence): those with at least one ancestor, none of them
    ``var`` or a data node, whose ancestors have no child in the plan outside ``Y`` and its
    ancestors (the sub-network meets the rest only through ``Y``), so that
    ``Σ_{An(Y)} Π P(· | ·) = P(Y)``; only maximal ones (two such sub-networks are nested or
    disjoint), the lowest in topological order first."""
    marginal = _KINDS[QueryKind.MARGINAL]
    _, replaced, _ = _orders.prune(compiled.mask_table, (var,), (), marginal, True)
    return list(replaced)


def _plan(
    compiled: Compiled,
    targets: Sequence[int],
    ev: tuple[int, ...],
    kept: Sequence[int],
    replaced: tuple[int, ...],
    dropped: tuple[int, ...],
    prior: Callable[[int], FloatArray] | None,
) -> Plan:
    """The plan made of the CPTs of ``kept`` (in topological order), laid out for the
    evidence ``ev`` — each of ``replaced`` by its prior, each whose every variable is
    observed as a check — with the observed variables ``dropped`` in components without a
    target. Factors are made once per network version and shared by every plan."""
    position = dict(zip(ev, range(len(ev)), strict=True)).__getitem__  # place of each in ev
    ev_mask = 0
    for v in ev:
        ev_mask |= 1 << v
    parents = compiled.parents
    family_masks = compiled.family_masks
    shared = compiled.factors  # evidence-free factors, the same in every plan
    layouts = compiled.layouts  # observed-first layouts of CPTs, by observed family members
    factors: list[Factor] = []
    checks: list[Factor] = []
    for v in kept:
        if replaced and v in replaced:
            assert prior is not None
            factor = shared.get(-1 - v)
            if factor is None:
                table = prior(v)
                factor = Factor(v, table, perm=(0,), ev_pos=(), free=(v,), shape=table.shape)
                shared[-1 - v] = factor
            factors.append(factor)
            continue
        seen_mask = ev_mask & family_masks[v]
        if not seen_mask:
            factor = shared.get(v)
            if factor is None:
                variables = (v, *parents[v])
                array = None if v in compiled.sources else compiled.cpts[v]
                perm = tuple(range(len(variables)))
                shape = tuple(map(compiled.card.__getitem__, variables))
                factor = Factor(v, array, perm, ev_pos=(), free=variables, shape=shape)
                shared[v] = factor
            factors.append(factor)
            continue
        key = (v, seen_mask)
        layout = layouts.get(key)
        if layout is None:
            layout = layouts[key] = _layout(compiled, v, ev_mask)
        array, perm, seen, free, made = layout
        ev_pos = tuple(map(position, seen))
        factor = made.get(ev_pos)
        if factor is None:
            shape = tuple(map(compiled.card.__getitem__, free))
            factor = made[ev_pos] = Factor(v, array, perm, ev_pos, free, shape)
        (factors if free else checks).append(factor)
    return Plan(
        targets=tuple(targets),
        evidence=ev,
        factors=factors,
        checks=tuple(checks),
        dropped=dropped,
    )


def _layout(compiled: Compiled, v: int, ev_mask: int) -> Layout:
    """The CPT of ``v`` with its observed axes first: array, permutation, observed, free ids
    (and, empty, its factors by the positions of the observed values in a plan's evidence)."""
    variables = (v, *compiled.parents[v])
    observed_axes = [k for k, u in enumerate(variables) if (ev_mask >> u) & 1]
    free_axes = [k for k, u in enumerate(variables) if not (ev_mask >> u) & 1]
    perm = (*observed_axes, *free_axes)
    array = None if v in compiled.sources else compiled.transposed(v, perm)
    seen = tuple(variables[k] for k in observed_axes)
    return array, perm, seen, tuple(variables[k] for k in free_axes), {}


Records = Sequence[tuple[int, tuple[int, ...]]]
"""Each step of an order: the entries of its operands' product and their labels, in order
of first appearance."""

Steps = tuple[list[tuple[int, ...]], list[tuple[int, ...]], Records, int]
"""An order walked: SSA path, the labels each step keeps, each step's records, and the
total multiply-adds."""


def order(
    compiled: Compiled,
    scopes: Sequence[Sequence[int]],
    output: Sequence[int],
    sizes: Mapping[int, int] | None = None,
    *,
    tuning: Tuning = TUNING,
) -> tuple[list[tuple[int, ...]], int]:
    """A contraction order (opt_einsum SSA path) for ``scopes`` -> ``output``, and its cost.

    See :func:`order_steps`, which also gives the labels each step keeps.
    """
    path, _, total = order_steps(compiled, scopes, output, sizes, tuning=tuning)
    return path, total


def order_steps(
    compiled: Compiled,
    scopes: Sequence[Sequence[int]],
    output: Sequence[int],
    sizes: Mapping[int, int] | None = None,
    *,
    search: bool = False,
    emit: Callable[[Sequence[tuple[int, ...]], Sequence[tuple[int, ...]], Records], None]
    | None = None,
    network: Sequence[bool] | None = None,
    tuning: Tuning = TUNING,
) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]] | None, int]:
    """A contraction order (opt_einsum SSA path), the labels each step keeps, and its cost.

    An elimination order of these factors: each variable, in that order, has the factors
    holding it multiplied and summed over it (a variable no other factor holds is summed
    at once); a last step multiplies what is left into ``output``. The cost is the number
    of multiply-adds (the sizes of the steps' index unions).

    With ``network`` (a one-case question: whether each factor is evidence-free), the
    order is first the network-wide one restricted to these factors' variables
    (:func:`network_order`), which needs no search, with the evidence-free sub-trees
    first: a label is passed over while a factor holding it depends on the evidence, and
    the passed-over labels are summed out after the rest, in the same order, so the
    evidence-free steps are contracted into steps a program computes once (and shares
    between patterns), and the steps a question repeats for new values are the few that
    join the evidence. It is kept when it costs at most
    ``tuning.network_order_per_factor`` multiply-adds per factor: then all of its
    arithmetic is worth less than a fraction of the contraction calls' fixed cost, and no
    order could save more than that; the walk stops as soon as it passes that bound, and
    is not tried when the labels' network-wide elimination weights exceed it by more than
    ``tuning.network_order_slack`` (a dense part of the network).
    Otherwise (or without ``network``) the order is the greedy min-weight order of the
    factors themselves (:func:`elimination_rank`). If the order costs more than
    ``tuning.greedy_above`` multiply-adds (and ``tuning.greedy_per_factor`` per factor),
    :func:`opt_einsum.paths.ssa_greedy_optimize` is run on these factors as well and the
    order with the fewer multiply-adds is kept (its kept labels are then ``None``: they are
    not computed here). ``sizes`` gives the size of labels that are not variables (the case
    axis of a batch, label −1). ``search`` asks opt_einsum's greedy search whatever the cost
    (for contractions cached long and run over the whole network: the two-pass scheme,
    where min-weight's order cost andes 1.3–1.8× more time). The kept labels feed
    :class:`~bayesmap.bn.elimination.SumProgram`, which would otherwise recount them.

    The orders are walked by compiled code (``csrc/walk.c``: each label summed out with
    the operands then holding it, as :class:`~bayesmap.bn.elimination.Walker` reads a
    path), which also gives each step's entries and labels; the walk stops as soon as it
    passes a bound. ``emit`` (e.g. :meth:`SumProgram.extend
    <bayesmap.bn.elimination.SumProgram.extend>`) is given the returned order: its path,
    the labels each step keeps (the last step's in any order), and each step's entries and
    labels, so no order is walked twice.
    """
    card = compiled.card
    extra = sizes or {}
    n = len(scopes)
    if n == 1:
        entries = math.prod([card[w] if w >= 0 else extra[w] for w in scopes[0]])
        if emit is not None:
            emit([(0,)], [tuple(output)], [(entries, tuple(scopes[0]))])
        return [(0,)], [tuple(output)], entries
    steps: Steps | None = None
    if network is not None and not extra and not search:
        positions, weights = network_order(compiled)
        limit = tuning.network_order_per_factor * n
        # the labels to sum, in the network's order; their network-wide weights bound the
        # restricted order's steps (up to the kept output labels, before the evidence-free
        # steps move first): far above the limit, the order is not worth a walk
        bound = tuning.network_order_slack * limit
        ordered = _orders.restrict(scopes, output, positions, weights, bound)
        if ordered is not None:
            steps = _orders.eliminate(scopes, ordered, output, card, None, network, limit)
    if steps is None:
        rank, _ = elimination_rank(scopes, output, card)
        # the ranked labels in rank order, then the labels not ranked (the case axis)
        unranked = (
            [u for u in dict.fromkeys(chain.from_iterable(scopes)) if u < 0 and u not in output]
            if extra
            else []
        )
        steps = _orders.eliminate(scopes, [*rank, *unranked], output, card, extra, None, None)
        assert steps is not None  # no limit
    path, kept_steps, records, total = steps
    if search or (total > tuning.greedy_above and total > tuning.greedy_per_factor * n):
        sets = [frozenset(scope) for scope in scopes]
        table = {u: card[u] if u >= 0 else extra[u] for u in chain(*scopes, output)}
        greedy = _greedy(sets, frozenset(output), table)
        greedy_total = _cost(sets, set(output), greedy, table)
        if greedy_total < _cost(sets, set(output), path, table):
            if emit is not None:
                steps_taken = walk(scopes, output, greedy)
                emit(
                    greedy,
                    [step.kept for step in steps_taken],
                    [(math.prod([table[u] for u in s.union]), s.union) for s in steps_taken],
                )
            return greedy, None, greedy_total
    if emit is not None:
        emit(path, kept_steps, records)
    return path, kept_steps, total


def network_order(compiled: Compiled) -> tuple[list[int], list[int]]:
    """Each variable's position in a network-wide elimination order and the weight of its
    elimination there (the entries of its factor with its neighbours then), by variable
    id, computed once per network version (:attr:`Compiled.network_order`).

    The greedy min-weight order (:func:`elimination_rank`) of the moral graph, every CPT's
    variables linked. A plan's interaction graph is a subgraph of it (evidence, barren
    variables and replaced sub-networks only remove vertices and edges), and eliminating a
    subgraph's vertices in the order they take in the whole graph fills in no edge that
    the whole graph's elimination did not (Koller & Friedman 2009, §9.4.3.1), so the
    restricted order is no wider than the network-wide one — each step within its
    variable's weight here, up to the labels the plan keeps (its targets) — and costs no
    search. :func:`order_steps` moves the
    evidence-free sub-trees first, which that bound does not cover; its cost check does.
    """
    known = compiled.network_order
    if known is None:
        families = [(v, *ps) for v, ps in enumerate(compiled.parents)]
        found: dict[int, int] = {}
        rank, _ = elimination_rank(families, (), compiled.card, found)
        ids = range(len(families))
        known = compiled.network_order = ([rank[v] for v in ids], [found[v] for v in ids])
    return known


def elimination_rank(
    scopes: Sequence[Sequence[int]],
    output: Sequence[int],
    card: Sequence[int],
    weights: dict[int, int] | None = None,
) -> tuple[dict[int, int], int]:
    """Position of each summed-out label in a greedy min-weight elimination order, and the
    sum of the weights of its eliminations.

    Variable elimination on the interaction graph of ``scopes`` (the labels of each factor
    linked) repeatedly sums out the label whose factor — the label and its current
    neighbours — has the fewest entries (ties: the least label), then links its
    neighbours (Koller & Friedman 2009, §9.4.3.2). Labels in ``output`` are never summed
    out. Compiled (``csrc/rank.c``: the graph as bit rows, the next label from a heap whose
    stale entries are skipped), as it runs on every cold question whose network order is
    not kept. ``card`` gives the variables' sizes; other labels (the case axis of a batch,
    label −1) are left out of the graph: the order is the one-case order, which keeps a
    case axis off the evidence-free steps (with it, min-weight spreads the axis early and a
    batch costs 30× more on alarm). The summed weights bound the multiply-adds of the steps
    that sum these labels out in this order (each step's operands lie within the label's
    factor). ``weights``, if given, receives each label's weight when it is summed out.
    """
    rank: dict[int, int]
    rank, bound = _orders.min_weight(scopes, output, card, weights)
    return rank, bound


def _greedy(
    sets: Sequence[frozenset[int]], output: frozenset[int], table: Mapping[int, int]
) -> list[tuple[int, ...]]:
    """opt_einsum's greedy SSA path, after multiplying each factor into one that holds it.

    A factor whose labels are all held by another (a prior, a CPT sliced by evidence) is
    first multiplied into that one — the step greedy takes first anyway, as it only
    shrinks the operands — so :func:`opt_einsum.paths.ssa_greedy_optimize`, whose time
    grows faster than linearly with the number of operands, searches fewer of them.
    """
    n = len(sets)
    owners: dict[int, list[int]] = {}
    for k, scope in enumerate(sets):
        for u in scope:
            owners.setdefault(u, []).append(k)
    walker = Walker(sets, output)
    ssa = list(range(n))  # current SSA id of each factor (a host's merged result)
    live = list(sets)
    absorbed = [False] * n
    path: list[tuple[int, ...]] = []
    for k in sorted(range(n), key=lambda k: len(sets[k])):
        scope = sets[k]
        if not scope:
            continue
        candidates = owners[next(iter(scope))]
        host = next((j for j in candidates if j != k and not absorbed[j] and scope <= live[j]), -1)
        if host < 0:
            continue
        absorbed[k] = True
        live[host] = frozenset(walker.step((ssa[host], ssa[k])).kept)
        path.append((ssa[host], ssa[k]))
        ssa[host] = n + len(path) - 1
    rest = [j for j in range(n) if not absorbed[j]]
    if len(rest) < 2:
        return path
    first = n + len(path)
    greedy = opt_einsum.paths.ssa_greedy_optimize([live[j] for j in rest], output, table)
    ids = [ssa[j] for j in rest]
    for step in greedy:
        path.append(tuple(ids[i] if i < len(rest) else first + i - len(rest) for i in step))
    return path


def _cost(
    sets: Sequence[frozenset[int]],
    output: set[int],
    path: Sequence[tuple[int, ...]],
    size: Mapping[int, int],
) -> int:
    """Multiply-adds of an SSA path: the sum of the sizes of each step's index union."""
    total = 0
    for step in walk(sets, output, path):
        total += math.prod([size[u] for u in step.union])
    return total
