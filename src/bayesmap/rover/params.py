"""Parameters of the rover's mapping and decisions, with the paper's defaults (§5)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from bayesmap.errors import ConfigError
from bayesmap.sensing.ir import (
    R_MAX,
    RANGER_ANGLES,
    RANGER_OFFSET,
    RAW_FIT,
    SIGMA_R,
    W_R,
    Calibration,
)


@dataclass(frozen=True)
class RoverParams:
    """Everything the rover's brain needs to know about itself and its task.

    Attributes
    ----------
    prior
        ``P(R)``: prior probability of an obstacle in a cell (§5: 0.2).
    beta_b
        Base probability of a correct detection, eq. 31 (§5: 0.2).
    r_max
        Maximum range of the IR rangers [m] (§4.1: 2 m).
    reliability_floor
        Lower bound on ``beta_r`` (see :func:`bayesmap.sensing.fusion.ir_cell_evidence`).
    sigma_r
        RMS noise of an IR reading [ADC units], for contact detection (eq. 33).
    ir_fit
        ``(a, b, c)`` of the rangers' ADC fit ``r_raw = (a r + b) / (r + c)`` (§5.1).
    w_r
        Angular sensitivity of a ranger [rad] (eq. 34).
    sigma_xy
        Spread of a contact on the map (2-D Gaussian) [m].
    sensor_angles
        Mounting angles of the rangers relative to the heading [rad] (0, ±30°).
    sensor_offset
        Distance of the rangers ahead of the rover's centre [m].
    d_max
        Radius of the local area searched for targets and obstacles [m] (§5: 8 m).
    d_min
        Targets closer than this are skipped (they lie inside the turning circle) [m].
    target_margin
        ``delta_h`` margin of eq. 39 [bits]: among cells this close to the largest entropy,
        the nearest is chosen.
    n_headings
        ``M``, number of discrete headings (eqs. 41–43), 4 to 360: the decision network
        names its heading states in whole degrees.
    clearance
        Half-width of the corridor swept along each heading (eqs. 41–42) [m].
    distance_weighted
        Use eq. 42 (closer obstacles count more) rather than eq. 41.
    p_block
        Cells with at least this probability are likely obstacles: the footprint keeps off
        them, paths go around them, and targets keep ``clearance`` from them.
    h_desired
        Mapping is done when every cell's entropy is below this [bits].
    speed, min_turn_radius, pivot_rate
        The rover's drive limits: speed [m/s], turning radius [m], pivot rate [rad/s].
    dt
        Length of one cycle [s].
    footprint_radius
        Radius of the rover's body [m]; the safety check keeps it off likely obstacles.
    position_sigma
        Standard deviation of the position estimate per axis [m] (GPS error).
    margin_sigmas
        The safety margin grows by this many ``position_sigma``.
    lookahead
        Distance [m] along the path each candidate heading would drive that the footprint
        check covers (the next cycle's arc, turning included, and on along the new heading).
    hit_memory
        Cycles for which the points the rangers read stay obstacles to the footprint check
        (about the GPS error's correlation time, so they stay where the map put them).
    track_cycles
        Cycles of the rover's own recent track (dead-reckoned from its commands) that a
        back-off may reverse into (:func:`bayesmap.rover.safety.recent_track`).
    track_tolerance
        How far [m] a back-off's centre may stray from that track: the straight reverse
        of one cycle's tightest forward arc strays 0.0125 m from it.
    view_range
        A target is reached when the rover stands this close to it [m]: it goes to the
        nearest point it can reach within this distance and turns to look at the target
        (the rangers see obstacles' sides from there, well inside the range where eq. 31
        informs).
    target_timeout
        Cycles a target may stay unreached beyond the time its path cost needs at
        ``speed``, before it is blacklisted.
    """

    prior: float = 0.2
    beta_b: float = 0.2
    r_max: float = R_MAX
    reliability_floor: float = 0.5
    sigma_r: float = SIGMA_R
    ir_fit: Calibration = RAW_FIT
    w_r: float = W_R
    sigma_xy: float = 0.25
    sensor_angles: tuple[float, ...] = RANGER_ANGLES
    sensor_offset: float = RANGER_OFFSET
    d_max: float = 8.0
    d_min: float = 1.0
    target_margin: float = 0.05
    n_headings: int = 36
    clearance: float = 0.6
    distance_weighted: bool = True
    p_block: float = 0.5
    h_desired: float = 0.3
    speed: float = 0.25
    min_turn_radius: float = 0.4
    pivot_rate: float = 0.8
    dt: float = 0.4
    footprint_radius: float = 0.2
    position_sigma: float = 0.1
    margin_sigmas: float = 3.0
    lookahead: float = 0.6
    hit_memory: int = 50
    track_cycles: int = 15
    track_tolerance: float = 0.02
    target_timeout: int = 60
    view_range: float = 1.0

    def __post_init__(self) -> None:
        checks = {
            "prior in (0, 1)": 0.0 < self.prior < 1.0,
            "beta_b in [0, 1]": 0.0 <= self.beta_b <= 1.0,
            "reliability_floor in [0, 1)": 0.0 <= self.reliability_floor < 1.0,
            "r_max > 0": self.r_max > 0,
            "w_r > 0": self.w_r > 0,
            "sigma_xy > 0": self.sigma_xy > 0,
            "sigma_r >= 0": self.sigma_r >= 0,
            "0 <= d_min < d_max": 0.0 <= self.d_min < self.d_max,
            "target_margin >= 0": self.target_margin >= 0,
            "4 <= n_headings <= 360 (heading states are whole degrees)": (
                4 <= self.n_headings <= 360
            ),
            "clearance > 0": self.clearance > 0,
            "view_range > 0": self.view_range > 0,
            "p_block in (0, 1]": 0.0 < self.p_block <= 1.0,
            "h_desired in (0, 1]": 0.0 < self.h_desired <= 1.0,
            "speed, min_turn_radius, pivot_rate > 0": min(
                self.speed, self.min_turn_radius, self.pivot_rate
            )
            > 0,
            "at least one sensor angle": len(self.sensor_angles) > 0,
            "dt, footprint_radius, lookahead > 0": min(
                self.dt, self.footprint_radius, self.lookahead
            )
            > 0,
            "position_sigma, margin_sigmas >= 0": min(self.position_sigma, self.margin_sigmas) >= 0,
            "target_timeout, hit_memory, track_cycles >= 1": min(
                self.target_timeout, self.hit_memory, self.track_cycles
            )
            >= 1,
            "track_tolerance >= 0": self.track_tolerance >= 0,
        }
        failed = [name for name, ok in checks.items() if not ok]
        if failed:
            raise ConfigError(f"RoverParams: need {', '.join(failed)}")

    @property
    def safety_margin(self) -> float:
        """Clearance [m] kept between the footprint's edge and a likely obstacle's edge.

        ``margin_sigmas * position_sigma``: it grows with the position uncertainty.
        """
        return self.margin_sigmas * self.position_sigma

    @property
    def view_half_angle(self) -> float:
        """Half-angle [rad] of the rangers' joint view: the outermost axis plus half a
        ranger's angle of view ``w_r`` (30° + 8.6° with the paper's rangers)."""
        return max(abs(a) for a in self.sensor_angles) + self.w_r / 2.0

    @property
    def headings(self) -> tuple[float, ...]:
        """The ``M`` discrete world headings ``theta_m = 2 pi m / M`` [rad]."""
        return tuple(2.0 * math.pi * m / self.n_headings for m in range(self.n_headings))
