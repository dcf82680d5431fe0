"""Random-number conventions (SPEC 7).

Public entry points accept ``rng: int | numpy.random.Generator | None`` and normalise it
once with :func:`as_generator`; internal functions take a required keyword
``rng: numpy.random.Generator``. Nothing in bayesmap seeds global state.
"""

from __future__ import annotations

import numpy as np

RNGLike = int | np.random.Generator | np.random.SeedSequence | None


def as_generator(rng: RNGLike) -> np.random.Generator:
    """Return a :class:`numpy.random.Generator` for a seed, a generator or ``None``.

    A generator passed in is returned as is (its stream is shared, not copied); an
    integer or :class:`numpy.random.SeedSequence` seeds a new PCG64 generator; ``None``
    draws fresh entropy from the operating system.
    """
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


def spawn(seed: int | np.random.SeedSequence, n: int) -> list[np.random.Generator]:
    """Derive ``n`` independent generators from one seed (one per world, sensor, chain)."""
    sequence = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return [np.random.default_rng(child) for child in sequence.spawn(n)]
