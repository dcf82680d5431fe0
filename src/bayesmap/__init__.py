"""bayesmap: Bayesian mapping and decision-making with sparse, noisy, local sensors.

Sub-packages
------------
bn
    Discrete Bayesian networks (Post et al. 2016, §2–3): model, exact inference,
    fixed-point arithmetic and XMLBIF/BIF/XBN files.
grid
    Occupancy grids with probability and entropy layers and ROS map export.
sensing
    Inverse sensor models as pure functions (IR, sonar) and opinion-pool fusion.
sonar
    Specular-reading rejection for sonar rings (ICINCO 2007 fragment).
rover
    The micro-rover's exploration and collision avoidance (Post et al. 2016, §4–5).
blackboard
    Hierarchical object mapping with a Bayesian blackboard (Fox & Prescott 2011).
sim
    Simulated worlds, robots and sensors.
experiments
    The paper experiments behind ``bayesmap reproduce``.
"""

from bayesmap.errors import (
    BayesmapError,
    ConfigError,
    FormatError,
    InputError,
    ModelError,
)

__version__ = "0.1.0"

__all__ = [
    "BayesmapError",
    "ConfigError",
    "FormatError",
    "InputError",
    "ModelError",
    "__version__",
]
