"""Hierarchical object mapping with a Bayesian blackboard (Fox & Prescott 2011).

Tables cause legs, legs cause whisker contacts ("shapelets"); a blackboard of hypotheses is
explored by the annealed Metropolis–Hastings proposals of Algorithm 1, and each time step
returns the MAP set of tables (eq. 18). See docs/blackboard.md.

Modules: :mod:`~bayesmap.blackboard.params` (constants), :mod:`~.densities` (the factors,
eqs. 4–24), :mod:`~.hypotheses` (tables, legs, the blackboard), :mod:`~.blanket` (moves and
Markov-blanket ratios), :mod:`~.proposals` (the Q's), :mod:`~.kernel` (one sweep),
:mod:`~.annealing` (schedule and driver), :mod:`~.scoring` (eq. 14 from scratch),
:mod:`~.spatial_hash`, :mod:`~.mapper` (:class:`TableMapper`).
"""

from bayesmap.blackboard.annealing import AnnealResult, Snapshot, anneal, schedule
from bayesmap.blackboard.hypotheses import NULL, Blackboard, Leg, Table, make_leg, make_table
from bayesmap.blackboard.kernel import SamplerState, StepInfo, accept, step
from bayesmap.blackboard.mapper import StepResult, TableMapper, check_shapelets, prune
from bayesmap.blackboard.params import BlackboardParams
from bayesmap.blackboard.scoring import log_joint

__all__ = [
    "NULL",
    "AnnealResult",
    "Blackboard",
    "BlackboardParams",
    "Leg",
    "SamplerState",
    "Snapshot",
    "StepInfo",
    "StepResult",
    "Table",
    "TableMapper",
    "accept",
    "anneal",
    "check_shapelets",
    "log_joint",
    "make_leg",
    "make_table",
    "prune",
    "schedule",
    "step",
]
