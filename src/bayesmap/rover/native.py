"""The rover's decision network run through generated C (Post et al. 2016 §3: bare C).

:func:`compiled_evaluator` compiles the cycle's question,
``P(Motors | IR_k, ProbabilityMap, Footprint)``, with :mod:`bayesmap.bn.codegen` and returns an
:data:`~bayesmap.rover.network.Evaluator` for :class:`~bayesmap.rover.explorer.Explorer`:
the data nodes' tables (sensor models, the map, the navigation goal) are read from the
explorer's network each cycle and handed to the C function, as the rover's firmware would.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from bayesmap.bn.codegen import generate
from bayesmap.bn.codegen.native import NativeNetwork
from bayesmap.rover.network import DecisionNetwork, Evaluator
from bayesmap.rover.params import RoverParams


def compiled_evaluator(
    params: RoverParams,
    arith: str = "double",
    directory: str | Path | None = None,
    flags: Sequence[str] = ("-O2",),
) -> Evaluator:
    """Generate, build (system C compiler) and load the decision network's C code.

    Parameters
    ----------
    params
        The rover's parameters (they fix the network's tables and sizes).
    arith
        ``"double"`` (headings as the float engine's), ``"float"``, ``"q16.16"``, ``"q8.24"``.
    directory
        Where to write and build the code (default: a temporary directory).
    flags
        Compiler flags besides the strict warnings.

    Raises
    ------
    ConfigError
        No C compiler, or the build failed.
    """
    decision = DecisionNetwork(params)
    code = generate(decision.net, ["Motors"], list(decision.observed), arith, name="rover_decision")
    return NativeNetwork(code, directory, flags).ask
