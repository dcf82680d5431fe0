"""Simulated IR rangers of the Beaver micro-rover (Post et al. 2016 §4.2, §5.1).

Three rangers look ahead at 0° and ±30°. Each has a Gaussian angular sensitivity of width
``w_r``: it is modelled as a fan of rays, and it reports the range of the hit ray it is most
sensitive to (the one closest to its axis) among the hits that send back enough light to be
located (:func:`detection_range`: ``r_max`` on the axis, less off it). A surface farther
away reads at the noise floor, so it cannot mask a nearer one elsewhere in the fan; with no
hit located, the ranger reports the hit closest to its axis, however far. The range goes
through the ADC transfer function fitted in §5.1, gets Gaussian noise of ``sigma_r`` ADC
units, and is quantised to 8 bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.errors import ConfigError
from bayesmap.geometry import cast_on_boxes
from bayesmap.sensing.ir import (
    R_MAX,
    RANGER_ANGLES,
    RANGER_OFFSET,
    SIGMA_R,
    W_R,
    ranger_poses,
    raw_from_range,
)
from bayesmap.sim.world2d import BoxWorld, world_ray_cast


@dataclass(frozen=True)
class IRRangers:
    """Geometry and noise of the rangers.

    Attributes
    ----------
    angles
        Mounting angles relative to the rover's heading [rad].
    offset
        Distance of the rangers ahead of the rover's centre [m].
    w_r
        Angular sensitivity (angle of view) [rad].
    sigma_r
        RMS noise of a reading [ADC units].
    n_rays
        Rays per ranger, spread over ``±w_r`` (sensitivity above e^-1 of the peak).
    r_max
        Maximum range [m] on the axis (:func:`detection_range`).
    """

    angles: tuple[float, ...] = RANGER_ANGLES
    offset: float = RANGER_OFFSET
    w_r: float = W_R
    sigma_r: float = SIGMA_R
    n_rays: int = 7
    r_max: float = R_MAX

    def __post_init__(self) -> None:
        if not self.angles:
            raise ConfigError("IRRangers needs at least one ranger angle")
        if (
            self.w_r <= 0
            or self.sigma_r < 0
            or self.n_rays < 1
            or self.offset < 0
            or not self.r_max > 0
        ):
            raise ConfigError(
                f"IRRangers: need w_r > 0, sigma_r >= 0, n_rays >= 1, offset >= 0, r_max > 0; "
                f"got w_r={self.w_r}, sigma_r={self.sigma_r}, n_rays={self.n_rays}, "
                f"offset={self.offset}, r_max={self.r_max}"
            )

    def poses(self, pose: npt.ArrayLike) -> FloatArray:
        """``(n, 3)`` ranger poses ``(x, y, theta)`` for a rover pose ``(x, y, heading)``."""
        return ranger_poses(pose, self.angles, self.offset)


Obstacles = npt.ArrayLike | BoxWorld
"""``(k, 4)`` boxes, or a world with boxes and polygons."""


def detection_range(theta: npt.ArrayLike, rangers: IRRangers) -> FloatArray:
    """Farthest distance [m] at which a surface ``theta`` [rad] off a ranger's axis is located.

    The light a surface sends back falls as ``exp(-(theta / w_r)^2) / d^2``: the angular
    sensitivity (the shape of eq. 34) over the spreading loss. A surface is located when it
    returns at least as much as one on the axis at the maximum range ``r_max``, so the
    range shrinks to ``r_max exp(-(theta / w_r)^2 / 2)`` off the axis (0.61 ``r_max`` at
    ``theta = w_r``).
    """
    t = np.asarray(theta, dtype=np.float64)
    return np.asarray(rangers.r_max * np.exp(-0.5 * (t / rangers.w_r) ** 2))


def true_ranges(boxes: Obstacles, pose: npt.ArrayLike, rangers: IRRangers) -> FloatArray:
    """``(n,)`` range [m] each ranger senses (``inf`` if nothing in its fan), noise-free.

    ``boxes`` is an array of boxes or a :class:`~bayesmap.sim.world2d.BoxWorld` (whose
    polygons count too).
    """
    sensors = rangers.poses(pose)
    offsets = np.linspace(-rangers.w_r, rangers.w_r, rangers.n_rays)
    angles = sensors[:, 2:3] + offsets[None, :]
    origins = np.repeat(sensors[:, :2], rangers.n_rays, axis=0)
    if isinstance(boxes, BoxWorld):
        d = world_ray_cast(boxes, origins, angles.ravel()).reshape(angles.shape)
    else:
        d = cast_on_boxes(boxes, origins, angles.ravel()).reshape(angles.shape)
    # the ranger reports the hit it is most sensitive to: the hit ray nearest its axis,
    # among the hits that send back enough light to be located (detection_range)
    order = np.argsort(np.abs(offsets), kind="stable")
    ordered: FloatArray = d[:, order]
    rows = np.arange(len(ordered))
    within = ordered <= detection_range(offsets[order], rangers)[None, :]
    nearest_within = ordered[rows, np.argmax(within, axis=1)]
    nearest_any = ordered[rows, np.argmax(np.isfinite(ordered), axis=1)]
    return np.asarray(np.where(within.any(axis=1), nearest_within, nearest_any))


def h(boxes: Obstacles, pose: npt.ArrayLike, rangers: IRRangers) -> FloatArray:
    """Noise-free ADC readings (unquantised, unclipped) of the rangers at ``pose``."""
    return raw_from_range(true_ranges(boxes, pose, rangers))


def observe(
    boxes: Obstacles, pose: npt.ArrayLike, rangers: IRRangers, *, rng: np.random.Generator
) -> FloatArray:
    """8-bit ADC readings: noise-free reading + N(0, sigma_r), rounded and clipped to 0..255."""
    clean = h(boxes, pose, rangers)
    noisy = clean + rng.normal(0.0, rangers.sigma_r, size=clean.shape)
    return np.asarray(np.clip(np.rint(noisy), 0.0, 255.0))
