"""Validation of conditional probability tables: the normalisation policy of the model.

Kept apart from the model so that the inference code, which checks the tables that data
nodes return at query time, applies exactly the same rules without importing the model.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.errors import ModelError

SUM_TOLERANCE = 1e-2
"""A CPT column whose sum is further than this from 1 is an error."""

WARN_TOLERANCE = 1e-6
"""A CPT column whose sum is further than this from 1 is renormalised with a warning."""


class CPTNormalisationWarning(UserWarning):
    """A CPT column summed to 1 only roughly and was renormalised."""


DataSource = Callable[[Mapping[str, str]], npt.ArrayLike]
"""A data node's source: called at query time, returns the node's CPT ``(child, *parents)``.

It receives the network's current evidence (``{variable: state}``) so that it can, for
example, look up the cell of a map under the robot.
"""


class _StateNames(Protocol):
    def __contains__(self, name: object) -> bool: ...

    def states(self, name: str) -> tuple[str, ...]: ...


def checked_cpt(
    name: str,
    cpt: npt.ArrayLike,
    shape: tuple[int, ...],
    parents: Sequence[str],
    net: _StateNames,
    *,
    states: Sequence[str] | None = None,
) -> FloatArray:
    """Validate ``cpt`` against ``shape`` and renormalise it by the normalisation policy.

    ``states`` names the child's states when it is not in ``net`` yet (a variable being
    added), so that messages name a state rather than its index.

    Raises
    ------
    ModelError
        Non-numeric, wrong shape, NaN, negative or a column off 1 by more than
        :data:`SUM_TOLERANCE`; the message names the node and the parent states.
    """
    try:
        table = np.array(cpt, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ModelError(f"variable {name!r}: CPT is not numeric ({error})") from None
    if table.ndim == 1 and len(shape) > 1 and table.size == int(np.prod(shape)):
        raise ModelError(
            f"variable {name!r}: CPT given flat with {table.size} values; pass shape {shape} "
            "(child, *parents) or use cpt_from_flat for the eq.-29 layout"
        )
    if table.shape != shape:
        raise ModelError(
            f"variable {name!r}: CPT has shape {table.shape}, expected {shape} "
            f"(states of {name!r}, then parents {list(parents)})"
        )
    if not np.all(np.isfinite(table)):
        raise ModelError(f"variable {name!r}: CPT holds NaN or infinite values")
    if np.any(table < 0):
        column = np.argwhere(table < 0)[0]
        raise ModelError(
            f"variable {name!r}: negative probability at "
            f"{_describe(column, name, parents, net, states)}"
        )
    sums = table.sum(axis=0)
    deviation = np.abs(sums - 1.0)
    worst = int(np.argmax(deviation)) if deviation.size else 0
    worst_dev = float(deviation.flat[worst]) if deviation.size else 0.0
    if worst_dev > SUM_TOLERANCE:
        where = np.unravel_index(worst, sums.shape) if sums.ndim else ()
        raise ModelError(
            f"variable {name!r}: the distribution for {_parent_states(where, parents, net)} "
            f"sums to {float(sums.flat[worst]):.6g}, not 1"
        )
    if worst_dev > WARN_TOLERANCE:
        where = np.unravel_index(worst, sums.shape) if sums.ndim else ()
        warnings.warn(
            f"variable {name!r}: the distribution for {_parent_states(where, parents, net)} "
            f"sums to {float(sums.flat[worst]):.9g}; renormalised",
            CPTNormalisationWarning,
            stacklevel=3,
        )
    # Columns that already sum to 1 up to rounding are kept bit for bit, so normalising is
    # idempotent: a network written to a file and read back is unchanged.
    rounding = 4 * shape[0] * np.finfo(np.float64).eps
    return np.asarray(np.where(deviation <= rounding, table, table / sums))


def _parent_states(where: Sequence[Any], parents: Sequence[str], net: _StateNames) -> str:
    if not parents:
        return "the root"
    pairs = [f"{p}={net.states(p)[int(i)]}" for p, i in zip(parents, where, strict=True)]
    return "parents " + ", ".join(pairs)


def _describe(
    index: Sequence[Any],
    name: str,
    parents: Sequence[str],
    net: _StateNames,
    states: Sequence[str] | None,
) -> str:
    if states is None and name in net:
        states = net.states(name)
    state = str(index[0]) if states is None else states[int(index[0])]
    return f"state {state!r} given {_parent_states(index[1:], parents, net)}"
