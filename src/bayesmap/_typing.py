"""Array aliases used across bayesmap, with their axis conventions.

- ``CPT``: a conditional probability table as an array of shape ``(child, *parents)``:
  axis 0 is the child's state, axes 1.. are the parents' states in parent order.
- ``Grid``: a map layer of shape ``(ny, nx)``; row ``i`` is the ``i``-th cell along y
  from the map origin (lower-left corner), column ``j`` the ``j``-th along x.
- ``Poses``: ``(n, 3)`` rows of ``(x [m], y [m], heading [rad])`` in the world frame.
- ``Ranges``: ``(n, n_sensors)`` range readings ``[m]``; ``inf`` or ``nan`` is no echo.

And the one shape of a progress callback, ``ProgressHook``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeAlias

import numpy as np
import numpy.typing as npt

FloatArray: TypeAlias = npt.NDArray[np.float64]
IntArray: TypeAlias = npt.NDArray[np.int64]
BoolArray: TypeAlias = npt.NDArray[np.bool_]
CPT: TypeAlias = npt.NDArray[np.float64]
Grid: TypeAlias = npt.NDArray[np.float64]
Poses: TypeAlias = npt.NDArray[np.float64]
Ranges: TypeAlias = npt.NDArray[np.float64]

ProgressHook: TypeAlias = Callable[[str, int, int], None]
"""``hook(description, completed, total)``: called as long work advances.

``description`` names the current stage (e.g. ``"obstacles-flat"``, ``"mapping"``),
``completed`` and ``total`` count its units of work (poses, steps, runs, rings, bytes);
a negative ``total`` means it is not known yet. The library never prints; the CLI turns
these calls into a progress bar.
"""
