"""Infrared ranger models of Post et al. 2016 (§4.1, §5.1): reliability, Bayes update, contact.

Symbols: ``R`` the distance from the rover to a map point [m]; ``r_max`` the ranger's maximum
range [m]; ``beta_b`` the base probability that a detection is correct; ``beta_r`` the
probability that the range sensor state is correct (eq. 31); ``o`` the contact flag (eq. 33);
``r_raw`` the 8-bit ADC reading and ``sigma_r`` its RMS noise [ADC units].
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import numpy.typing as npt
from scipy.optimize import OptimizeWarning, curve_fit

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.errors import InputError

R_MAX = 2.0
"""Maximum range of the Beaver's IR rangers [m] (§4.1, §5.1)."""

SIGMA_R = 2.777
"""RMS noise of the IR reading in 8-bit ADC units (§5.1)."""

RAW_FIT = (-7.933, 56.61, 0.07544)
"""First-order rational fit ``r_raw = (a r + b) / (r + c)`` of §5.1: ``(a, b, c)``."""

Calibration = tuple[float, float, float]
"""``(a, b, c)`` of the ADC fit ``r_raw = (a r + b) / (r + c)`` (§5.1), ``r`` in metres."""

RANGER_ANGLES = (math.radians(30.0), 0.0, -math.radians(30.0))
"""Mounting angles of the three rangers relative to the rover's heading [rad] (§4.2)."""

RANGER_OFFSET = 0.15
"""Distance of the rangers ahead of the rover's centre [m] (ours; the paper gives none)."""

W_R = 0.3
"""Angle of view ``w_r`` of a ranger [rad] (eq. 34; ours, the paper gives no value)."""


def beta_r(
    R: npt.ArrayLike, *, r_max: float = R_MAX, beta_b: float = 0.2, floor: float = 0.0
) -> FloatArray:
    """Probability that the range sensor state is correct at distance ``R`` [m].

    Inverse IR sensor model, Post et al. 2016 eq. 31:
    ``beta_b + (1 - beta_b) (r_max^2 - R^2)^2 / r_max^4`` for ``R <= r_max``, else ``beta_b``.
    It is 1 at the sensor and falls to ``beta_b`` at ``r_max``. Values below ``floor`` are
    raised to it (``floor = 1/2`` keeps eq. 32 from reversing evidence when ``beta_b < 1/2``;
    the default 0 is the literal paper).

    Examples
    --------
    >>> beta_r([0.0, 2.0, 5.0], beta_b=0.2).tolist()
    [1.0, 0.2, 0.2]
    >>> beta_r([0.0, 2.0], beta_b=0.2, floor=0.5).tolist()
    [1.0, 0.5]
    """
    distance = np.asarray(R, dtype=np.float64)
    inside = beta_b + (1.0 - beta_b) * (r_max**2 - distance**2) ** 2 / r_max**4
    return np.asarray(np.maximum(np.where(distance <= r_max, inside, beta_b), floor))


def informative_range(*, r_max: float = R_MAX, beta_b: float = 0.2) -> float:
    """Distance [m] within which eq. 31 makes a reading evidence for what it says.

    Beyond the distance where ``beta_r`` falls to 1/2, eq. 32 carries no information (with
    a floor of 1/2) or reverses it (the literal ``beta_b < 1/2``). Solving
    ``beta_b + (1 - beta_b)(r_max^2 - R^2)^2 / r_max^4 = 1/2`` gives
    ``R = r_max sqrt(1 - sqrt((1/2 - beta_b) / (1 - beta_b)))``; ``r_max`` when
    ``beta_b >= 1/2``.

    Examples
    --------
    >>> round(informative_range(beta_b=0.2), 3)
    1.245
    >>> informative_range(beta_b=0.5)
    2.0
    """
    if beta_b >= 0.5:
        return float(r_max)
    return float(r_max * math.sqrt(1.0 - math.sqrt((0.5 - beta_b) / (1.0 - beta_b))))


def sensor_posterior(beta: npt.ArrayLike, prior: npt.ArrayLike, o: npt.ArrayLike) -> FloatArray:
    """Probability of an object at range ``R`` after a reading with contact flag ``o``.

    Inverse IR sensor model, Post et al. 2016 eq. 32 (Bayes' rule with ``P(r|R) = beta_r``):
    ``beta P / (2 beta P - beta - P + 1)`` if ``o = 1`` and
    ``(1 - beta) P / (-2 beta P + beta + P)`` if ``o = 0``, with ``P = P(R, t)``.

    Examples
    --------
    >>> sensor_posterior(1.0, 0.2, [1, 0]).round(12).tolist()
    [1.0, 0.0]
    >>> round(float(sensor_posterior(0.5, 0.2, 1)), 12)
    0.2
    """
    b = np.asarray(beta, dtype=np.float64)
    p = np.asarray(prior, dtype=np.float64)
    contact = np.asarray(o).astype(bool)
    hit = b * p / (2.0 * b * p - b - p + 1.0)
    miss = (1.0 - b) * p / (-2.0 * b * p + b + p)
    return np.asarray(np.where(contact, hit, miss))


def contact(
    raw: npt.ArrayLike, previous_raw: npt.ArrayLike, *, sigma_r: float = SIGMA_R
) -> BoolArray:
    """Contact flag ``o``: two readings in a row above ``2 sigma_r`` (Post et al. 2016 eq. 33).

    Examples
    --------
    >>> contact([10, 10, 3], [10, 3, 10]).tolist()
    [True, False, False]
    """
    threshold = 2.0 * sigma_r
    now = np.asarray(raw, dtype=np.float64)
    before = np.asarray(previous_raw, dtype=np.float64)
    return np.asarray((now > threshold) & (before > threshold))


def angular_weight(theta: npt.ArrayLike, w_r: float) -> FloatArray:
    """Detection weight of a ranger at angle ``theta`` [rad] off its axis.

    Post et al. 2016 eq. 34: ``alpha = exp(-(theta / w_r)^2) / (w_r^2 sqrt(2 pi))``, with
    ``w_r`` the sensor's angle of view [rad].
    """
    t = np.asarray(theta, dtype=np.float64)
    return np.asarray(np.exp(-((t / w_r) ** 2)) / (w_r**2 * np.sqrt(2.0 * np.pi)))


def raw_from_range(r: npt.ArrayLike, fit: Calibration = RAW_FIT) -> FloatArray:
    """Noise-free ADC reading of an IR ranger at range ``r`` [m] (§5.1 fit; ``inf`` → asymptote).

    ``r_raw = (a r + b) / (r + c)`` with the paper's ``(a, b, c) = (-7.933, 56.61, 0.07544)``
    by default (unclipped, unquantised).
    """
    a, b, c = fit
    distance = np.asarray(r, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        value = (a * distance + b) / (distance + c)
    return np.asarray(np.where(np.isinf(distance), a, value))


def range_from_raw(raw: npt.ArrayLike, fit: Calibration = RAW_FIT) -> FloatArray:
    """Range [m] from an ADC reading: the inverse of the fit, ``r = (b - c r_raw) / (r_raw - a)``.

    With the paper's fit this is its transfer function
    ``r = -0.08 (943 r_raw - 707625) / (1000 r_raw + 7933)`` (§5.1).

    Examples
    --------
    >>> round(float(range_from_raw(raw_from_range(1.5))), 9)
    1.5
    >>> round(float(range_from_raw(30.0)), 6) == round(-0.08 * (943 * 30 - 707625) / 37933, 6)
    True
    """
    a, b, c = fit
    value = np.asarray(raw, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray((b - c * value) / (value - a))


def calibration_problem(fit: Calibration) -> str | None:
    """What is wrong with ``fit = (a, b, c)`` as an IR calibration, or ``None``.

    The §5.1 model ``r_raw = (a r + b) / (r + c)`` must fall with range at every ``r > 0``,
    so that a reading names one range: its slope ``(a c - b) / (r + c)^2`` is negative
    where ``a c < b``, and the pole ``r = -c`` must not lie at a positive range (``c >= 0``).
    The paper's fit has ``a c - b = -57.2`` and ``c = 0.075``.

    >>> calibration_problem(RAW_FIT) is None
    True
    >>> calibration_problem((7.933, 56.61, 0.07544)) is None  # a sign slip in a: still falls
    True
    >>> print(calibration_problem((1.0, 1.0, 1.0)))
    r_raw = (a r + b)/(r + c) with (a, b, c) = (1, 1, 1) does not fall with range (need ...)
    """
    a, b, c = fit
    if not all(math.isfinite(v) for v in fit):
        return f"the calibration numbers must be finite, got {fit}"
    if a * c < b and c >= 0:
        return None
    return (
        f"r_raw = (a r + b)/(r + c) with (a, b, c) = ({a:g}, {b:g}, {c:g}) does not fall with "
        "range (need a c < b and c >= 0)"
    )


def fit_calibration(raw: npt.ArrayLike, distance: npt.ArrayLike) -> Calibration:
    """Fit ``r_raw = (a r + b) / (r + c)`` to calibration pairs, as §5.1 did (least squares).

    Parameters
    ----------
    raw
        ADC readings.
    distance
        The true ranges [m] at which they were taken.

    Raises
    ------
    InputError
        Fewer than 3 finite pairs, or no fit that falls with range.
    """
    x = np.asarray(distance, dtype=np.float64).ravel()
    y = np.asarray(raw, dtype=np.float64).ravel()
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0)
    if x.shape != y.shape or ok.sum() < 3:
        raise InputError(
            f"an IR calibration needs at least 3 finite (raw, distance > 0) pairs, got {ok.sum()}"
        )

    if np.ptp(y[ok]) == 0:
        raise InputError(
            f"every raw reading of the IR calibration is {y[ok][0]:g}: a calibration needs "
            "readings that change with distance"
        )

    def model(r: FloatArray, a: float, b: float, c: float) -> FloatArray:
        return (a * r + b) / (r + c)

    try:
        with warnings.catch_warnings():  # three pairs fit exactly, with no covariance: fine
            warnings.simplefilter("ignore", OptimizeWarning)
            found, _ = curve_fit(model, x[ok], y[ok], p0=RAW_FIT, maxfev=20000)
    except (RuntimeError, ValueError) as error:
        raise InputError(
            f"the IR calibration pairs admit no fit r_raw = (a r + b)/(r + c): {error}"
        ) from None
    a, b, c = (float(v) for v in found)
    span = np.linspace(x[ok].min(), x[ok].max(), 50)
    if not (c > -x[ok].min() and np.all(np.diff(model(span, a, b, c)) < 0)):
        raise InputError("the fitted IR calibration does not fall with range; check the pairs")
    return (a, b, c)


def ranger_poses(pose: npt.ArrayLike, angles: npt.ArrayLike, offset: float) -> FloatArray:
    """``(n, 3)`` ranger poses ``(x [m], y [m], theta [rad])`` for a rover pose ``(x, y, heading)``.

    The rangers sit ``offset`` [m] ahead of the rover's centre, turned by ``angles`` [rad]
    from its heading.

    Examples
    --------
    >>> ranger_poses([1.0, 2.0, 0.0], [0.5, 0.0], 0.15).tolist()
    [[1.15, 2.0, 0.5], [1.15, 2.0, 0.0]]
    """
    x, y, heading = np.asarray(pose, dtype=np.float64).reshape(3)
    sx = x + offset * np.cos(heading)
    sy = y + offset * np.sin(heading)
    theta = heading + np.asarray(angles, dtype=np.float64)
    return np.stack([np.full_like(theta, sx), np.full_like(theta, sy), theta], axis=1)
