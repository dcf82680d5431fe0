"""Discrete Bayesian networks: model, forms, exact and fixed-point inference, file formats.

The engine of Post et al. 2016 (§2–3): build a :class:`BayesNet` in code or :func:`read` one
from XMLBIF/BIF/XBN/NET/XDSL/UAI, then ask it questions — :meth:`~BayesNet.posterior`,
:meth:`~BayesNet.joint_posterior`, :meth:`~BayesNet.posterior_batch`, :meth:`~BayesNet.map`,
:meth:`~BayesNet.marginal_map`, :meth:`~BayesNet.probability` of a proposition — exactly, or in
Q-format fixed point.

Examples
--------
>>> from bayesmap.bn import BayesNet, V
>>> net = BayesNet("rain")
>>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
>>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
>>> round(net.probability((V("Rain") == "yes") | (V("Wet") == "yes")), 3)
0.28
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from bayesmap.bn.model import BayesNet, NodeKind, Variable, cpt_from_flat

if TYPE_CHECKING:
    from bayesmap.bn.fixed_point import FixedResult, QFormat
    from bayesmap.bn.forms import discretised_gaussian, gaussian_cpt
    from bayesmap.bn.io import read, write
    from bayesmap.bn.naive_bayes import class_ratio
    from bayesmap.bn.propositions import Proposition, V, parse

_LAZY = {
    "FixedResult": "bayesmap.bn.fixed_point",
    "QFormat": "bayesmap.bn.fixed_point",
    "discretised_gaussian": "bayesmap.bn.forms",
    "gaussian_cpt": "bayesmap.bn.forms",
    "read": "bayesmap.bn.io",
    "write": "bayesmap.bn.io",
    "class_ratio": "bayesmap.bn.naive_bayes",
    "Proposition": "bayesmap.bn.propositions",
    "V": "bayesmap.bn.propositions",
    "parse": "bayesmap.bn.propositions",
}
"""Public names whose modules load on first use: the file formats (and the file plumbing
they need) cost more to import than the engine itself, and a program that builds its
network in code never reads one. The inference engine loads with a network's first
question (``BayesNet._engine``)."""


def __getattr__(name: str) -> Any:
    """Import a lazily exported name (:data:`_LAZY`) on first access (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'bayesmap.bn' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


__all__ = [
    "BayesNet",
    "FixedResult",
    "NodeKind",
    "Proposition",
    "QFormat",
    "V",
    "Variable",
    "class_ratio",
    "cpt_from_flat",
    "discretised_gaussian",
    "gaussian_cpt",
    "parse",
    "read",
    "write",
]
