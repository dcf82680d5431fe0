"""Every constant of the Bayesian blackboard, with its default and the reason for it.

Fox & Prescott (2011) leave their noise levels, priors, temperatures, ε, δ and the proposal
thresholds unstated ("TODO: say what noise levels and priors used"). Each field of
:class:`BlackboardParams` below is one of those gaps, filled with a documented choice;
docs/blackboard.md explains how the defaults work together. Lengths are in metres [m],
angles in radians [rad], textures are unitless in (0, 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from bayesmap.errors import ConfigError

_POSITIVE = (
    "table_length",
    "table_width",
    "leg_width",
    "sigma_r_leg",
    "sigma_theta_leg",
    "sigma_w",
    "sigma_tau_leg",
    "sigma_r_shapelet",
    "sigma_theta_shapelet",
    "sigma_tau_shapelet",
    "c_T",
    "c_L",
    "c_S",
    "alpha_L",
    "alpha_S",
    "delta",
    "beta_min",
    "beta_max",
    "parent_margin",
)
_NON_NEGATIVE = ("parent_fit_weight", "leg_jitter_theta", "table_jitter_xy", "table_jitter_theta")


@dataclass(frozen=True, slots=True)
class BlackboardParams:
    """Hyper-parameters of the blackboard model (Fox & Prescott 2011 §II) and its sampler.

    Parameters
    ----------
    table_length, table_width
        Outer size of every table [m] (the microworld has one table size, §III). A table is
        a ``table_length`` × ``table_width`` rectangle centred on ``(x, y)`` with its long
        side along ``theta``. Defaults 1.0 m × 0.6 m, a small desk.
    leg_width
        Side of the square legs [m], flush with the table's corners inside the rectangle;
        the corners ``(x_T^i, y_T^i)`` of eq. 6 are therefore the leg centres, at
        ``(±(table_length − leg_width)/2, ±(table_width − leg_width)/2)`` in the table
        frame. New legs proposed from a shapelet get this width. Default 0.05 m.
    sigma_r_leg, sigma_theta_leg, sigma_w, sigma_tau_leg
        The σ's of the leg-given-table distance Δ_TL (eq. 6): how far [m], how rotated
        [rad], how much wider [m] and how differently textured a leg may be from its
        table's corner. Tables are rigid, so these are tight: 0.02 m, 0.1 rad, 0.01 m,
        0.1 — about the shapelet noise, so that legs inferred from noisy contacts still
        fit one rigid table.
    sigma_r_shapelet, sigma_theta_shapelet, sigma_tau_shapelet
        The σ's of the shapelet-given-leg distance Δ_LS (eq. 7): the whisker's noise as
        the model sees it. Defaults 0.02 m, 0.25 rad, 0.1 — a little above the simulator's
        normal noise; set them to the sensor's σ for other noise conditions.
    c_T
        Flat table prior density (eq. 4) [m⁻² rad⁻¹]. The paper asks ∫_A c_T ≤ 1 over the
        arena: 8·10⁻³ keeps the expected number of tables below one for arenas up to
        1/(8·10⁻³ π) ≈ 40 m².
    c_L
        Null prior density of a leg without a table (eq. 8). Eq. 10 asks
        c_S < c_L < c_T ("larger objects are more probable to exist without causes"):
        default 2·10⁻³.
    c_S
        Null prior density of a shapelet without a leg (eq. 9): 10⁻³, below c_L (eq. 10).
    alpha_L
        Non-normalising scale α_L of the leg-given-table density (eq. 5). Default
        (2δ)⁻³ = 15 625 for δ = 0.02: a leg exactly at its table's corner then has
        probability (2δ)³ α_L = 1 (eq. 19) — a table certainly has its four legs, and φ_a
        charges only for missing ones.
    alpha_S
        Non-normalising scale α_S of the shapelet-given-leg density (eq. 7). Default 10³,
        so a well-fitting shapelet is e^13.8 ≈ 10⁶ times better explained by a leg than by
        chance (α_S / c_S): one contact alone does not pay for a table, two or more do.
    epsilon
        The penalty ε of the constraint factors φ_b (two legs on one corner of one table,
        eq. 17) and φ_c (two overlapping tables or legs, eq. 16). Default e⁻⁴ ≈ 0.018:
        rival tables and doubled legs cost 4 nats each.
    epsilon_a
        The penalty ε of φ_a = ε^m (missing legs, eq. 15). The paper writes one ε for all
        three factors; with e⁻⁴ here a new table with one leg costs 12 nats more than it
        gains, is almost never accepted, and the search stalls. Since a leg at its
        table's corner is free ((2δ)³ α_L = 1), the MAP completes its tables for any
        ε_a < 1; ε_a only sets how easily half-built tables survive while annealing.
        Default e⁻¹.
    delta
        Half-width δ of a discrete hypothesis in x, y [m] and θ [rad] (eq. 19): a
        hypothesis has probability (2δ)³ p. Default 0.02 (2 cm, 1.1°).
    beta_min, beta_max, n_temperatures
        The annealing schedule: ``n_temperatures`` inverse temperatures β, geometric from
        ``beta_min`` to ``beta_max`` (eqs. 20–21 raise the blanket conditional to β).
        Defaults 0.1 → 3 over 40 temperatures: at β = 0.1 a hypothesis costing 10 nats is
        still accepted a quarter of the time; at β = 3 a move losing 2 nats is accepted
        0.25 % of the time, so the last sweeps climb to a local maximum of eq. 14 (and the
        driver keeps the best blackboard seen).
    r1, r2, r3
        Thresholds 0 < r1 < r2 < r3 < 1 that choose each hypothesis' move (Algorithm 1,
        whose second ``r < r2`` is r3): death with probability r1, parent change r2 − r1,
        child r3 − r2, new parent 1 − r3. Moves a hypothesis cannot make (a table has no
        parent, a leg's children are observed shapelets) are dropped and the others
        renormalised. Defaults 0.15, 0.35, 0.65.
    leg_jitter_theta
        Standard deviation [rad] of the angle noise added to a leg proposed from a
        shapelet (the shapelet's normal is itself noisy). Default 0.05.
    table_jitter_xy, table_jitter_theta
        Standard deviations [m], [rad] of the pose noise added to a table proposed as a
        leg's parent, so that repeated proposals explore poses fitting several legs.
        Defaults 0.01 m, 0.03 rad.
    parent_fit_weight
        λ ≥ 0 of the parent-table proposal: each of the eight tables a leg allows is drawn
        with weight exp(λ n), n the shapelets lying within ``leg_width + 2 σ_r`` of its
        other three corners. 0 is the paper's uniform choice; the default 3 makes a table
        that reaches two more contacts e⁶ ≈ 400 times likelier to be proposed. On three
        contacts from three legs of one table, 40 sweeps find the right table in about
        9 runs of 10 with it and 2 of 10 without it (docs/blackboard.md).
    parent_margin
        Tables whose centre lies within the table's half diagonal plus this margin [m] of
        a leg are its candidate parents for a parent change (the paper's "threshold radius
        in pose space", :attr:`parent_radius`). Default 0.2 m = 10 σ_r of eq. 6: farther
        tables have negligible p(L | T).
    memory_size
        Working memory: the number of most recent shapelets kept (§II-C: seven).
    max_hypotheses
        Safety cap on the blackboard's size; proposals that would exceed it are skipped.
        Default 400, far above what the schedule produces.
    """

    table_length: float = 1.0
    table_width: float = 0.6
    leg_width: float = 0.05
    sigma_r_leg: float = 0.02
    sigma_theta_leg: float = 0.1
    sigma_w: float = 0.01
    sigma_tau_leg: float = 0.1
    sigma_r_shapelet: float = 0.02
    sigma_theta_shapelet: float = 0.25
    sigma_tau_shapelet: float = 0.1
    c_T: float = 8e-3
    c_L: float = 2e-3
    c_S: float = 1e-3
    alpha_L: float = 15625.0
    alpha_S: float = 1e3
    epsilon: float = math.exp(-4.0)
    epsilon_a: float = math.exp(-1.0)
    delta: float = 0.02
    beta_min: float = 0.1
    beta_max: float = 3.0
    n_temperatures: int = 40
    r1: float = 0.15
    r2: float = 0.35
    r3: float = 0.65
    leg_jitter_theta: float = 0.05
    table_jitter_xy: float = 0.01
    table_jitter_theta: float = 0.03
    parent_fit_weight: float = 3.0
    parent_margin: float = 0.2
    memory_size: int = 7
    max_hypotheses: int = 400

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ConfigError(f"BlackboardParams.{f.name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ConfigError(f"BlackboardParams.{f.name} must be finite, got {value!r}")
        for name in _POSITIVE:
            if getattr(self, name) <= 0:
                raise ConfigError(
                    f"BlackboardParams.{name} must be > 0, got {getattr(self, name)!r}"
                )
        for name in _NON_NEGATIVE:
            if getattr(self, name) < 0:
                raise ConfigError(
                    f"BlackboardParams.{name} must be >= 0, got {getattr(self, name)!r}"
                )
        for name in ("n_temperatures", "memory_size", "max_hypotheses"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"BlackboardParams.{name} must be an integer >= 1, got {value!r}")
        if not 2 * self.leg_width < min(self.table_length, self.table_width):
            raise ConfigError(
                "BlackboardParams: two legs must fit along each table side "
                f"(2 × leg_width = {2 * self.leg_width} must be < table_width "
                f"{self.table_width} and table_length {self.table_length})"
            )
        if self.table_width > self.table_length:
            raise ConfigError(
                f"BlackboardParams: table_width {self.table_width} must be <= table_length "
                f"{self.table_length} (theta is the angle of the long side)"
            )
        for name in ("epsilon", "epsilon_a"):
            if not 0.0 < getattr(self, name) < 1.0:
                raise ConfigError(
                    f"BlackboardParams.{name} must be in (0, 1), got {getattr(self, name)!r}"
                )
        if not 0.0 < self.r1 < self.r2 < self.r3 < 1.0:
            raise ConfigError(
                "BlackboardParams thresholds must satisfy 0 < r1 < r2 < r3 < 1, got "
                f"r1={self.r1}, r2={self.r2}, r3={self.r3}"
            )
        if self.beta_min > self.beta_max:
            raise ConfigError(
                f"BlackboardParams.beta_min {self.beta_min} must be <= beta_max {self.beta_max}"
            )
        if not self.c_S < self.c_L < self.c_T:
            raise ConfigError(
                "BlackboardParams null priors must satisfy c_S < c_L < c_T (Fox & Prescott "
                f"2011 eq. 10), got c_S={self.c_S}, c_L={self.c_L}, c_T={self.c_T}"
            )

    @property
    def corner_offset(self) -> tuple[float, float]:
        """Leg-centre offsets ``(a, b)`` [m] from the table centre along its axes."""
        return (
            0.5 * (self.table_length - self.leg_width),
            0.5 * (self.table_width - self.leg_width),
        )

    @property
    def parent_radius(self) -> float:
        """Radius [m] of the candidate-parent look-up: half diagonal + ``parent_margin``."""
        return 0.5 * math.hypot(self.table_length, self.table_width) + self.parent_margin

    @property
    def log_box(self) -> float:
        """``log (2δ)³``: the log volume of a discrete hypothesis (eq. 19)."""
        return 3.0 * math.log(2.0 * self.delta)
