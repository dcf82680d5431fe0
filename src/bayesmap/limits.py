"""How much a reader may allocate: checked *before* allocating, so a hostile file costs nothing.

Every reader of a file (network files, occupancy-grid ``.npz``, ROS map_server maps) takes an
optional ``limits=`` :class:`ReadLimits`. Before it allocates anything whose size the file
dictates — the bytes of the file itself, a gunzipped stream, a probability table, an image,
a grid — it computes that size with Python integers (which cannot overflow) and refuses a
size over the limit with a :class:`~bayesmap.errors.FormatError` naming the file, the place
and the limit, and how to raise it. The defaults fit every network of the bnlearn
repository and maps of tens of millions of cells; raise them for larger inputs::

    from bayesmap.limits import ReadLimits
    net = bn.read("huge.bif", limits=ReadLimits(max_table_entries=2**28))

The coarsest map cell a user may ask for (:data:`MAX_CELL_SIDE`, :func:`cell_side_problem`)
is kept here too: a world file's ``resolution`` or a ``--resolution`` in the wrong unit is
refused before a grid is made.

Why a table limit: a variable with ``L`` parents of ``N_l`` states each stores
``N x prod(N_l)`` probabilities (Post et al. 2016 eq. 28), which a short file — a BIF
``default`` row, or 63 binary parents — can make astronomically large. Why a parents limit:
a table is an array of ``1 + L`` dimensions and numpy allows at most 64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from bayesmap.errors import ConfigError, FormatError

__all__ = [
    "DEFAULT_LIMITS",
    "MAX_CELL_SIDE",
    "NUMPY_MAX_PARENTS",
    "ReadLimits",
    "cell_side_problem",
    "check_size",
]

NUMPY_MAX_PARENTS = 62
"""Most parents a table can have: numpy arrays have at most 64 dimensions, the child takes
one and inference may add one more."""


@dataclass(frozen=True)
class ReadLimits:
    """Largest inputs a reader accepts.

    Attributes
    ----------
    max_bytes
        Bytes of a file, and of its content after gunzipping (``.gz`` inputs) [bytes].
    max_table_entries
        Probabilities in one table: ``states x prod(parent states)`` (Post et al. eq. 28).
    max_network_entries
        Probabilities in all tables of one network together.
    max_parents
        Parents of one variable (at most :data:`NUMPY_MAX_PARENTS`).
    max_cells
        Cells of one grid layer, or pixels of one map image.
    """

    max_bytes: int = 1 << 28
    max_table_entries: int = 1 << 25
    max_network_entries: int = 1 << 26
    max_parents: int = 32
    max_cells: int = 1 << 25

    def __post_init__(self) -> None:
        for name in (
            "max_bytes",
            "max_table_entries",
            "max_network_entries",
            "max_parents",
            "max_cells",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ConfigError(f"ReadLimits.{name} must be a positive integer, got {value!r}")
        if self.max_parents > NUMPY_MAX_PARENTS:
            raise ConfigError(
                f"ReadLimits.max_parents must be at most {NUMPY_MAX_PARENTS} (numpy's "
                f"dimension limit), got {self.max_parents}"
            )


DEFAULT_LIMITS = ReadLimits()
"""The limits a reader uses when none are given."""


def check_size(
    what: str,
    size: int,
    limit: int,
    field: str,
    *,
    path: str | None = None,
    line: int | None = None,
    element: str | None = None,
) -> None:
    """Refuse ``size`` over ``limit`` with a :class:`FormatError` naming the limit to raise.

    ``what`` says what was being counted (``"entries in the table"``), ``field`` is the
    :class:`ReadLimits` attribute that sets the limit.
    """
    if size > limit:
        raise FormatError(
            f"{what}: {size:,} exceeds the limit of {limit:,} (ReadLimits.{field}); "
            "if the file is trusted, pass a larger limit",
            path=path,
            line=line,
            element=element,
        )


MAX_CELL_SIDE = 2.0
"""Coarsest cell side [m] a sensor map takes from a user (world files, ``--resolution``):
wider than the rover's informative IR range (≈ 1.25 m) and five times the rover's body, a
cell could no longer say where an obstacle is; a larger number is most likely a cell side
written in cm or mm."""


def cell_side_problem(resolution: float) -> str | None:
    """What is wrong with ``resolution`` as a sensor map's cell side [m], or ``None``.

    The callers name the place (a world file's field, a command-line option) and raise their
    own error with this text.
    """
    if not (math.isfinite(resolution) and resolution > 0):
        return f"must be a positive number of metres, got {resolution!r}"
    if resolution > MAX_CELL_SIDE:
        return (
            f"is {resolution:g} m, coarser than the {MAX_CELL_SIDE:g} m a sensor map can use "
            "(is it in cm or mm? give metres)"
        )
    return None
