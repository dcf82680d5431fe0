"""Fusing IR readings into map evidence: opinion pool and map update (Post et al. 2016 §4.2–4.4).

Each reading of ranger ``n`` gives, for every cell ``c`` near the rover, an opinion
``s[n, c]`` about an obstacle in ``c`` (eq. 32) and a weight ``w[n, c]`` in [0, 1]:

- cells along the beam closer than ``r - sigma_xy`` when the ranger has contact within
  ``r_max`` (closer than ``r_max`` otherwise) get the no-contact opinion ``eq. 32 (o = 0)``
  at their own distance ``R``, weighted by the beam's angular sensitivity
  ``exp(-(theta / w_r)^2)`` (the shape of eq. 34);
- with contact within ``r_max``, cells around the sensed point get the contact opinion
  ``eq. 32 (o = 1)`` at the read range, weighted by a 2-D Gaussian of the positional
  uncertainty ``sigma_xy`` (the spread of §4.3).

The rangers' opinions are pooled linearly (eq. 35) and the pooled evidence updates the map
by Bayes' rule (eq. 36). These choices fill gaps of the paper; docs/rover.md lists them.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.sensing.ir import beta_r, sensor_posterior

PROBABILITY_CLAMP = (1e-3, 1.0 - 1e-3)
"""Map probabilities are kept inside this interval so that evidence can always reverse them."""


def opinion_pool(opinions: npt.ArrayLike, weights: npt.ArrayLike, *, axis: int = 0) -> FloatArray:
    """Linear opinion pool ``sum_n w_n s_n / sum_n w_n`` (Post et al. 2016 eq. 35).

    The paper weights each ranger's ``P(R | r, o, t)`` by its angular detection weight
    (eq. 34); the weights are normalised here so the pool is a probability. Where all
    weights are 0 the result is NaN.
    """
    s = np.asarray(opinions, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    total = w.sum(axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray((w * s).sum(axis=axis) / total)


def bayes_map_update(p_map: npt.ArrayLike, evidence: npt.ArrayLike, prior: float) -> FloatArray:
    """Map update ``P(O | R, x, t+1) = P(R | O, x, t) P(O, x, t) / P(R, x, t)`` (eq. 36).

    ``evidence`` is the inverse-sensor probability of an obstacle computed with the constant
    prior ``P(R)`` (eq. 32); dividing that prior out gives the likelihood ratio, so the update
    is ``odds' = odds(p_map) * odds(evidence) / odds(prior)``. Evidence equal to the prior
    leaves a cell unchanged. The result is clamped to :data:`PROBABILITY_CLAMP`.

    Examples
    --------
    >>> round(float(bayes_map_update(0.2, 0.2, 0.2)), 12)
    0.2
    >>> round(float(bayes_map_update(0.5, 0.8, 0.5)), 12)
    0.8
    """
    lo, hi = PROBABILITY_CLAMP
    p = np.clip(np.asarray(p_map, dtype=np.float64), lo, hi)
    s = np.clip(np.asarray(evidence, dtype=np.float64), lo, hi)
    odds = (p / (1.0 - p)) * (s / (1.0 - s)) * ((1.0 - prior) / prior)
    return np.asarray(np.clip(odds / (1.0 + odds), lo, hi))


def ir_cell_evidence(
    xc: npt.ArrayLike,
    yc: npt.ArrayLike,
    sensors: npt.ArrayLike,
    ranges: npt.ArrayLike,
    contacts: npt.ArrayLike,
    *,
    prior: float,
    r_max: float,
    beta_b: float,
    w_r: float,
    sigma_xy: float,
    reliability_floor: float = 0.5,
    above_noise: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Pooled obstacle evidence and its strength for cells at ``(xc, yc)`` [m].

    Parameters
    ----------
    xc, yc
        Cell centres, any matching shape ``S``.
    sensors
        ``(n, 3)`` sensor poses ``(x [m], y [m], theta [rad])`` in the map frame.
    ranges
        ``(n,)`` read ranges [m] (from :func:`bayesmap.sensing.ir.range_from_raw`).
    contacts
        ``(n,)`` contact flags ``o`` (eq. 33).
    prior
        ``P(R)``, the prior probability of an obstacle used by eq. 32.
    r_max, beta_b
        Parameters of eq. 31.
    w_r
        Angular sensitivity (angle of view) of a ranger [rad], eq. 34.
    sigma_xy
        Standard deviation of the 2-D Gaussian spread of a contact [m]. The spread covers
        only cells at least ``r - sigma_xy`` from the ranger, where its free evidence
        stops: a reading reports the nearest obstacle on its beam, so it says of the cells
        in front of that only that they are free (the Gaussian of §4.3 places the contact,
        it does not put obstacle evidence on the beam's own free part).
    reliability_floor
        ``beta_r`` below this is raised to it (the ``floor`` of
        :func:`~bayesmap.sensing.ir.beta_r`). The paper's ``beta_b = 0.2`` makes ``beta_r``
        fall below 1/2 beyond ~1.27 m, where eq. 32 would turn a contact into evidence of
        free space; the default floor of 1/2 makes such readings uninformative instead.
        Use 0 for the literal paper.
    above_noise
        ``(n,)`` readings above the noise level now (``r_raw > 2 sigma_r``), whether or not
        eq. 33 confirms them yet. Such a ranger's beam is free only up to ``r - sigma_xy``:
        the first reading of a new obstacle is not yet a contact, but neither is it
        evidence that the obstacle's cell is free (the paper would paint it free; ours).
        ``None``: the contact flags alone decide.

    Returns
    -------
    (evidence, strength)
        Arrays of shape ``S``: the pooled probability of an obstacle (eq. 35) and the
        largest weight any ranger gave the cell (0 = untouched). Feed
        ``prior + strength * (evidence - prior)`` to :func:`bayes_map_update`.
    """
    x = np.asarray(xc, dtype=np.float64)[..., None]
    y = np.asarray(yc, dtype=np.float64)[..., None]
    pose = np.atleast_2d(np.asarray(sensors, dtype=np.float64))
    r = np.asarray(ranges, dtype=np.float64).reshape(-1)
    o = np.asarray(contacts).astype(bool).reshape(-1)
    sx, sy, st = pose[:, 0], pose[:, 1], pose[:, 2]
    dx, dy = x - sx, y - sy
    distance = np.hypot(dx, dy)
    off_axis = np.angle(np.exp(1j * (np.arctan2(dy, dx) - st)))
    hit = o & (r <= r_max)
    seen = o if above_noise is None else np.asarray(above_noise).astype(bool).reshape(-1) | o
    free_limit = np.where(seen & (r <= r_max), r - sigma_xy, r_max)
    w_free = np.exp(-((off_axis / w_r) ** 2)) * (distance < free_limit)
    s_free = sensor_posterior(
        beta_r(distance, r_max=r_max, beta_b=beta_b, floor=reliability_floor), prior, 0
    )
    hx, hy = sx + r * np.cos(st), sy + r * np.sin(st)
    behind = distance >= r - sigma_xy  # a ranger reads the nearest obstacle: none in front
    w_hit = np.exp(-((x - hx) ** 2 + (y - hy) ** 2) / (2.0 * sigma_xy**2)) * hit * behind
    s_hit = sensor_posterior(
        beta_r(r, r_max=r_max, beta_b=beta_b, floor=reliability_floor), prior, 1
    )
    weight = np.maximum(w_free, w_hit)
    with np.errstate(invalid="ignore", divide="ignore"):
        opinion = np.where(weight > 0, (w_free * s_free + w_hit * s_hit) / (w_free + w_hit), prior)
    pooled = opinion_pool(opinion, weight, axis=-1)
    strength = weight.max(axis=-1)
    return np.asarray(np.where(strength > 0, pooled, prior)), np.asarray(strength)
