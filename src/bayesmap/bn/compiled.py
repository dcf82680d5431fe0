"""A network frozen into integer ids and arrays, the evidence-independent part of every query.

The inference code never walks :class:`~bayesmap.bn.model.BayesNet` objects on the hot
path: it works on a :class:`Compiled` snapshot (variables as integer ids in insertion
order, parents as id tuples, CPTs as read-only arrays, a state-name → index dictionary per
variable), rebuilt only when the network's version counter changes.
"""

from __future__ import annotations

import sys
from array import array
from collections.abc import Mapping, Sequence
from itertools import compress, count
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.bn.elimination import ConstantMemo
from bayesmap.bn.suggest import unknown
from bayesmap.bn.tables import DataSource, checked_cpt
from bayesmap.errors import InputError, ModelError


class _Variable(Protocol):
    name: str
    states: tuple[str, ...]
    parents: tuple[str, ...]
    cpt: FloatArray
    source: DataSource | None


class NetworkLike(Protocol):
    """What the inference code needs of a network (satisfied by ``BayesNet``)."""

    name: str

    @property
    def version(self) -> int: ...

    @property
    def variables(self) -> tuple[str, ...]: ...

    def variable(self, name: str) -> _Variable: ...

    def states(self, name: str) -> tuple[str, ...]: ...

    def topological_order(self) -> tuple[str, ...]: ...

    def __contains__(self, name: object) -> bool: ...


class Compiled:
    """The arrays and id tables of one version of a network.

    Attributes
    ----------
    names
        Variable names; a variable's id is its position here.
    card
        Number of states of each variable.
    parents
        Parent ids of each variable, in CPT axis order.
    cpts
        CPT of each variable, shape ``(child, *parents)``.
    topo
        Ids in a topological order (parents first).
    sources
        Ids of data nodes whose table comes from a callable at query time.
    """

    def __init__(self, net: NetworkLike) -> None:
        self.net = net
        self.version = net.version
        self.topo_names = net.topological_order()
        self.names: tuple[str, ...] = tuple(net.variables)
        self.index = {name: i for i, name in enumerate(self.names)}
        variables = [net.variable(name) for name in self.names]
        self.states = tuple(v.states for v in variables)
        self.card = tuple(len(v.states) for v in variables)
        self.parents = tuple(tuple(self.index[p] for p in v.parents) for v in variables)
        self.cpts: tuple[FloatArray, ...] = tuple(v.cpt for v in variables)
        self.lookup = tuple({s: k for k, s in enumerate(v.states)} for v in variables)
        self.topo = tuple(self.index[n] for n in self.topo_names)
        self.sources = {i: v.source for i, v in enumerate(variables) if v.source is not None}
        children: list[list[int]] = [[] for _ in self.names]
        for child, parents in enumerate(self.parents):
            for parent in parents:
                children[parent].append(child)
        self.children = tuple(tuple(c) for c in children)
        masks = [0] * len(self.names)
        for v in self.topo:
            for parent in self.parents[v]:
                masks[v] |= masks[parent] | (1 << parent)
        self.ancestor_masks = tuple(masks)
        """Ancestors of each variable as a bit mask (bit ``i`` = variable id ``i``)."""
        self.topo_pos = {v: k for k, v in enumerate(self.topo)}
        """Position of each variable in :attr:`topo`."""
        self.parent_masks = tuple(sum(1 << p for p in ps) for ps in self.parents)
        """Parents of each variable as a bit mask."""
        self.family_masks = tuple(1 << v | m for v, m in enumerate(self.parent_masks))
        """Each variable and its parents (the variables of its CPT) as a bit mask."""
        self.lineage_masks = tuple(1 << v | m for v, m in enumerate(self.ancestor_masks))
        """Each variable and its ancestors as a bit mask."""
        self.child_masks = tuple(sum(1 << c for c in kids) for kids in self.children)
        """Children of each variable as a bit mask."""
        reach = [0] * len(self.names)
        for v in self.topo:
            for parent in self.parents[v]:
                reach[v] |= reach[parent] | self.child_masks[parent]
        self.reach_masks = tuple(reach)
        """The children of each variable's ancestors as a bit mask: where the sub-network
        above a variable meets the rest of the network (``plans.build``, step 2)."""
        self.source_mask = sum(1 << v for v in self.sources)
        """Data nodes as a bit mask."""
        self._transposed: dict[tuple[int, tuple[int, ...]], FloatArray] = {}
        self.factors: dict[int, Any] = {}
        """Evidence-free plan factors, shared by every plan of this version (``plans.build``)."""
        self.constants = ConstantMemo()
        """Evidence-independent contraction steps already computed (``SumProgram`` memo)."""
        self._independent: list[bool | None] = [None] * len(self.names)
        self.network_order: tuple[list[int], list[int]] | None = None
        """Each variable's position and weight in the network-wide elimination order (by
        id), once a question has needed it (``plans.network_order``)."""
        self.layouts: dict[tuple[int, int], Any] = {}
        """Observed-first layouts of CPTs and their factors, by variable and observed family
        (``plans.build``)."""
        self._mask_table: bytes | None = None

    @property
    def mask_table(self) -> bytes:
        """The variable sets pruning reads, as bit rows for the compiled ``_orders.prune``
        (built on the first question): the number of variables and of 64-bit words per
        row; each variable's lineage, ancestors, reach and family; the data nodes; the
        topological order and each variable's place in it."""
        table = self._mask_table
        if table is None:
            n = len(self.names)
            words = max(1, (n + 63) // 64)
            size = 8 * words
            rows = [
                mask.to_bytes(size, sys.byteorder)
                for masks in (
                    self.lineage_masks,
                    self.ancestor_masks,
                    self.reach_masks,
                    self.family_masks,
                    (self.source_mask,),
                )
                for mask in masks
            ]
            places = [self.topo_pos[v] for v in range(n)]
            table = self._mask_table = b"".join(
                [
                    array("q", [n, words]).tobytes(),
                    *rows,
                    array("q", self.topo).tobytes(),
                    array("q", places).tobytes(),
                ]
            )
        return table

    def transposed(self, var: int, perm: tuple[int, ...]) -> FloatArray:
        """CPT of ``var`` with axes permuted by ``perm``, C-contiguous (cached)."""
        key = (var, perm)
        array = self._transposed.get(key)
        if array is None:
            array = self._transposed[key] = np.ascontiguousarray(self.cpts[var].transpose(perm))
        return array

    def id(self, name: str) -> int:
        """Id of variable ``name``; :class:`ModelError` if it is not in the network."""
        try:
            return self.index[name]
        except (KeyError, TypeError):
            raise ModelError(
                f"network {self.net.name!r} has no variable {name!r}; "
                + unknown("variable", name, self.names)
            ) from None

    def state(self, var: int, value: object) -> int:
        """Index of state ``value`` (a name or an index) of variable ``var``."""
        try:
            return self.lookup[var][value]  # type: ignore[index]
        except (KeyError, TypeError):
            pass
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            if 0 <= int(value) < self.card[var]:
                return int(value)
        raise InputError(
            f"variable {self.names[var]!r} has no state {value!r}; "
            + unknown("state", value, self.states[var])
        )

    def independent_parents(self, var: int) -> bool:
        """Whether the parents of ``var`` are independent when nothing is observed.

        They are when no two of them share an ancestor and none is an ancestor of another:
        every trail between two parents then passes a collider, so with no evidence they are
        d-separated (Post et al. 2016 §3.2; Pearl 1988) and ``P(parents) = Π P(parent)``.
        Found once per variable.
        """
        known = self._independent[var]
        if known is not None:
            return known
        seen = 0
        answer = True
        for parent in self.parents[var]:
            family = self.lineage_masks[parent]
            if seen & family:
                answer = False
                break
            seen |= family
        self._independent[var] = answer
        return answer

    def table(self, var: int, evidence: Mapping[str, str]) -> FloatArray:
        """CPT of ``var``: stored, or asked of its data source with the query's evidence."""
        source = self.sources.get(var)
        if source is None:
            return self.cpts[var]
        shape = (self.card[var], *(self.card[p] for p in self.parents[var]))
        raw: npt.ArrayLike = source(evidence)
        parent_names: Sequence[str] = [self.names[p] for p in self.parents[var]]
        return checked_cpt(self.names[var], raw, shape, parent_names, self.net)

    def evidence_names(self, evidence: Mapping[int, int]) -> dict[str, str]:
        """Evidence as ``{variable name: state name}`` (what data sources receive)."""
        return {self.names[v]: self.states[v][s] for v, s in evidence.items()}


_BINARY_DIGITS = bytes.maketrans(b"01", b"\x00\x01")


def bits(mask: int) -> list[int]:
    """Ids of the set bits of ``mask`` (a variable set as a bit mask), ascending.

    The binary digits, lowest first, as bytes 0 and 1 select the ids from a count, all in
    C: a cold question lists a few relevant sets of dozens to hundreds of variables.
    """
    digits = format(mask, "b")[::-1].encode().translate(_BINARY_DIGITS)
    return list(compress(count(), digits))
