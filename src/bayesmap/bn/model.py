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
import math
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from bayesmap._typing import CPT, FloatArray, IntArray
from bayesmap.bn.suggest import unknown
from bayesmap.bn.tables import SUM_TOLERANCE as SUM_TOLERANCE
from bayesmap.bn.tables import WARN_TOLERANCE as WARN_TOLERANCE
from bayesmap.bn.tables import CPTNormalisationWarning as CPTNormalisationWarning
from bayesmap.bn.tables import DataSource as DataSource
from bayesmap.bn.tables import checked_cpt
from bayesmap.bn.tuning import TUNING, Tuning
from bayesmap.errors import ConfigError, InputError, ModelError

if TYPE_CHECKING:  # the engine and each feature's module load on first use (issue 15 item 5)
    from bayesmap._rng import RNGLike
    from bayesmap.bn.fixed_point import FixedResult, QFormat
    from bayesmap.bn.inference import BatchEvidence, Engine, Evidence
    from bayesmap.bn.learning import FitReport, Prior
    from bayesmap.bn.propositions import Proposition
    from bayesmap.bn.soft import Likelihoods, Shadow

_MAX_SHADOWS = 32
"""Shadow networks kept for soft evidence (one per set of softly observed variables)."""


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
                f"variable {self.name!r} has {len(self.states)} states; "
                f"index {state} is out of range"
            )
        try:
            return self.states.index(str(state))
        except ValueError:
            raise ModelError(
                f"variable {self.name!r} has no state {state!r}; "
                + unknown("state", state, self.states)
            ) from None


class BayesNet:
    """A discrete Bayesian network, built in code or read from a file.

    Parameters
    ----------
    name
        The network's name (written to files).
    tuning
        Where the inference engine switches between equally exact ways to answer
        (:class:`~bayesmap.bn.tuning.Tuning`; the measured defaults if not given).

    Examples
    --------
    >>> net = BayesNet("rain")
    >>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    >>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
    >>> net.cpt("Wet").shape
    (2, 2)
    """

    def __init__(self, name: str = "network", *, tuning: Tuning = TUNING) -> None:
        self.name = name
        self._variables: dict[str, Variable] = {}
        self.properties: dict[str, str] = {}
        self._version = 0
        self._tuning = tuning
        self._shadows: dict[tuple[str, ...], Shadow] = {}
        self._counts: list[FloatArray] | None = None
        self._counts_version = -1

    @property
    def tuning(self) -> Tuning:
        """The inference engine's tuning; setting it drops the engine's caches."""
        return self._tuning

    @tuning.setter
    def tuning(self, tuning: Tuning) -> None:
        self._tuning = tuning
        self.__dict__.pop("_engine", None)
        self._shadows.clear()

    @cached_property
    def _engine(self) -> Engine:
        """The inference engine with its caches, built by the first question.

        Its modules load then too, so ``import bayesmap.bn`` and a program that only
        builds, reads or writes networks never load them (issue 15, fast start).
        """
        from bayesmap.bn.inference import Engine

        return Engine(self, self._tuning)

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
            raise ModelError(
                f"network {self.name!r} has no variable {name!r}; "
                + unknown("variable", name, self._variables)
            ) from None

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
            else checked_cpt(name, cpt, shape, parent_tuple, self, states=state_tuple)
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
        table = checked_cpt(name, cpt, shape, variable.parents, self)
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
            table = checked_cpt(child, cpt, shape, new_parents, self)
        table.setflags(write=False)
        variable.parents = new_parents
        variable.cpt = table
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

    # --------------------------------------------------------------- questions
    def posterior(
        self,
        target: str,
        evidence: Evidence | None = None,
        *,
        soft: Likelihoods | None = None,
        fixed_point: QFormat | str | None = None,
    ) -> dict[str, float]:
        """Exact ``P(target | evidence)`` (Post et al. 2016 eqs. 22–25).

        Evidence may be on any variables. Barren and d-separated parts are pruned, and the
        contraction order is cached per pattern of observed variables; where the paper's
        ancestral recursion (eq. 27) is exact it is used instead (see
        :meth:`ancestral_posterior`).

        Parameters
        ----------
        target
            The queried variable.
        evidence
            Observed values ``{variable: state name or index}``.
        soft
            Soft (likelihood) evidence ``{variable: weight per state}``, e.g. a sensor's
            ``P(reading | state)``; only ratios matter (see :mod:`bayesmap.bn.soft`).
        fixed_point
            Compute in this Q-format (``"Q16.16"``, ``"Q8.24"``, ...) with integer
            arithmetic, as the rover's embedded engine does; see :meth:`posterior_fixed`
            for the error bound.

        Returns
        -------
        dict
            ``{state: probability}`` in state order, summing to 1.

        Raises
        ------
        ModelError
            Unknown variable.
        InputError
            Unknown state, or evidence of probability zero.

        Examples
        --------
        >>> net = BayesNet("rain")
        >>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
        >>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"],
        ...                      cpt=[[0.9, 0.1], [0.1, 0.9]])
        >>> round(net.posterior("Rain", {"Wet": "yes"})["yes"], 4)
        0.6923
        >>> round(net.posterior("Rain", soft={"Wet": [0.2, 0.6]})["yes"], 4)
        0.3684
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.posterior(target, hard, fixed_point=fixed_point)
        if fixed_point is not None:
            values = self.posterior_fixed(target, evidence, fixed_point).values
        else:
            values = self._engine.posterior(target, evidence or {})
        return dict(zip(self.variable(target).states, values.tolist(), strict=True))

    def posterior_batch(
        self,
        target: str,
        evidence: BatchEvidence,
        *,
        columns: Sequence[str] | None = None,
        soft: Mapping[str, npt.ArrayLike] | None = None,
    ) -> Any:
        """``P(target | case)`` for many evidence cases: an ``(n_cases, n_states)`` array.

        ``evidence`` is an ``(n_cases, n_columns)`` integer array of state indices (−1 =
        unobserved; columns are ``columns`` or all variables in network order), a list
        of ``{variable: state}`` mappings, or a pandas DataFrame with one column per
        observed variable (state names or indices, blanks unobserved) — then the answer is
        a DataFrame too, one column ``"target=state"`` per state, rows labelled alike (see
        :mod:`bayesmap.bn.cases`). Cases observing the same variables are answered by one
        contraction with a leading case axis. ``soft`` gives soft evidence per case,
        ``{variable: (n_cases, n_states) weights}`` (a row of ones: no information).

        Examples
        --------
        >>> import pandas as pd
        >>> net = BayesNet("rain")
        >>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
        >>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"],
        ...                      cpt=[[0.9, 0.1], [0.1, 0.9]])
        >>> net.posterior_batch("Rain", pd.DataFrame({"Wet": ["yes", None]})).round(4)
           Rain=no  Rain=yes
        0   0.3077    0.6923
        1   0.8000    0.2000
        """
        if _is_frame(evidence):
            if columns is not None or soft:
                raise InputError("posterior_batch: a DataFrame names its own columns; no soft")
            from bayesmap.bn.cases import posterior_frame

            return posterior_frame(self, evidence, [target])
        return self._engine.posterior_batch(target, evidence, columns=columns, soft=soft)

    def joint_posterior(
        self,
        targets: Sequence[str],
        evidence: Evidence | None = None,
        *,
        soft: Likelihoods | None = None,
        fixed_point: QFormat | str | None = None,
    ) -> FloatArray:
        """Exact joint ``P(targets | evidence)``: one array axis per target, in the given order.

        ``soft`` adds soft evidence as in :meth:`posterior`. With ``fixed_point``, computed
        in that Q-format (see :meth:`joint_posterior_fixed`).
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.joint_posterior(targets, hard, fixed_point=fixed_point)
        if fixed_point is not None:
            return self.joint_posterior_fixed(targets, evidence, fixed_point).values
        return self._engine.joint_posterior(list(targets), evidence or {})

    def posteriors(
        self,
        evidence: Evidence | None = None,
        *,
        soft: Likelihoods | None = None,
        fixed_point: QFormat | str | None = None,
    ) -> dict[str, dict[str, float]]:
        """Every unobserved variable's posterior, ``{variable: {state: probability}}``.

        One contraction of the network and its reverse give all of them at once (the
        two-pass scheme of :mod:`bayesmap.bn.marginals`), exact like :meth:`posterior`.
        ``soft`` adds soft evidence; with ``fixed_point`` each posterior is computed by
        :meth:`posterior_fixed` in turn.

        Examples
        --------
        >>> net = BayesNet("rain")
        >>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
        >>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"],
        ...                      cpt=[[0.9, 0.1], [0.1, 0.9]])
        >>> {k: round(v["yes"], 4) for k, v in net.posteriors({"Wet": "yes"}).items()}
        {'Rain': 0.6923}
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            answers = net.posteriors(hard, fixed_point=fixed_point)
            return {name: answers[name] for name in self.variables if name in answers}
        evidence = evidence or {}
        if fixed_point is not None:
            observed = {self._engine.compiled.id(name) for name in evidence}
            return {
                name: self.posterior(name, evidence, fixed_point=fixed_point)
                for v, name in enumerate(self.variables)
                if v not in observed
            }
        names = self.variables
        return {
            names[v]: dict(zip(self.states(names[v]), values.tolist(), strict=True))
            for v, values in self._engine.posteriors(evidence).items()
        }

    def posteriors_batch(
        self,
        evidence: BatchEvidence,
        *,
        columns: Sequence[str] | None = None,
        targets: Sequence[str] | None = None,
    ) -> dict[str, FloatArray]:
        """:meth:`posteriors` for many cases: ``{variable: (n_cases, n_states) array}`` of
        every variable, or of ``targets`` (observed variables one-hot); evidence as in
        :meth:`posterior_batch` (arrays or mappings)."""
        names = self.variables
        answers = self._engine.posteriors_batch(evidence, columns, targets)
        return {names[v]: values for v, values in answers.items()}

    def sample(self, n: int = 1, *, rng: RNGLike = None) -> IntArray:
        """``n`` independent draws of the joint distribution (forward sampling, eq. 8).

        Returns an ``(n, len(variables))`` array of state indices, columns in
        :attr:`variables` order — the batch layout :meth:`posterior_batch` takes. A data
        node's table is asked of its source with no evidence.

        Examples
        --------
        >>> net = BayesNet("rain")
        >>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
        >>> net.sample(5, rng=0).shape
        (5, 1)
        """
        from bayesmap._rng import as_generator  # numpy.random loads only for sampling
        from bayesmap.bn.sampling import forward_sample

        return forward_sample(self._engine.compiled, n, rng=as_generator(rng))

    def probability_of_evidence(self, evidence: Evidence | None = None) -> float:
        """``P(evidence)``, the normaliser Σ of Post et al. 2016 eq. 24."""
        return self._engine.probability_of_evidence(evidence or {})

    def posterior_fixed(
        self,
        target: str,
        evidence: Evidence | None = None,
        fixed_point: QFormat | str = "Q16.16",
        *,
        soft: Likelihoods | None = None,
    ) -> FixedResult:
        """``P(target | evidence)`` in Q-format integer arithmetic, with a guaranteed error bound.

        Returns a :class:`~bayesmap.bn.fixed_point.FixedResult` (raw integers, values and
        the bound on ``|value − exact|`` of each state). Soft evidence is quantised like a
        CPT column (its largest weight scaled to 1).
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.posterior_fixed(target, hard, fixed_point)
        return self._engine.fixed_posterior(target, evidence or {}, _qformat(fixed_point))

    def joint_posterior_fixed(
        self,
        targets: Sequence[str],
        evidence: Evidence | None = None,
        fixed_point: QFormat | str = "Q16.16",
        *,
        soft: Likelihoods | None = None,
    ) -> FixedResult:
        """:meth:`joint_posterior` in Q-format integer arithmetic, with a guaranteed bound."""
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.joint_posterior_fixed(targets, hard, fixed_point)
        q = _qformat(fixed_point)
        return self._engine.fixed_joint_posterior(list(targets), evidence or {}, q)

    def posterior_batch_fixed(
        self,
        target: str,
        evidence: BatchEvidence,
        fixed_point: QFormat | str = "Q16.16",
        *,
        columns: Sequence[str] | None = None,
        soft: Mapping[str, npt.ArrayLike] | None = None,
    ) -> FixedResult:
        """:meth:`posterior_batch` in Q-format integer arithmetic, with error bounds.

        ``soft`` gives soft evidence per case, ``{variable: (n_cases, n_states) weights}``,
        as in :meth:`posterior_batch`; each case's weights are scaled to a largest weight of
        1 and quantised like a CPT, so the bound covers their rounding too.
        """
        q = _qformat(fixed_point)
        return self._engine.fixed_posterior_batch(target, evidence, q, columns=columns, soft=soft)

    def map(
        self,
        evidence: Evidence | None = None,
        *,
        soft: Likelihoods | None = None,
        fixed_point: QFormat | str | None = None,
    ) -> tuple[dict[str, str], float]:
        """MAP/MPE over all unobserved variables (Post et al. 2016 eq. 13), by max-product.

        A true joint maximisation: the returned assignment maximises ``P(x ∩ e)`` jointly,
        which per-variable arg-maxes of the marginals need not do.

        Returns
        -------
        tuple
            ``({variable: state}, P(assignment | evidence))``. With ``fixed_point``, the
            max-product runs in that Q-format (ties broken by the lowest state index).
            ``soft`` adds soft evidence as in :meth:`posterior`.
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.map(hard, fixed_point=fixed_point)
        if fixed_point is not None:
            assignment, result = self.map_fixed(evidence, fixed_point)
            return assignment, float(result.values)
        return self._engine.mpe(evidence or {})

    def map_fixed(
        self,
        evidence: Evidence | None = None,
        fixed_point: QFormat | str = "Q16.16",
        *,
        soft: Likelihoods | None = None,
    ) -> tuple[dict[str, str], FixedResult]:
        """:meth:`map` by max-product in Q-format integers; ``P(x | e)`` as a 0-d
        :class:`~bayesmap.bn.fixed_point.FixedResult` whose bound covers both the exact
        probability of the returned assignment and the exact maximum."""
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.map_fixed(hard, fixed_point)
        return self._engine.fixed_mpe(evidence or {}, _qformat(fixed_point))

    def marginal_map(
        self,
        variables: Sequence[str],
        evidence: Evidence | None = None,
        *,
        soft: Likelihoods | None = None,
        fixed_point: QFormat | str | None = None,
    ) -> tuple[dict[str, str], float]:
        """Marginal MAP over ``variables`` (Post et al. 2016 eq. 14): sum out the rest, then max.

        Returns ``({variable: state}, P(assignment | evidence))``; exact, or with
        ``fixed_point`` in that Q-format (see :meth:`marginal_map_fixed`). ``soft`` adds
        soft evidence as in :meth:`posterior`.
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.marginal_map(variables, hard, fixed_point=fixed_point)
        if fixed_point is not None:
            assignment, result = self.marginal_map_fixed(variables, evidence, fixed_point)
            return assignment, float(result.values)
        return self._engine.marginal_map(list(variables), evidence or {})

    def marginal_map_fixed(
        self,
        variables: Sequence[str],
        evidence: Evidence | None = None,
        fixed_point: QFormat | str = "Q16.16",
        *,
        soft: Likelihoods | None = None,
    ) -> tuple[dict[str, str], FixedResult]:
        """:meth:`marginal_map` in Q-format integers; ``P(x | e)`` as a 0-d
        :class:`~bayesmap.bn.fixed_point.FixedResult` (bound as in :meth:`map_fixed`)."""
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.marginal_map_fixed(variables, hard, fixed_point)
        q = _qformat(fixed_point)
        return self._engine.fixed_marginal_map(list(variables), evidence or {}, q)

    def probability(
        self,
        proposition: Proposition | str,
        evidence: Evidence | None = None,
        *,
        given: Proposition | str | None = None,
        soft: Likelihoods | None = None,
        fixed_point: QFormat | str | None = None,
    ) -> float:
        """``P(proposition | given, evidence)`` of a logical proposition (Post et al. 2016 §2.4).

        Build it with :class:`~bayesmap.bn.propositions.V` (``(V("A") == "yes") & ~(V("B")
        == "no")``) or pass a string such as ``"A=yes and not B=no"``. ``given`` is a
        condition, itself a proposition: ``P(p | g, e) = P(p ∧ g | e) / P(g | e)``. With
        ``fixed_point``, computed in that Q-format (see :meth:`probability_fixed`).

        Examples
        --------
        >>> net = BayesNet("rain")
        >>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
        >>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"],
        ...                      cpt=[[0.9, 0.1], [0.1, 0.9]])
        >>> round(net.probability("Rain=yes", given="Wet=yes"), 4)
        0.6923
        """
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.probability(proposition, hard, given=given, fixed_point=fixed_point)
        if fixed_point is not None:
            answer = self.probability_fixed(proposition, evidence, fixed_point, given=given)
            return float(answer.values)
        return self._engine.probability(proposition, evidence or {}, given)

    def probability_fixed(
        self,
        proposition: Proposition | str,
        evidence: Evidence | None = None,
        fixed_point: QFormat | str = "Q16.16",
        *,
        given: Proposition | str | None = None,
        soft: Likelihoods | None = None,
    ) -> FixedResult:
        """:meth:`probability` in Q-format integers, as a 0-d
        :class:`~bayesmap.bn.fixed_point.FixedResult` with its guaranteed bound."""
        if soft:
            net, hard = self._with_soft(evidence, soft)
            return net.probability_fixed(proposition, hard, fixed_point, given=given)
        q = _qformat(fixed_point)
        return self._engine.fixed_probability(proposition, evidence or {}, q, given)

    # --------------------------------------------------------------- learning
    def fit(
        self,
        data: Any,
        *,
        columns: Sequence[str] | None = None,
        prior: Prior = "none",
        equivalent_sample_size: float = 1.0,
        max_iterations: int = 100,
        tol: float = 1e-8,
    ) -> FitReport:
        """Learn every CPT from data (see :mod:`bayesmap.bn.learning`), keeping the structure.

        Parameters
        ----------
        data
            Cases: a pandas DataFrame (one column per variable, state names or indices,
            blanks missing), an ``(n_cases, n_columns)`` integer array (−1 missing) or
            array of state names, or a list of ``{variable: state}`` mappings. Variables
            without a column are hidden: learned by EM.
        columns
            Variable of each array column (default: all, in network order).
        prior
            ``"none"``: maximum likelihood; ``"bdeu"``: BDeu pseudo-counts; ``"cpt"``: the
            current CPTs as the prior (the paper's map learning).
        equivalent_sample_size
            Weight of the prior in cases (``"bdeu"``, ``"cpt"``).
        max_iterations, tol
            EM stops after ``max_iterations`` or when the log-likelihood gains less than
            ``tol`` per case.

        Returns
        -------
        FitReport
            Cases, EM iterations, log-likelihood and convergence.

        Examples
        --------
        >>> import pandas as pd
        >>> net = BayesNet("rain")
        >>> _ = net.add_variable("Rain", ["no", "yes"])
        >>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"])
        >>> data = pd.DataFrame(
        ...     {"Rain": ["no", "no", "yes", "no"], "Wet": ["no", "yes", "yes", None]}
        ... )
        >>> report = net.fit(data)
        >>> net.cpt("Rain").round(3).tolist(), report.iterations > 0
        ([0.75, 0.25], True)
        """
        from bayesmap.bn.learning import (
            FitReport,
            complete_log_likelihood,
            family_counts,
            pseudo_counts,
        )

        if max_iterations < 1:
            raise ConfigError(f"max_iterations must be at least 1, got {max_iterations}")
        table, n_cases = self._learning_table(data, columns)
        compiled = self._engine.compiled
        learned = [v for v in range(len(compiled.names)) if v not in compiled.sources]
        pseudo = [pseudo_counts(compiled.cpts[v], prior, equivalent_sample_size) for v in learned]
        if np.all(table[:, learned] >= 0):
            cards = [tuple(compiled.cpts[v].shape) for v in learned]
            counts = [
                family_counts(table, (v, *compiled.parents[v]), c, None)
                for v, c in zip(learned, cards, strict=True)
            ]
            tables = self._set_learned(learned, counts, pseudo)
            log_likelihood = complete_log_likelihood(counts, tables)
            self._keep_counts(counts, pseudo)
            return FitReport(float(n_cases), 0, log_likelihood, True)
        unique, weights = np.unique(table, axis=0, return_counts=True)
        ids = list(range(len(compiled.names)))
        previous = -math.inf
        log_likelihood, converged, iteration = -math.inf, False, 0
        for iteration in range(1, max_iterations + 1):  # noqa: B007 (the report says it)
            expected, log_likelihood = self._engine.expected_counts(
                unique, ids, weights.astype(np.float64)
            )
            counts = [expected[v] for v in learned]
            self._set_learned(learned, counts, pseudo)
            if log_likelihood - previous <= tol * n_cases:
                converged = True
                break
            previous = log_likelihood
        self._keep_counts(counts, pseudo)
        return FitReport(float(n_cases), iteration, log_likelihood, converged)

    def update(
        self,
        cases: Any,
        *,
        columns: Sequence[str] | None = None,
        equivalent_sample_size: float = 1.0,
    ) -> None:
        """Online Bayesian learning: add the counts of ``cases`` and renormalise every CPT.

        The counts accumulate from call to call (and from :meth:`fit`); the first update —
        or the first after a CPT was changed by hand — starts from the current CPTs worth
        ``equivalent_sample_size`` cases (the ``"cpt"`` prior of :meth:`fit`), so that
        updating case by case gives the same CPTs as one Bayesian fit of all cases.
        Missing values count by their expectation under the CPTs before the update (one
        E-step: the sequential updating of Spiegelhalter & Lauritzen 1990).
        ``cases`` takes the forms :meth:`fit` takes.
        """
        from bayesmap.bn.learning import family_counts, pseudo_counts

        table, _ = self._learning_table(cases, columns)
        compiled = self._engine.compiled
        learned = [v for v in range(len(compiled.names)) if v not in compiled.sources]
        if self._counts is None or self._counts_version != self._version:
            self._counts = [
                pseudo_counts(compiled.cpts[v], "cpt", equivalent_sample_size) for v in learned
            ]
        if np.all(table[:, learned] >= 0):
            counts = [
                family_counts(table, (v, *compiled.parents[v]), compiled.cpts[v].shape, None)
                for v in learned
            ]
        else:
            unique, weights = np.unique(table, axis=0, return_counts=True)
            expected, _ = self._engine.expected_counts(
                unique, list(range(len(compiled.names))), weights.astype(np.float64)
            )
            counts = [expected[v] for v in learned]
        totals = [a + n for a, n in zip(self._counts, counts, strict=True)]
        self._set_learned(learned, totals, [np.zeros(t.shape) for t in totals])
        self._counts = totals
        self._counts_version = self._version

    def _learning_table(self, data: Any, columns: Sequence[str] | None) -> tuple[IntArray, int]:
        """Cases as an ``(n_cases, n_variables)`` index array over every variable (−1 missing)."""
        if not _is_frame(data) and not isinstance(data, list):
            array = np.asarray(data)
            if array.dtype.kind in "OUS":
                import pandas as pd

                data = pd.DataFrame(array, columns=list(columns or self.variables))
                columns = None
        if _is_frame(data):
            from bayesmap.bn.cases import case_array

            table, names = case_array(self, data)
            cols = [self._engine.compiled.id(n) for n in names]
        else:
            table, cols = self._engine.batch_array(data, columns)
        if table.shape[0] == 0:
            raise InputError("no cases to learn from")
        full = np.full((table.shape[0], len(self)), -1, dtype=np.int64)
        full[:, cols] = table
        return full, table.shape[0]

    def _set_learned(
        self, learned: list[int], counts: list[FloatArray], pseudo: list[FloatArray]
    ) -> list[CPT]:
        from bayesmap.bn.learning import estimate

        names = self.variables
        tables = []
        for v, n, a in zip(learned, counts, pseudo, strict=True):
            table = estimate(n, a, self.cpt(names[v]))
            self.set_cpt(names[v], table)
            tables.append(self.cpt(names[v]))
        return tables

    def _keep_counts(self, counts: list[FloatArray], pseudo: list[FloatArray]) -> None:
        """Remember the fitted counts (with pseudo-counts) for later :meth:`update` calls."""
        self._counts = [n + a for n, a in zip(counts, pseudo, strict=True)]
        self._counts_version = self._version

    def _with_soft(
        self, evidence: Evidence | None, soft: Likelihoods
    ) -> tuple[BayesNet, dict[str, str | int]]:
        """The shadow network to ask (see :mod:`bayesmap.bn.soft`) and the evidence to ask it.

        One shadow is kept per set of softly observed variables while the network is
        unchanged, so repeated questions reuse its plans.
        """
        from bayesmap.bn.soft import Shadow, likelihood

        names = tuple(sorted(soft))
        weights = {x: likelihood(x, self.states(x), soft[x]) for x in names}
        shadow = self._shadows.get(names)
        if shadow is None or shadow.version != self._version:
            if len(self._shadows) >= _MAX_SHADOWS:
                self._shadows.pop(next(iter(self._shadows)))
            shadow = self._shadows[names] = Shadow(self, names)
        return shadow.net, shadow.evidence(evidence or {}, weights)

    def class_ratio(
        self, variable: str, state_1: str, state_2: str, evidence: Evidence | None = None
    ) -> float:
        """``P(state_1, e) / P(state_2, e)``, the class ratio of Post et al. 2016 eq. 6.

        Computed exactly by inference, so it holds on any network; on a naive-Bayes
        network it equals :func:`bayesmap.bn.naive_bayes.class_ratio`.
        """
        compiled = self._engine.compiled
        index = compiled.id(variable)
        a, b = compiled.state(index, state_1), compiled.state(index, state_2)
        values = self._engine.posterior(variable, evidence or {})
        if values[b] == 0.0:
            if values[a] == 0.0:
                raise InputError(
                    f"class_ratio: {variable}={state_1!r} and {variable}={state_2!r} both have "
                    "probability zero given the evidence"
                )
            return float("inf")
        return float(values[a] / values[b])

    def ancestral_posterior(
        self, target: str, evidence: Evidence | None = None
    ) -> dict[str, float]:
        """The paper's recursive ancestral query (Post et al. 2016 eqs. 10, 26–27).

        Walks up from ``target`` computing each ancestor's distribution from its parents'
        (saving them, as the paper does), treating observed ancestors as point masses. It
        ignores evidence on non-ancestors and multiplies parents' distributions as if
        independent, so it is exact only when :meth:`ancestral_is_exact` says so (then
        :meth:`posterior` uses it automatically); otherwise it is the paper's
        approximation.
        """
        values = self._engine.ancestral_posterior(target, evidence or {})
        return dict(zip(self.variable(target).states, values.tolist(), strict=True))

    def ancestral_is_exact(self, target: str, evidence: Evidence | None = None) -> bool:
        """Whether :meth:`ancestral_posterior` is exact: all evidence on visited ancestors,
        and the visited ancestors form a polytree."""
        return self._engine.ancestral_is_exact(target, evidence or {})

    def copy(self) -> BayesNet:
        """A copy sharing no mutable state (CPT arrays are read-only and shared)."""
        other = BayesNet(self.name, tuning=self.tuning)
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
        raise ModelError(
            f"flat table has {values.size} values; shape {tuple(shape)} needs {int(np.prod(shape))}"
        )
    return np.asarray(values.reshape(tuple(shape), order="F"))


def _qformat(fixed_point: QFormat | str) -> QFormat:
    """The Q-format named by ``fixed_point`` (its module loads with the first such question)."""
    from bayesmap.bn.fixed_point import QFormat

    return QFormat.parse(fixed_point)


def _is_frame(value: object) -> bool:
    """Whether ``value`` is a pandas DataFrame (without importing pandas)."""
    pandas = sys.modules.get("pandas")
    return pandas is not None and isinstance(value, pandas.DataFrame)


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
