"""Compiled elimination orders, program steps and small sum-products (sources in ``csrc/``)."""

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

def eliminate(
    scopes: Sequence[Sequence[int]],
    labels: Iterable[int],
    output: Sequence[int],
    card: Sequence[int],
    extra: Mapping[int, int] | None,
    constant: Sequence[bool] | None,
    limit: int | None,
) -> (
    tuple[
        list[tuple[int, ...]],
        list[tuple[int, ...]],
        list[tuple[int, tuple[int, ...]]],
        int,
    ]
    | None
): ...
def min_weight(
    scopes: Sequence[Sequence[int]],
    output: Sequence[int],
    card: Sequence[int],
    weights: dict[int, int] | None,
) -> tuple[dict[int, int], int]: ...
def step(
    chosen: Sequence[tuple[Any, int, Sequence[int]]],
    kept: Sequence[int],
    union: Sequence[int],
    large: bool,
    results: dict[Any, Any] | None,
    steps: list[Any],
    n_inputs: int,
    constant: Callable[..., Any],
) -> tuple[Any, int, tuple[int, ...]]: ...
def emit(
    live: list[tuple[Any, int, Sequence[int]]],
    path: Sequence[Sequence[int]],
    kept: Sequence[Sequence[int]],
    records: Sequence[tuple[int, Iterable[int]]],
    results: dict[Any, Any] | None,
    steps: list[Any],
    n_inputs: int,
    blas_above: int,
    split_above: int,
    max_operands: int,
    max_entries: int,
    constant: Callable[..., Any],
    wide: Callable[..., Any],
) -> None: ...
def contract(*operands: Any) -> Any: ...
def prune(
    table: bytes, targets: Sequence[int], evidence: Sequence[int], kind: int, priors: bool
) -> tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]]: ...
def restrict(
    scopes: Sequence[Sequence[int]],
    output: Sequence[int],
    positions: Sequence[int],
    weights: Sequence[int],
    bound: int,
) -> list[int] | None: ...
