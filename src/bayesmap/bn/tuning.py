"""The engine's tuning constants: where it switches between equally exact ways to answer.

None of these changes an answer beyond the last bits of a float (a different contraction
order or grouping); they trade time and memory. Each was set by a measurement in
``benchmarks/`` on the bnlearn networks. A network takes its tuning at construction,
``BayesNet(name, tuning=Tuning(...))``, or later through ``net.tuning = ...`` (which drops
the engine's caches); tests use it to force the rarely taken branches.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tuning:
    """Thresholds of the exact-inference engine (multiply-adds, entries or cases).

    Attributes
    ----------
    batch_class
        Batches up to ``2 * batch_class - 1`` cases share one contraction order; above,
        one order per power of two of cases.
    many_patterns
        Batches whose cases spread over more patterns of observed columns than this are
        answered by one contraction with evidence indicators rather than one per pattern.
    max_lookup
        Largest memo of batch answers (combinations of observed states × target states).
    joint_above
        Multiply-adds per case of a batch contraction above which contracting the
        evidence-free joint of the observed variables and the target once is considered.
    call_cost
        Fixed cost of one contraction call, in multiply-adds (a few µs of Python and numpy).
    calls_per_question
        The fixed cost of one single-variable question (evidence, slicing, contraction,
        normalising), in calls of ``call_cost``: with the compiled planner a warm one takes
        8–14 µs beside its arithmetic (pigs, alarm, munin1), about four calls (it was eight
        before; pigs' every-posterior questions then took the two-pass contraction, 16×
        slower there than a question per variable).
    one_step
        A one-case contraction over at most this many joint entries (and at most
        ``one_step_operands`` factors) is one ``np.einsum`` call: its fixed cost, a few µs,
        outweighs the arithmetic, so no order is computed.
    one_step_operands
        See ``one_step``.
    greedy_above
        A plan's min-weight contraction order is compared with opt_einsum's greedy search
        on the plan only above this many multiply-adds ...
    greedy_per_factor
        ... and this many per factor: below, even a much better order saves less time than
        the search costs (~30–40 µs per factor).
    network_order_per_factor
        A one-case question's plan is contracted in the network-wide elimination order
        (restricted to its variables) when that order costs at most this many multiply-adds
        per factor (a quarter of ``call_cost``: the arithmetic then weighs less than the
        calls' fixed cost, whatever the order); above, a min-weight order of the plan's own
        is used.
    network_order_slack
        ... and it is not even tried when its variables' weights in the network-wide
        elimination (which bound its steps) sum to more than this many times that limit.
    search_above
        Greedy orders of the pluggable-arithmetic contractions (MAP, fixed point) costing
        more multiply-adds than this are improved by a random-greedy search.
    search_repeats
        Trials of that search (each seeded by its number, so the order is reproducible).
    split_above
        A compiled sum-product step of three or more operands over more joint entries than
        this is split into pairwise contractions (``np.einsum`` loops naively over the
        union of all its operands' indices).
    blas_above
        A pairwise compiled sum-product step over more joint entries than this goes to
        :func:`opt_einsum.contract` (BLAS) rather than ``np.einsum``.
    two_pass_blas_above
        The same for the steps of the two-pass contraction (:mod:`bayesmap.bn.marginals`).
    """

    batch_class: int = 256
    many_patterns: int = 64
    max_lookup: int = 1 << 16
    joint_above: int = 1 << 20
    call_cost: int = 4000
    calls_per_question: int = 4
    one_step: int = 1 << 10
    one_step_operands: int = 16
    greedy_above: int = 1 << 20
    greedy_per_factor: int = 1 << 15
    network_order_per_factor: int = 1000
    network_order_slack: int = 16
    search_above: float = 1e8
    search_repeats: int = 16
    split_above: int = 1 << 12
    blas_above: int = 1 << 16
    two_pass_blas_above: int = 1 << 14


TUNING = Tuning()
"""The measured defaults."""
