"""Two sonar models users know, as baselines for the ICINCO 2007 filter.

- :func:`thrun_inverse_model`: the ``inverse_range_sensor_model`` of Thrun, Burgard & Fox,
  *Probabilistic Robotics* (2005), Table 9.2, with log-odds ``l_occ = +0.4`` per hit and
  ``l_free = -0.4`` per miss;
- :func:`ros_sensor_model`: the sonar model of the ROS costmap ``range_sensor_layer``
  (``DLu/navigation_layers``, ``range_sensor_layer.cpp``: ``gamma``, ``delta``,
  ``sensor_model``), with its defaults ``phi = 1.2`` and the map resolution used as a
  fraction of the range; :func:`ros_bayes_update` is its cell update and cost quantisation.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray

__all__ = ["ROS_LETHAL", "ros_bayes_update", "ros_sensor_model", "thrun_inverse_model"]

ROS_LETHAL = 254
"""``costmap_2d::LETHAL_OBSTACLE``: the layer stores ``p`` as the cost ``(uchar)(p * 254)``."""


def thrun_inverse_model(
    z: npt.ArrayLike,
    r: npt.ArrayLike,
    phi: npt.ArrayLike,
    *,
    z_max: float,
    alpha: float,
    beta: float,
    l_occ: float = 0.4,
    l_free: float = -0.4,
) -> FloatArray:
    """Log-odds increment of Thrun et al. (2005) Table 9.2 ``inverse_range_sensor_model``.

    Parameters
    ----------
    z
        Measured range [m] (``z_max`` for no echo).
    r
        Distance of the cell centre from the sensor [m].
    phi
        Bearing of the cell centre off the beam axis [rad].
    z_max
        Maximum range [m].
    alpha
        Obstacle thickness [m].
    beta
        Full beam width [rad].
    l_occ, l_free
        Log-odds added for a hit and for a miss (``l_0 = 0``: prior 0.5).

    Returns
    -------
    The log-odds increment of each cell: ``l_occ``, ``l_free`` or 0.

    Examples
    --------
    >>> thrun_inverse_model(2.0, [1.0, 2.0, 3.0], 0.0, z_max=5.0, alpha=0.1, beta=0.4).tolist()
    [-0.4, 0.4, 0.0]
    """
    zz = np.asarray(z, dtype=np.float64)
    rr = np.asarray(r, dtype=np.float64)
    outside = (rr > np.minimum(z_max, zz + alpha / 2.0)) | (np.abs(np.asarray(phi)) > beta / 2.0)
    hit = (zz < z_max) & (np.abs(rr - zz) < alpha / 2.0)
    miss = rr <= zz
    out = np.where(hit, l_occ, np.where(miss, l_free, 0.0))
    return np.asarray(np.where(outside, 0.0, out))


def ros_sensor_model(
    r: npt.ArrayLike,
    phi: npt.ArrayLike,
    theta: npt.ArrayLike,
    *,
    max_angle: float,
    resolution: float,
    phi_v: float = 1.2,
) -> FloatArray:
    """``RangeSensorLayer::sensor_model``: the probability a reading gives a cell.

    ``lambda = delta(phi) · gamma(theta)`` with ``gamma = 1 - (theta / max_angle)²`` in the
    cone, ``delta = 1 - (1 + tanh(2 (phi - phi_v))) / 2``; with ``dr = resolution · r``,
    ``p = (1 - lambda) / 2`` before ``r - 2 dr``, a quadratic rise to the peak
    ``lambda / 2 + 1/2`` at ``r``, 1/2 beyond ``r + dr``.

    Parameters
    ----------
    r
        Measured range [m].
    phi
        Distance of the cell from the sensor [m].
    theta
        Bearing of the cell off the beam axis [rad].
    max_angle
        Half the field of view [rad].
    resolution
        Map resolution; the code uses it (unit-less) as a fraction of ``r``.
    phi_v
        The layer's ``phi`` parameter (default 1.2).
    """
    rr = np.asarray(r, dtype=np.float64)
    ph = np.asarray(phi, dtype=np.float64)
    th = np.asarray(theta, dtype=np.float64)
    gamma = np.where(np.abs(th) > max_angle, 0.0, 1.0 - (th / max_angle) ** 2)
    delta = 1.0 - (1.0 + np.tanh(2.0 * (ph - phi_v))) / 2.0
    lam = delta * gamma
    dr = resolution * rr
    rise = lam * 0.5 * ((ph - (rr - 2.0 * dr)) / dr) ** 2 + (1.0 - lam) * 0.5
    peak = lam * ((1.0 - 0.5 * ((rr - ph) / dr) ** 2) - 0.5) + 0.5
    out = np.where(
        ph < rr - 2.0 * dr,
        (1.0 - lam) * 0.5,
        np.where(ph < rr - dr, rise, np.where(ph < rr + dr, peak, 0.5)),
    )
    return np.asarray(np.where(ph >= 0.0, out, 0.5))


def ros_bayes_update(prior: npt.ArrayLike, sensor: npt.ArrayLike) -> FloatArray:
    """``RangeSensorLayer::update_cell``: Bayes' rule, then the cost quantisation.

    ``p' = s p0 / (s p0 + (1 - s)(1 - p0))``, stored as the cost ``(uchar)(p' · 254)`` and
    read back as ``cost / 254``.
    """
    p0 = np.asarray(prior, dtype=np.float64)
    s = np.asarray(sensor, dtype=np.float64)
    occ = s * p0
    denominator = occ + (1.0 - s) * (1.0 - p0)
    with np.errstate(invalid="ignore", divide="ignore"):
        new = np.where(denominator > 0.0, occ / denominator, p0)
    return np.asarray(np.floor(new * ROS_LETHAL) / ROS_LETHAL)
