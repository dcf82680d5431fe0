"""Shared by the property-based fuzz tests of every reader: mutations and the CI budget.

A fuzz test draws a seed file, mutates it with :func:`mutated`, reads it with
:func:`read_within_budget` and accepts two outcomes only: a result, or a
:class:`~bayesmap.errors.BayesmapError`. Hypothesis's ``deadline`` (:data:`FUZZ`) fails a
case that runs past it, and the memory a case allocates is measured with ``tracemalloc``
(numpy reports its buffers to it) against :data:`MEMORY_LIMIT`. Longer campaigns run from
``fuzz/`` (see docs/reliability.md).
"""

from __future__ import annotations

import tracemalloc
import warnings
from collections.abc import Callable
from datetime import timedelta

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from bayesmap.errors import BayesmapError

MEMORY_LIMIT = 256 * 2**20
"""Bytes one fuzz case may allocate at its peak."""
FUZZ = settings(
    max_examples=120,
    deadline=timedelta(seconds=5),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
"""The CI budget of a fuzz test: examples, and a generous wall-clock limit per case."""

TOKENS = [
    b"nan", b"inf", b"-Infinity", b"1_0", "\u0661".encode(), b"1e999", b"-1", b"\x00", b"\xff",
    b'"', b"{", b"}", b"(", b")", b";", b",", b"|", b"=", b"/*", b"*/", b"//", b"<", b">",
    b"&e;", b"<!ENTITY e 'x'>", b"]]>", b"<!--", b"default", b"table", b"\n", b"\r\n", b"\r",
    b"P5", b"65535", b"99999 99999", b"PK\x03\x04", b"mode: raw", b"negate: 1", b"[/x]",
]  # fmt: skip


@st.composite
def mutated(draw: st.DrawFn, seeds: list[bytes]) -> bytes:
    """One of ``seeds`` after 1-4 edits: byte changes, token inserts, cuts, copies, cut-offs."""
    data = bytearray(draw(st.sampled_from(seeds)))
    for _ in range(draw(st.integers(1, 4))):
        n = len(data)
        i = draw(st.integers(0, n))
        j = min(n, i + draw(st.integers(0, 48)))
        op = draw(st.sampled_from(["byte", "insert", "delete", "duplicate", "truncate"]))
        if op == "byte" and n:
            data[min(i, n - 1)] = draw(st.integers(0, 255))
        elif op == "insert":
            data[i:i] = draw(st.sampled_from(TOKENS))
        elif op == "delete":
            del data[i:j]
        elif op == "duplicate":
            data[j:j] = data[i:j] * draw(st.integers(1, 3))
        else:
            del data[i:]
    return bytes(data)


def read_within_budget(read: Callable[[], object]) -> object | BayesmapError:
    """``read()``'s result or the :class:`BayesmapError` it raised; fails past the memory
    limit. Any other exception propagates and fails the test."""
    tracemalloc.start()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                return read()
            except BayesmapError as error:
                return error
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert peak < MEMORY_LIMIT, f"a fuzz case allocated {peak / 2**20:.0f} MB"
