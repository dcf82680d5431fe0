"""Inverse sensor models as pure functions, and the fusion of their opinions.

- :mod:`~bayesmap.sensing.ir`: the IR ranger's Bernoulli model (Post et al. 2016 §4.2, eqs. 26–34);
- :mod:`~bayesmap.sensing.sonar`: the Elfes cone model; :mod:`~bayesmap.sensing.sonar_baselines`:
  the Thrun and ROS range-layer models it is compared with; :mod:`~bayesmap.sensing.sonar_rings`:
  Pioneer ring layouts;
- :mod:`~bayesmap.sensing.fusion`: opinion pools and Bayesian map updates.

The IR and sonar modules each have an ``angular_weight``: reach them through their module.
Names load on first use (:mod:`bayesmap._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bayesmap._lazy import lazy_exports

if TYPE_CHECKING:
    from bayesmap.sensing import fusion, ir, sonar, sonar_baselines, sonar_rings
    from bayesmap.sensing.fusion import bayes_map_update, opinion_pool
    from bayesmap.sensing.ir import (
        beta_r,
        fit_calibration,
        range_from_raw,
        raw_from_range,
        sensor_posterior,
    )
    from bayesmap.sensing.sonar import elfes_inverse_model, log_odds, reading_likelihood
    from bayesmap.sensing.sonar_baselines import ros_sensor_model, thrun_inverse_model

_EXPORTS = {
    "bayes_map_update": "fusion",
    "beta_r": "ir",
    "elfes_inverse_model": "sonar",
    "fit_calibration": "ir",
    "fusion": "fusion",
    "ir": "ir",
    "log_odds": "sonar",
    "opinion_pool": "fusion",
    "range_from_raw": "ir",
    "raw_from_range": "ir",
    "reading_likelihood": "sonar",
    "ros_sensor_model": "sonar_baselines",
    "sensor_posterior": "ir",
    "sonar": "sonar",
    "sonar_baselines": "sonar_baselines",
    "sonar_rings": "sonar_rings",
    "thrun_inverse_model": "sonar_baselines",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = [
    "bayes_map_update",
    "beta_r",
    "elfes_inverse_model",
    "fit_calibration",
    "fusion",
    "ir",
    "log_odds",
    "opinion_pool",
    "range_from_raw",
    "raw_from_range",
    "reading_likelihood",
    "ros_sensor_model",
    "sensor_posterior",
    "sonar",
    "sonar_baselines",
    "sonar_rings",
    "thrun_inverse_model",
]
