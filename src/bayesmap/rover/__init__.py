"""The micro-rover's mapping and decisions (Post et al. 2016 §4): IR mapping on an occupancy
grid, entropy-driven exploration, collision avoidance, and the decision network of Fig. 8.

- :mod:`~bayesmap.rover.decisions`: eqs. 38–43 as pure functions (the ground truth);
- :mod:`~bayesmap.rover.network`: the Fig. 8 Bayesian network asked for the heading;
- :mod:`~bayesmap.rover.mapping`: readings → probability and entropy maps (eqs. 31–37);
- :mod:`~bayesmap.rover.targets`: the paper's target rule and a frontier baseline;
- :mod:`~bayesmap.rover.explorer`: one sense–map–decide cycle.
"""

from bayesmap.rover.explorer import Decision, Explorer
from bayesmap.rover.params import RoverParams
from bayesmap.rover.targets import EntropyTarget, FrontierTarget

__all__ = ["Decision", "EntropyTarget", "Explorer", "FrontierTarget", "RoverParams"]
