"""The naive-Bayes class ratio, Post et al. 2016 eq. 6.

For a class variable ``Y`` whose features ``X_1..X_M`` are independent given ``Y``
(eq. 4), two classes compare by

    P(x_1..x_M, y_1) / P(x_1..x_M, y_2) = P(y_1)/P(y_2) · Π_m P(x_m | y_1)/P(x_m | y_2).

:func:`class_ratio` is that formula on arrays. On any network (naive-Bayes or not) the
same ratio is ``P(y_1 | e) / P(y_2 | e)``, which :meth:`BayesNet.class_ratio
<bayesmap.bn.model.BayesNet.class_ratio>` computes exactly by inference.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from bayesmap.errors import InputError


def class_ratio(
    prior: npt.ArrayLike, likelihoods: Sequence[npt.ArrayLike], y1: int, y2: int
) -> float:
    """Eq. 6: ``P(y1)/P(y2) · Π_m P(x_m|y1)/P(x_m|y2)``.

    Parameters
    ----------
    prior
        ``P(Y)`` over the classes, shape ``(n_classes,)``.
    likelihoods
        For each observed feature ``m``, the row ``P(X_m = x_m | Y)``, shape ``(n_classes,)``.
    y1, y2
        Indices of the two classes.

    Returns
    -------
    float
        The ratio (``inf`` if only the denominator is zero).

    Raises
    ------
    InputError
        Both numerator and denominator are zero, or shapes disagree.

    Examples
    --------
    >>> round(class_ratio([0.5, 0.5], [[0.9, 0.3], [0.8, 0.4]], 0, 1), 9)
    6.0
    """
    p = np.asarray(prior, dtype=np.float64)
    rows = [np.asarray(row, dtype=np.float64) for row in likelihoods]
    if p.ndim != 1 or any(row.shape != p.shape for row in rows):
        raise InputError(
            f"class_ratio: prior and every likelihood row need shape ({p.size},); "
            f"got {p.shape} and {[row.shape for row in rows]}"
        )
    numerator = p[y1] * float(np.prod([row[y1] for row in rows]))
    denominator = p[y2] * float(np.prod([row[y2] for row in rows]))
    if denominator == 0.0:
        if numerator == 0.0:
            raise InputError(f"class_ratio: both classes {y1} and {y2} have probability zero")
        return float("inf")
    return float(numerator / denominator)
