"""Parametric forms for CPTs: the discretised Gaussian of Post et al. 2016 §3.1 step 3.

The paper defines a node's distribution by a Gaussian ``P(X = x) = exp(−(x − x̄)²/2σ²) /
(σ√(2π))`` over a continuous quantity that the node's discrete states cut into bins. We
discretise it by integrating the density over each bin (differences of the normal CDF),
with the first and last bins extended to −∞ and +∞ so that every distribution sums to 1
exactly. A node whose mean depends on its parents (e.g. a range sensor whose reading
centres on the true distance) gets one column per parent state: :func:`gaussian_cpt`.

The paper's other form, the "program" form of data nodes (§3.4: a distribution computed at
query time, e.g. by a lookup in a map), is a :data:`~bayesmap.bn.model.DataSource`
callable given to :meth:`BayesNet.add_variable <bayesmap.bn.model.BayesNet.add_variable>`
(``source=``); the inference engine calls it with the query's evidence.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bayesmap._typing import CPT, FloatArray
from bayesmap.errors import ConfigError


def discretised_gaussian(
    mean: npt.ArrayLike, sigma: npt.ArrayLike, edges: npt.ArrayLike
) -> FloatArray:
    """Probability of each bin under ``N(mean, sigma²)``, Post et al. 2016 §3.1 step 3.

    Parameters
    ----------
    mean
        Mean ``x̄`` (any shape; broadcast with ``sigma``), in the units of ``edges``.
    sigma
        Standard deviation ``σ > 0``, same units.
    edges
        Increasing bin edges, shape ``(n_bins + 1,)``; the outer two are treated as −∞
        and +∞ so that no probability is lost.

    Returns
    -------
    ndarray
        Shape ``(*broadcast(mean, sigma).shape, n_bins)``; sums to 1 along the last axis.

    Raises
    ------
    ConfigError
        Non-positive ``sigma``, fewer than two edges, or edges not increasing.

    Examples
    --------
    >>> discretised_gaussian(0.0, 1.0, [-1.0, 0.0, 1.0]).round(3)
    array([0.5, 0.5])
    """
    e = np.asarray(edges, dtype=np.float64)
    if e.ndim != 1 or e.size < 2 or np.any(np.diff(e) <= 0):
        raise ConfigError(f"bin edges must be an increasing 1-D array of ≥ 2 values, got {e}")
    mu = np.asarray(mean, dtype=np.float64)[..., np.newaxis]
    s = np.asarray(sigma, dtype=np.float64)[..., np.newaxis]
    if np.any(~(s > 0)):
        raise ConfigError(f"sigma must be positive, got {np.asarray(sigma)}")
    from scipy.special import ndtr  # imported here: scipy.special costs ~0.3 s to load

    cdf = ndtr((e - mu) / s)
    cdf[..., 0] = 0.0
    cdf[..., -1] = 1.0
    return np.asarray(np.diff(cdf, axis=-1))


def gaussian_cpt(means: npt.ArrayLike, sigma: npt.ArrayLike, edges: npt.ArrayLike) -> CPT:
    """A CPT ``(child, *parents)`` whose column for each parent state is a discretised Gaussian.

    Parameters
    ----------
    means
        Mean for every parent configuration, shape ``(*parent cardinalities)`` (a scalar
        for a root node).
    sigma
        Standard deviation: a scalar or one per parent configuration.
    edges
        Bin edges of the child's states, shape ``(n_states + 1,)``.

    Examples
    --------
    >>> gaussian_cpt([0.5, 1.5], 0.3, [0.0, 1.0, 2.0]).shape
    (2, 2)
    """
    table = discretised_gaussian(means, sigma, edges)
    return np.asarray(np.moveaxis(table, -1, 0))
