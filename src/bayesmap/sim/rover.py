"""A skid-steer micro-rover with compass, time-averaged GPS and IR rangers (Post et al. 2016 §5).

Functional shape: :func:`initial` → :func:`transition` (one control period) →
:func:`observe` (noisy) beside :func:`h` (noise-free). The rover drives at up to ``speed``
with its turning radius at least ``min_turn_radius``; a skid-steer rover may also pivot in
place at zero speed. Nothing keeps it inside the mapped area.

Positions come from a GPS whose error is a slowly varying (time-averaged) Gauss–Markov
process of standard deviation ``gps_sigma`` and correlation time ``gps_tau``; the heading from
a compass with white noise ``compass_sigma``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.errors import ConfigError
from bayesmap.sim import ir
from bayesmap.sim.world2d import BoxWorld, world_distance, world_truth


@dataclass(frozen=True)
class SimulatedRoverParams:
    """Physical and sensor parameters of the simulated rover.

    Attributes
    ----------
    speed
        Forward speed when driving [m/s].
    min_turn_radius
        Smallest turning radius while driving [m].
    pivot_rate
        Yaw rate when pivoting in place at zero speed [rad/s].
    dt
        Control period [s].
    radius
        Radius of the rover's footprint [m] (touching an obstacle is a collision).
    gps_sigma
        Standard deviation of the time-averaged GPS error, per axis [m].
    gps_tau
        Correlation time of the GPS error [s].
    compass_sigma
        Standard deviation of the compass error [rad].
    rangers
        The IR rangers.
    """

    speed: float = 0.25
    min_turn_radius: float = 0.4
    pivot_rate: float = 0.8
    dt: float = 0.4
    radius: float = 0.2
    gps_sigma: float = 0.1
    gps_tau: float = 20.0
    compass_sigma: float = math.radians(2.0)
    rangers: ir.IRRangers = field(default_factory=ir.IRRangers)

    def __post_init__(self) -> None:
        positive = {
            "speed": self.speed,
            "min_turn_radius": self.min_turn_radius,
            "pivot_rate": self.pivot_rate,
            "dt": self.dt,
            "radius": self.radius,
            "gps_tau": self.gps_tau,
        }
        bad = [f"{k}={v!r} (need > 0)" for k, v in positive.items() if not v > 0]
        noise = {"gps_sigma": self.gps_sigma, "compass_sigma": self.compass_sigma}
        bad += [f"{k}={v!r} (need >= 0)" for k, v in noise.items() if not v >= 0]
        if bad:
            raise ConfigError(f"SimulatedRoverParams: fix {', '.join(bad)}")


class RoverState(NamedTuple):
    """True pose and the GPS error process."""

    pose: FloatArray
    """``(x [m], y [m], heading [rad])``."""
    gps_error: FloatArray
    """``(ex, ey)`` current GPS error [m]."""


class Observation(NamedTuple):
    """What the rover's own sensors report in one control period."""

    raw: FloatArray
    """``(n,)`` 8-bit IR readings."""
    pose: FloatArray
    """``(x, y, heading)`` estimated from GPS and compass."""


def initial(
    pose: npt.ArrayLike, params: SimulatedRoverParams, *, rng: np.random.Generator
) -> RoverState:
    """Start at ``pose`` with a GPS error drawn from its stationary distribution."""
    start = np.asarray(pose, dtype=np.float64).reshape(3)
    return RoverState(start, rng.normal(0.0, params.gps_sigma, size=2))


def transition(
    state: RoverState,
    command: tuple[float, float],
    params: SimulatedRoverParams,
    *,
    rng: np.random.Generator,
) -> RoverState:
    """Drive one period with ``command = (speed [m/s], yaw_rate [rad/s])``, limits enforced.

    Speed is clipped to ``[-params.speed, params.speed]`` (negative: backing off); while
    moving, the yaw rate is clipped so the turning radius stays at least
    ``min_turn_radius``; at zero speed the rover pivots at up to ``pivot_rate``. The pose is
    integrated exactly along the arc.
    """
    v = float(np.clip(command[0], -params.speed, params.speed))
    limit = abs(v) / params.min_turn_radius if v != 0 else params.pivot_rate
    w = float(np.clip(command[1], -limit, limit))
    x, y, psi = state.pose
    dt = params.dt
    if abs(w) < 1e-9:
        x, y = x + v * dt * math.cos(psi), y + v * dt * math.sin(psi)
    else:
        x += v / w * (math.sin(psi + w * dt) - math.sin(psi))
        y -= v / w * (math.cos(psi + w * dt) - math.cos(psi))
    psi = math.remainder(psi + w * dt, 2.0 * math.pi)
    rho = math.exp(-dt / params.gps_tau)
    error = rho * state.gps_error + math.sqrt(1.0 - rho**2) * rng.normal(0.0, params.gps_sigma, 2)
    return RoverState(np.array([x, y, psi]), error)


def h(world: BoxWorld, state: RoverState, params: SimulatedRoverParams) -> Observation:
    """Noise-free observation: exact pose and unquantised IR readings."""
    return Observation(ir.h(world, state.pose, params.rangers), state.pose.copy())


def observe(
    world: BoxWorld, state: RoverState, params: SimulatedRoverParams, *, rng: np.random.Generator
) -> Observation:
    """Noisy observation: quantised IR readings, GPS position and compass heading."""
    raw = ir.observe(world, state.pose, params.rangers, rng=rng)
    x, y, psi = state.pose
    heading = math.remainder(psi + rng.normal(0.0, params.compass_sigma), 2.0 * math.pi)
    return Observation(raw, np.array([x + state.gps_error[0], y + state.gps_error[1], heading]))


def collides(world: BoxWorld, state: RoverState, params: SimulatedRoverParams) -> bool:
    """Whether the rover's footprint touches an obstacle."""
    return world_distance(world, float(state.pose[0]), float(state.pose[1])) <= params.radius


def clearance(world: BoxWorld, state: RoverState, params: SimulatedRoverParams) -> float:
    """Distance [m] from the rover's footprint to the nearest obstacle (negative: overlap)."""
    return world_distance(world, float(state.pose[0]), float(state.pose[1])) - params.radius


def off_map(world: BoxWorld, state: RoverState) -> bool:
    """Whether the rover's centre is outside the mapped area ``[0, width] x [0, height]``."""
    x, y = float(state.pose[0]), float(state.pose[1])
    return not (0.0 <= x <= world.width and 0.0 <= y <= world.height)


def observable_cells(
    world: BoxWorld,
    shape: tuple[int, int],
    resolution: float,
    start: tuple[float, float],
    *,
    clearance: float,
    sense_range: float,
    step: float = 0.1,
    n_rays: int = 48,
) -> BoolArray:
    """``(ny, nx)`` map cells a ranger can see from where the rover may go: the coverage base.

    The rover may go where its centre keeps ``clearance`` [m] from every obstacle, inside the
    area and connected to ``start`` (free space rasterised at ``step`` [m]). From positions
    of that region ``resolution`` apart, rays in ``n_rays`` directions (the rover can
    turn in place) reach ``sense_range`` [m] or the first obstacle; a cell is observable when
    a ray enters it, so cells wholly inside an obstacle, or seen only through one, are not.
    The map's lower-left corner is the origin.
    """
    nyf = max(int(math.ceil(world.height / step)), 1)
    nxf = max(int(math.ceil(world.width / step)), 1)
    occupied = world_truth(world, (nyf, nxf), step, (0.0, 0.0))
    if occupied.any():
        distance = ndimage.distance_transform_edt(~occupied) * step - step / 2
    else:
        distance = np.full(occupied.shape, np.inf)
    room = distance >= clearance
    labels, _ = ndimage.label(room, structure=np.ones((3, 3), dtype=bool))
    i0 = int(np.clip(start[1] / step, 0, nyf - 1))
    j0 = int(np.clip(start[0] / step, 0, nxf - 1))
    if labels[i0, j0] == 0:  # the start itself is too close: take the nearest room
        if not room.any():
            return np.zeros(shape, dtype=bool)
        _, (ri, rj) = ndimage.distance_transform_edt(~room, return_indices=True)
        i0, j0 = int(ri[i0, j0]), int(rj[i0, j0])
    stride = max(int(round(resolution / step)), 1)
    reach = labels == labels[i0, j0]
    rows, cols = np.nonzero(reach[::stride, ::stride])
    px = (cols * stride + 0.5) * step
    py = (rows * stride + 0.5) * step
    angles = np.linspace(0.0, 2.0 * math.pi, n_rays, endpoint=False)
    along = np.arange(step / 2, sense_range + step / 2, step)
    dx = np.cos(angles)[:, None] * along[None, :]
    dy = np.sin(angles)[:, None] * along[None, :]
    seen = np.zeros(shape, dtype=bool)
    for k in range(0, px.size, 1024):
        sx = px[k : k + 1024, None, None] + dx[None]
        sy = py[k : k + 1024, None, None] + dy[None]
        fi, fj = np.floor(sy / step).astype(np.int64), np.floor(sx / step).astype(np.int64)
        inside = (fi >= 0) & (fi < nyf) & (fj >= 0) & (fj < nxf)
        hit = ~inside | occupied[np.clip(fi, 0, nyf - 1), np.clip(fj, 0, nxf - 1)]
        before = np.logical_or.accumulate(hit, axis=2)
        visible = inside & np.concatenate([np.ones_like(hit[..., :1]), ~before[..., :-1]], axis=2)
        ci = np.floor(sy[visible] / resolution).astype(np.int64)
        cj = np.floor(sx[visible] / resolution).astype(np.int64)
        keep = (ci >= 0) & (ci < shape[0]) & (cj >= 0) & (cj < shape[1])
        seen[ci[keep], cj[keep]] = True
    return seen
