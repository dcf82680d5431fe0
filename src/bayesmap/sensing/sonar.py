"""The Elfes-style sonar model of the ICINCO 2007 fragment: eq. 1 and the beam-cone inverse model.

The fragment (ICINCO 2007, SciTePress paper 16519, p. 494) states only the reading model,
eq. 1, "based on the standard specification of a sensory model (Elfes, 1989)":

    p(s_t | m) = 1 / sqrt(2 pi sigma²) · exp(-½ d² / sigma²),

with ``d`` the distance between the reported range and the point of interest. The inverse
model over the beam cone is ours, built from the same Gaussian (documented in docs/sonar.md):
a cell at distance ``rho`` from the transducer and bearing ``theta`` off its axis, for a
reading ``r``, gets

- angular weight ``A(theta) = 1 - (2 theta / beta)²`` inside the cone of full width ``beta``
  (Moravec & Elfes 1985), 0 outside;
- occupied evidence ``o = A · g``, with ``g = exp(-½ (rho - r)² / sigma²)`` the eq. 1
  Gaussian scaled to peak 1 (the occupied arc at the echo);
- free evidence ``f = A · (1 - g)`` for ``rho < r`` (free before the echo);
- ``p = 1/2 + (p_occ - 1/2) · o - (1/2 - p_free) · f``, and 1/2 (no information) beyond
  ``r + 3 sigma``;
- optionally a one-sided arc: in front of ``r`` the Gaussian keeps its peak for
  ``front_flat`` and then falls with its own width ``sigma_front`` (the echo is the first
  return, so the surface that made it is not in front of ``r``).

A reading at or above the maximum range (no echo) is free up to the maximum range and has no
occupied arc.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.errors import ConfigError

__all__ = ["angular_weight", "elfes_inverse_model", "log_odds", "reading_likelihood"]


def reading_likelihood(d: npt.ArrayLike, sigma: float) -> FloatArray:
    """Gaussian sonar reading model, ICINCO 2007 fragment eq. 1 (after Elfes 1989).

    Parameters
    ----------
    d
        Distance between the reported range and the point of interest [m].
    sigma
        Standard deviation of the sensor's range error [m].

    Returns
    -------
    ``p(s_t | m)`` [1/m], same shape as ``d``.

    Examples
    --------
    >>> round(float(reading_likelihood(0.0, 1.0)), 4)
    0.3989
    """
    if not sigma > 0:
        raise ConfigError(f"sonar sigma must be a positive number of metres, got {sigma!r}")
    dd = np.asarray(d, dtype=np.float64)
    return np.asarray(np.exp(-0.5 * (dd / sigma) ** 2) / math.sqrt(2.0 * math.pi * sigma**2))


def angular_weight(theta: npt.ArrayLike, beam_width: float) -> FloatArray:
    """Moravec & Elfes (1985) angular profile ``1 - (2 theta / beta)²`` inside the cone, else 0.

    Parameters
    ----------
    theta
        Bearing off the beam axis [rad].
    beam_width
        Full cone width ``beta`` [rad].
    """
    t = np.asarray(theta, dtype=np.float64)
    return np.asarray(np.clip(1.0 - (2.0 * t / beam_width) ** 2, 0.0, 1.0))


def elfes_inverse_model(
    r: npt.ArrayLike,
    rho: npt.ArrayLike,
    theta: npt.ArrayLike,
    *,
    sigma: float,
    beam_width: float,
    max_range: float,
    p_occ: float = 0.7,
    p_free: float = 0.35,
    sigma_front: float | None = None,
    front_flat: float = 0.0,
) -> FloatArray:
    """Occupancy probability of cells in a sonar cone, from eq. 1's Gaussian (ours, see module).

    Parameters
    ----------
    r
        Reported range [m]; ``>= max_range`` means no echo. Broadcasts with ``rho``/``theta``.
    rho
        Distance of each cell centre from the transducer [m].
    theta
        Bearing of each cell centre off the beam axis [rad].
    sigma
        Range standard deviation of eq. 1 [m] (use at least half a cell).
    beam_width
        Full cone width [rad].
    max_range
        Maximum range [m].
    p_occ, p_free
        Probability at the peak of the occupied arc and deep in the free region.
    sigma_front, front_flat
        The occupied arc's near side (``rho < r``): it stays at its peak for ``front_flat``
        [m] in front of ``r``, then falls as a Gaussian of width ``sigma_front`` [m];
        ``None`` (default): eq. 1's Gaussian of width ``sigma`` on both sides. An echo is
        the *first* return, from the nearest surface in the cone, so a cell in front of
        the echo can hold that surface only if its centre lies within its own half-width
        (``front_flat``) and the range and pose error (``sigma_front``) of ``r``; behind
        the echo the arc keeps ``sigma`` (docs/sonar.md, *The first echo's near side*).

    Returns
    -------
    Occupancy probability of each cell; 0.5 means no information.

    Examples
    --------
    >>> p = elfes_inverse_model(2.0, [1.0, 2.0, 3.0], 0.0, sigma=0.05,
    ...                         beam_width=0.44, max_range=5.0)
    >>> [round(float(v), 2) for v in p]
    [0.35, 0.7, 0.5]
    >>> p = elfes_inverse_model(2.0, [1.9, 1.95, 2.1], 0.0, sigma=0.1, sigma_front=0.03,
    ...                         front_flat=0.05, beam_width=0.44, max_range=5.0)
    >>> [round(float(v), 2) for v in p]
    [0.44, 0.7, 0.62]
    """
    if not (0.0 < p_free < 0.5 < p_occ < 1.0):
        raise ConfigError(f"need 0 < p_free < 0.5 < p_occ < 1, got p_free={p_free}, p_occ={p_occ}")
    if not sigma > 0:
        raise ConfigError(f"sonar sigma must be a positive number of metres, got {sigma!r}")
    front = sigma if sigma_front is None else sigma_front
    flat = 0.0 if sigma_front is None else front_flat
    if not (front > 0 and flat >= 0):
        raise ConfigError(
            f"need sigma_front > 0 and front_flat >= 0 metres, got {front!r}, {front_flat!r}"
        )
    reading = np.asarray(r, dtype=np.float64)
    distance = np.asarray(rho, dtype=np.float64)
    echo = reading < max_range
    weight = angular_weight(theta, beam_width)
    before = distance < np.where(echo, reading, max_range)
    # How far the cell lies from where the echo may have come from, in widths of the
    # side it lies on (the near side flat for ``flat``).
    gap = np.where(
        before, np.maximum(reading - distance - flat, 0.0) / front, (distance - reading) / sigma
    )
    g = np.where(echo, np.exp(-0.5 * gap**2), 0.0)
    occupied = weight * g
    free = weight * (1.0 - g) * before
    p = 0.5 + (p_occ - 0.5) * occupied - (0.5 - p_free) * free
    beyond = distance > np.where(echo, reading + 3.0 * sigma, max_range)
    return np.asarray(np.where(beyond, 0.5, p))


def log_odds(p: npt.ArrayLike) -> FloatArray:
    """``log(p / (1 - p))`` of probabilities strictly inside (0, 1)."""
    q = np.asarray(p, dtype=np.float64)
    return np.asarray(np.log(q) - np.log1p(-q))
