"""The discrete Bayesian-network model: variables, node kinds and CPTs.

A :class:`BayesNet` holds, for every variable, its named states, its ordered parents,
its node kind (Post et al. 2016, §3.4: ability, bus, classification or data) and its
conditional probability table.

CPT layout
----------
In memory a CPT is a float64 array of shape ``(child, *parents)``: axis 0 is the child's
state, axis ``k`` the state of the ``k``-th parent. Post et al. 2016 store each node as one
flat array indexed by eq. 29, ``i = m_1 + m_2 M_1 + m_3 M_1 M_2 + ...``, where ``m_1`` is the
child's state and ``m_2, m_3, ...`` are the parents' states: the child's index varies
fastest. That is numpy's Fortran (column-major) order of the ``(child, *parents)`` array,
or equally C order of the reversed shape; :meth:`BayesNet.flat_cpt` and
:func:`cpt_from_flat` convert between the two.

Because a new parent becomes the *slowest* axis of eq. 29, adding a parent at run time
(:meth:`BayesNet.add_parent`) keeps the old flat table as the first block and repeats it
once per state of the new parent: until the user says otherwise, the child ignores the
new parent.

Normalisation policy
--------------------
Each distribution of the child (one column ``cpt[:, *parent_states]``) must sum to 1. A
column off by more than :data:`SUM_TOLERANCE` raises :class:`~bayesmap.errors.ModelError`
naming the node and the parent states; one off by more than :data:`WARN_TOLERANCE` is
renormalised with a :class:`CPTNormalisationWarning`; smaller rounding (as in published
bnlearn files) is renormalised silently, so that every stored column sums to 1 to machine
precision.
"""

from __future__ import annotations

import enum
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from bayesmap._typing import CPT, FloatArray
from bayesmap.errors import ModelError

SUM_TOLERANCE = 1e-2
"""A CPT column whose sum is further than this from 1 is an error."""

WARN_TOLERANCE = 1e-6
"""A CPT column whose sum is further than this from 1 is renormalised with a warning."""


class CPTNormalisationWarning(UserWarning):
    """A CPT column summed to 1 only roughly and was renormalised."""


class NodeKind(enum.Enum):
    """The four kinds of node of Post et al. 2016, §3.4 (Figs. 6 and 8).

    ABILITY
        What a part of the robot can do or sense: a sensor or movement model.
    BUS
        An interface to hardware: a sensor reading or a motor command.
    CLASSIFICATION
        An inference that combines others: fusion, a decision.
    DATA
        A node whose distribution comes from stored data at query time (e.g. a map).
    """

    ABILITY = "A"
    BUS = "B"
    CLASSIFICATION = "C"
    DATA = "D"


DataSource = Callable[[Mapping[str, str]], npt.ArrayLike]
"""A data node's source: called at query time, returns the node's CPT ``(child, *parents)``.

It receives the network's current evidence (``{variable: state}``) so that it can, for
example, look up the cell of a map under the robot.
"""


@dataclass
class Variable:
    """One discrete random variable of a :class:`BayesNet`.

    Attributes
    ----------
    name
        Unique name in the network.
    states
        Names of its states, in order.
    parents
        Names of its parents, in the order of the CPT's axes 1..L.
    cpt
        Conditional probability table of shape ``(len(states), *parent cardinalities)``.
    kind
        Node kind (Post et al. 2016 §3.4), or ``None`` for a plain variable.
    properties
        Free-form ``name -> value`` annotations (written as XMLBIF ``<PROPERTY>``).
    source
        For data nodes whose table is computed at query time: the callable that gives it.
    """

    name: str
    states: tuple[str, ...]
    parents: tuple[str, ...]
    cpt: CPT
    kind: NodeKind | None = None
    properties: dict[str, str] = field(default_factory=dict)
    source: DataSource | None = None

    @property
    def cardinality(self) -> int:
        """Number of states."""
        return len(self.states)

    def index(self, state: str | int) -> int:
        """Index of ``state`` (a name, or an index checked for range)."""
        if isinstance(state, (int, np.integer)) and not isinstance(state, bool):
            if 0 <= int(state) < len(self.states):
                return int(state)
            raise ModelError(
                f"variable {self.name!r} has {len(self.states)} states; index {state} is out of range"
            )
        try:
            return self.states.index(str(state))
        except ValueError:
            raise ModelError(
                f"variable {self.name!r} has no state {state!r}; its states are {list(self.states)}"
            ) from None


class BayesNet:
    """A discrete Bayesian network, built in code or read from a file.

    Parameters
    ----------
    name
        The network's name (written to files).

    Examples
    --------
    >>> net = BayesNet("rain")
    >>> net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    >>> net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    >>> net.cpt("Wet").shape
    (2, 2)
    """

    def __init__(self, name: str = "network") -> None:
        self.name = name
        self._variables: dict[str, Variable] = {}
        self.properties: dict[str, str] = {}
        self._version = 0

    # ------------------------------------------------------------------ structure
    @property
    def version(self) -> int:
        """Counter bumped by every change; caches keyed on it go stale on change."""
        return self._version

    @property
    def variables(self) -> tuple[str, ...]:
        """Names of the variables, in the order they were added."""
        return tuple(self._variables)

    def __contains__(self, name: object) -> bool:
        return name in self._variables

    def __len__(self) -> int:
        return len(self._variables)

    def __repr__(self) -> str:
        edges = sum(len(v.parents) for v in self._variables.values())
        return f"BayesNet({self.name!r}, {len(self)} variables, {edges} edges)"

    def variable(self, name: str) -> Variable:
        """The :class:`Variable` called ``name``; :class:`ModelError` if there is none."""
        try:
            return self._variables[name]
        except KeyError:
            raise ModelError(f"network {self.name!r} has no variable {name!r}") from None

    def states(self, name: str) -> tuple[str, ...]:
        """State names of ``name``."""
        return self.variable(name).states

    def cardinality(self, name: str) -> int:
        """Number of states of ``name``."""
        return self.variable(name).cardinality

    def parents(self, name: str) -> tuple[str, ...]:
        """Parents of ``name``, in CPT axis order."""
        return self.variable(name).parents

    def children(self, name: str) -> tuple[str, ...]:
        """Variables that have ``name`` as a parent, in network order."""
        self.variable(name)
        return tuple(v.name for v in self._variables.values() if name in v.parents)

    def kind(self, name: str) -> NodeKind | None:
        """Node kind of ``name`` (Post et al. 2016 §3.4), or ``None``."""
        return self.variable(name).kind

    def cpt(self, name: str) -> CPT:
        """CPT of ``name`` as a read-only ``(child, *parents)`` array."""
        return self.variable(name).cpt

    def flat_cpt(self, name: str) -> FloatArray:
        """CPT of ``name`` as one flat array in the order of Post et al. 2016, eq. 29."""
        return np.asarray(self.cpt(name).ravel(order="F"))

    def edges(self) -> list[tuple[str, str]]:
        """All ``(parent, child)`` pairs."""
        return [(p, v.name) for v in self._variables.values() for p in v.parents]

    def topological_order(self) -> tuple[str, ...]:
        """Variables ordered so that every parent comes before its children."""
        order: list[str] = []
        placed: set[str] = set()
        remaining = dict(self._variables)
        while remaining:
            ready = [n for n, v in remaining.items() if all(p in placed for p in v.parents)]
            if not ready:
                raise ModelError(f"network {self.name!r} has a cycle among {sorted(remaining)}")
            for n in ready:
                order.append(n)
                placed.add(n)
                del remaining[n]
        return tuple(order)

    # --------------------------------------------------------------- changes
    def add_variable(
        self,
        name: str,
        states: Sequence[str],
        *,
        parents: Sequence[str] = (),
        cpt: npt.ArrayLike | None = None,
        kind: NodeKind | str | None = None,
        properties: Mapping[str, str] | None = None,
        source: DataSource | None = None,
    ) -> Variable:
        """Add a variable with its states, parents and CPT.

        Parameters
        ----------
        name
            Unique name.
        states
            At least one state name, all distinct.
        parents
            Names of variables already in the network.
        cpt
            Array of shape ``(len(states), *parent cardinalities)``; a 1-D array is accepted
            for a root. ``None`` means uniform.
        kind
            A :class:`NodeKind` or its letter ``"A"``, ``"B"``, ``"C"``, ``"D"``.
        properties
            Free-form annotations kept with the node.
        source
            For a data node: a :data:`DataSource` that gives its CPT at query time.

        Raises
        ------
        ModelError
            Duplicate name or state, unknown parent, CPT of the wrong shape or columns
            that do not sum to 1.
        """
        if not isinstance(name, str) or not name:
            raise ModelError(f"a variable name must be a non-empty string, got {name!r}")
        if name in self._variables:
            raise ModelError(f"network {self.name!r} already has a variable {name!r}")
        state_tuple = tuple(str(s) for s in states)
        if not state_tuple:
            raise ModelError(f"variable {name!r} needs at least one state")
        if len(set(state_tuple)) != len(state_tuple):
            duplicates = sorted({s for s in state_tuple if state_tuple.count(s) > 1})
            raise ModelError(f"variable {name!r} repeats state name(s) {duplicates}")
        parent_tuple = tuple(parents)
        if len(set(parent_tuple)) != len(parent_tuple):
            raise ModelError(f"variable {name!r} lists a parent twice: {list(parent_tuple)}")
        for parent in parent_tuple:
            if parent not in self._variables:
                raise ModelError(f"variable {name!r}: parent {parent!r} is not in the network")
        shape = (len(state_tuple), *(self._variables[p].cardinality for p in parent_tuple))
        table = (
            np.full(shape, 1.0 / len(state_tuple))
            if cpt is None
            else _checked_cpt(name, cpt, shape, parent_tuple, self)
        )
        table.setflags(write=False)
        variable = Variable(
            name=name,
            states=state_tuple,
            parents=parent_tuple,
            cpt=table,
            kind=_as_kind(kind, name),
            properties=dict(properties or {}),
            source=source,
        )
        self._variables[name] = variable
        self._version += 1
        return variable

    def set_cpt(self, name: str, cpt: npt.ArrayLike) -> None:
        """Replace the CPT of ``name`` (same shape rules as :meth:`add_variable`)."""
        variable = self.variable(name)
        shape = (variable.cardinality, *(self.cardinality(p) for p in variable.parents))
        table = _checked_cpt(name, cpt, shape, variable.parents, self)
        table.setflags(write=False)
        variable.cpt = table
        self._version += 1

    def set_kind(self, name: str, kind: NodeKind | str | None) -> None:
        """Set the node kind of ``name``."""
        self.variable(name).kind = _as_kind(kind, name)
        self._version += 1

    def set_source(self, name: str, source: DataSource | None) -> None:
        """Attach (or detach, with ``None``) a query-time data source to ``name``."""
        self.variable(name).source = source
        self._version += 1

    def add_parent(self, child: str, parent: str, *, cpt: npt.ArrayLike | None = None) -> None:
        """Add ``parent`` as the last parent of ``child`` at run time.

        Without ``cpt``, the child's table grows by the rule of eq. 29: the new parent is
        the slowest-varying index, so the old flat table is repeated once per state of the
        new parent (the child does not depend on it until its table is changed). With
        ``cpt``, that table of the new shape is used instead.

        Raises
        ------
        ModelError
            Unknown variable, parent already present, or a cycle.
        """
        variable = self.variable(child)
        new_parent = self.variable(parent)
        if parent in variable.parents:
            raise ModelError(f"{parent!r} is already a parent of {child!r}")
        if parent == child or child in self._ancestors(parent):
            raise ModelError(f"adding {parent!r} -> {child!r} would make a cycle")
        new_parents = (*variable.parents, parent)
        if cpt is None:
            table = np.repeat(variable.cpt[..., np.newaxis], new_parent.cardinality, axis=-1)
        else:
            shape = (variable.cardinality, *(self.cardinality(p) for p in new_parents))
            table = _checked_cpt(child, cpt, shape, new_parents, self)
        table.setflags(write=False)
        variable.parents = new_parents
        variable.cpt = table
        self._version += 1

    def remove_variable(self, name: str) -> None:
        """Remove a variable that has no children."""
        children = self.children(name)
        if children:
            raise ModelError(f"cannot remove {name!r}: it is a parent of {list(children)}")
        del self._variables[name]
        self._version += 1

    def _ancestors(self, name: str) -> set[str]:
        seen: set[str] = set()
        stack = list(self.parents(name))
        while stack:
            n = stack.pop()
            if n not in seen:
                seen.add(n)
                stack.extend(self._variables[n].parents)
        return seen

    def ancestors(self, names: Iterable[str]) -> set[str]:
        """All ancestors of the given variables (not including themselves)."""
        found: set[str] = set()
        for name in names:
            found |= self._ancestors(name)
        return found

    def copy(self) -> BayesNet:
        """A copy sharing no mutable state (CPT arrays are read-only and shared)."""
        other = BayesNet(self.name)
        other.properties = dict(self.properties)
        for v in self._variables.values():
            other._variables[v.name] = Variable(
                v.name, v.states, v.parents, v.cpt, v.kind, dict(v.properties), v.source
            )
        return other

    def structurally_equal(self, other: BayesNet, *, atol: float = 0.0) -> bool:
        """Same variables, states, parents, kinds and CPTs (within ``atol``)."""
        if set(self.variables) != set(other.variables):
            return False
        for name in self.variables:
            a, b = self.variable(name), other.variable(name)
            if (a.states, a.parents, a.kind) != (b.states, b.parents, b.kind):
                return False
            if not np.allclose(a.cpt, b.cpt, rtol=0.0, atol=atol):
                return False
        return True


def cpt_from_flat(flat: npt.ArrayLike, shape: Sequence[int]) -> CPT:
    """Inverse of :meth:`BayesNet.flat_cpt`: a flat eq.-29 array to ``(child, *parents)``."""
    values = np.asarray(flat, dtype=np.float64)
    if values.size != int(np.prod(shape)):
        raise ModelError(f"flat table has {values.size} values; shape {tuple(shape)} needs {int(np.prod(shape))}")
    return np.asarray(values.reshape(tuple(shape), order="F"))


def _as_kind(kind: NodeKind | str | None, name: str) -> NodeKind | None:
    if kind is None or isinstance(kind, NodeKind):
        return kind
    text = str(kind).strip().upper()
    for member in NodeKind:
        if text in (member.value, member.name):
            return member
    raise ModelError(
        f"variable {name!r}: unknown node kind {kind!r}; use one of A, B, C, D "
        "(ability, bus, classification, data)"
    )


def _checked_cpt(
    name: str, cpt: npt.ArrayLike, shape: tuple[int, ...], parents: Sequence[str], net: BayesNet
) -> FloatArray:
    """Validate and renormalise a CPT by the module's normalisation policy."""
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
        raise ModelError(f"variable {name!r}: negative probability at {_describe(column, name, parents, net)}")
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
    return np.asarray(table / sums)


def _parent_states(where: Sequence[Any], parents: Sequence[str], net: BayesNet) -> str:
    if not parents:
        return "the root"
    pairs = [f"{p}={net.states(p)[int(i)]}" for p, i in zip(parents, where, strict=True)]
    return "parents " + ", ".join(pairs)


def _describe(index: Sequence[Any], name: str, parents: Sequence[str], net: BayesNet) -> str:
    state = net.states(name)[int(index[0])] if name in net else str(index[0])
    return f"state {state!r} given {_parent_states(index[1:], parents, net)}"
