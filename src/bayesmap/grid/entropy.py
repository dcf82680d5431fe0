"""Bernoulli entropy of occupancy probabilities, in bits."""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray


def binary_entropy_bits(p: npt.ArrayLike) -> FloatArray:
    """Entropy ``-p log2 p - (1 - p) log2 (1 - p)`` of a Bernoulli variable [bits].

    Post et al. 2016 eq. 37 (written there with natural logs; measured here in bits so that
    the unknown value 1 is the maximum, reached at ``p = 0.5``). ``0 log 0`` is taken as 0.

    Examples
    --------
    >>> binary_entropy_bits([0.0, 0.5, 1.0]).tolist()
    [0.0, 1.0, 0.0]
    """
    q = np.clip(np.asarray(p, dtype=np.float64), 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = -q * np.log2(q) - (1.0 - q) * np.log2(1.0 - q)
    return np.asarray(np.nan_to_num(terms, nan=0.0))


@functools.lru_cache(maxsize=16)
def probability_at_entropy(h: float) -> float:
    """The probability ``p <= 1/2`` whose Bernoulli entropy is ``h`` [bits] (bisection).

    Cells with ``p`` below it (or above ``1 - p``) have entropy below ``h``.

    Examples
    --------
    >>> round(probability_at_entropy(0.3), 4)
    0.0532
    """
    lo, hi = 0.0, 0.5
    for _ in range(60):
        mid = (lo + hi) / 2
        if float(binary_entropy_bits(mid)) < h:
            lo = mid
        else:
            hi = mid
    return lo
