"""The fused mapper's leg detector: where whisked contacts put a leg's centre."""

from __future__ import annotations

import math

import numpy as np

from bayesmap.blackboard.data_driven import LegVotes, polish_leg, polish_table, table_candidates
from bayesmap.blackboard.fused import FusedMapper
from bayesmap.blackboard.sweep_model import (
    ObjectType,
    arena_contains,
    leg_centres,
    wall_contact_density,
)
from bayesmap.experiments.fused_run import fused_params
from bayesmap.sim.whisker_worlds import StressOptions, WorldFile, generate_world
from bayesmap.sim.whiskers import condition, observe

LEG_HALF = 0.05


def _one_leg_votes(sigma_r: float, offsets: np.ndarray) -> LegVotes:
    """Votes of whiskers that swept onto the corner (−h, −h) of an axis-aligned square leg
    centred at (3, 3), with the reported normal of the face turned to each root."""
    votes = LegVotes((6.0, 6.0), sigma_r, LEG_HALF, reach=1.0)
    corner = np.array([3.0 - LEG_HALF, 3.0 - LEG_HALF])
    # below and right of the leg, a clockwise sweep meets that corner first on the lower
    # face (normal −y); above and left, a counter-clockwise sweep meets it on the left
    # face (normal −x): either way the rest of the leg lies ahead of the shaft
    roots = np.array([[3.5, 2.3], [3.3, 2.2], [2.3, 3.4]])
    turn = np.array([-1.0, -1.0, 1.0])
    normal = np.array([-0.5 * math.pi, -0.5 * math.pi, math.pi])
    to_corner = corner - roots
    bearing = np.arctan2(to_corner[:, 1], to_corner[:, 0])
    r_hat = np.hypot(to_corner[:, 0], to_corner[:, 1]) + offsets
    votes.add(roots, bearing, r_hat, np.ones(3), bearing - 0.4 * turn, normal)
    return votes


def test_corner_contacts_vote_for_the_legs_centre_not_half_a_leg_behind_the_corner() -> None:
    votes = _one_leg_votes(0.02, np.zeros(3))
    peaks = votes.peaks((0.0, 0.0, 6.0, 6.0), 1.5)
    best = peaks[np.argmax(peaks[:, 2])]
    assert math.hypot(best[0] - 3.0, best[1] - 3.0) < 0.02


def test_noisy_bearings_cross_at_the_legs_centre() -> None:
    """σ_r = 0.5 m: every range is decimetres off, but the three bearings through the leg's
    corner, each shifted by the corner's offset from the centre, cross at the centre."""
    votes = _one_leg_votes(0.5, np.array([0.45, -0.3, 0.3]))
    peaks = votes.peaks((0.0, 0.0, 6.0, 6.0), 1.5)
    best = peaks[np.argmax(peaks[:, 2])]
    assert math.hypot(best[0] - 3.0, best[1] - 3.0) < 0.04


def _peak_errors(world_seed: int, name: str, min_votes: float) -> np.ndarray:
    """Distance [m] from each true leg to the nearest detected leg (legs found within
    0.15 m), after the whole tour of a generated stress world."""
    world_file = generate_world(np.random.default_rng(world_seed), StressOptions())
    world, sensor = world_file.world(), condition(name)
    votes = LegVotes(
        world_file.arena,
        max(sensor.sigma_r, 0.02),
        0.5 * min(c[3] for c in world_file.catalogue),
        sensor.whisker_length,
    )
    rng = np.random.default_rng(1)
    for pose in world_file.robot_poses():
        sweeps = observe(world, pose, sensor, rng=rng).sweeps
        c = sweeps[np.isfinite(sweeps[:, 3])]
        roots = np.tile(pose[:2], (len(c), 1))
        votes.add(roots, c[:, 1], c[:, 3], np.ones(len(c)), c[:, 0], c[:, 4])
    peaks = votes.peaks((0.0, 0.0, *world_file.arena), min_votes)
    t = world_file.tables
    half_a, half_b = 0.5 * (t[:, 3] - t[:, 5]), 0.5 * (t[:, 4] - t[:, 5])
    legs = []
    for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        c, s = np.cos(t[:, 2]), np.sin(t[:, 2])
        lx, ly = sx * half_a, sy * half_b
        legs.append(np.column_stack([t[:, 0] + c * lx - s * ly, t[:, 1] + s * lx + c * ly]))
    true = np.concatenate(legs)
    gaps = np.linalg.norm(true[:, None] - peaks[None, :, :2], axis=-1).min(axis=1)
    return gaps[gaps < 0.15]


def test_leg_peaks_of_a_whole_tour_sit_on_the_legs() -> None:
    """On a generated stress world (two leg sizes, the detector assumes the smaller), the
    detected legs lie on average within 2.5 cm of the true centres (half a leg beyond each
    contact's range put them about 5 cm off)."""
    errors = _peak_errors(5, "normal", 1.5)
    assert len(errors) >= 20
    assert errors.mean() < 0.025


def test_a_table_pressed_into_a_corner_is_proposed_though_its_legs_are_found_across_the_walls() -> (
    None
):
    """A desk turned 90° touching the floor and the right wall (1 mm gaps): its two inner
    legs, found 1.5 cm too far towards the walls, imply a desk crossing both; the candidate
    stands inside, against the walls, instead of being dropped."""
    catalogue = (ObjectType("desk", 1.2, 0.8, 0.1),)
    arena = (5.5, 6.0)
    truth = np.array([5.5 - 0.401, 0.601, 0.5 * math.pi, 0.0])
    legs = leg_centres(truth, catalogue)[0, :, :2]
    found = legs[[0, 3]] + np.array([0.015, -0.015])  # the two legs off the floor
    candidates, _ = table_candidates(np.column_stack([found, np.ones(2)]), catalogue, arena, 0.06)
    assert arena_contains(candidates, catalogue, arena).all()
    near = np.hypot(candidates[:, 0] - truth[0], candidates[:, 1] - truth[1]) < 0.03
    assert near.any()


def test_polish_keeps_a_desk_pressed_into_a_corner_where_it_stands() -> None:
    """A desk touching the floor and the right wall (1 mm gaps), seen on a whole tour with
    normal noise, its candidate 2–3 cm across both walls: polished, it stands inside the
    arena within 1.5 cm and 0.01 rad of the truth (a table left across a wall has zero
    prior, and the candidate would be lost)."""
    arena = (5.5, 6.0)
    truth = np.array([5.5 - 0.401, 0.601, 0.5 * math.pi, 0.0])
    world_file = WorldFile(
        arena, np.array([[*truth[:3], 1.2, 0.8, 0.1, 0.3]]), catalogue=(("desk", 1.2, 0.8, 0.1),)
    )
    catalogue = (ObjectType("desk", 1.2, 0.8, 0.1),)
    world, sensor = world_file.world(), condition("normal")
    model = FusedMapper(catalogue, arena, fused_params(sensor)).model  # the mapper's own model
    rng = np.random.default_rng(3)
    contacts = _tour_contacts(world_file, world, sensor, rng)
    contacts = contacts[np.hypot(contacts[:, 0] - truth[0], contacts[:, 1] - truth[1]) < 2.0]
    floor = np.maximum(
        model.clutter,
        wall_contact_density(
            contacts[:, :2], contacts[:, 2], contacts[:, 3], contacts[:, 4], model
        ),
    )
    counts = np.ones(len(contacts))
    start = truth + np.array([0.02, -0.03, 0.04, 0.0])
    out = polish_table(start, contacts, counts, floor, catalogue, model)
    assert arena_contains(out, catalogue, arena)[0]
    assert math.hypot(out[0] - truth[0], out[1] - truth[1]) < 0.015
    assert abs(out[2] - truth[2]) < 0.01


def test_polish_leg_moves_a_noisy_leg_peak_onto_the_leg() -> None:
    """A desk seen on a whole tour under the noisy condition (σ_r = 0.5 m, exact bearings):
    each leg's candidate started 3–4 cm off is fitted to within 1.5 cm of the leg's centre
    by its contacts' bearings alone."""
    arena = (5.0, 5.0)
    truth = np.array([2.4, 2.6, 0.3, 0.0])
    world_file = WorldFile(
        arena, np.array([[*truth[:3], 1.2, 0.8, 0.1, 0.3]]), catalogue=(("desk", 1.2, 0.8, 0.1),)
    )
    catalogue = (ObjectType("desk", 1.2, 0.8, 0.1),)
    world, sensor = world_file.world(), condition("noisy")
    model = FusedMapper(catalogue, arena, fused_params(sensor)).model
    rng = np.random.default_rng(5)
    contacts = _tour_contacts(world_file, world, sensor, rng)
    floor = np.maximum(
        model.clutter,
        wall_contact_density(
            contacts[:, :2], contacts[:, 2], contacts[:, 3], contacts[:, 4], model
        ),
    )
    counts = np.ones(len(contacts))
    legs = leg_centres(truth, catalogue)[0, :, :2]
    offsets = ([0.03, -0.02], [-0.02, -0.03], [0.0, 0.04], [-0.035, 0.0])
    for leg, off in zip(legs, offsets, strict=True):
        start = np.array([leg[0] + off[0], leg[1] + off[1], truth[2]])
        out = polish_leg(start, contacts, counts, floor, 0.05, model)
        assert math.hypot(out[0] - leg[0], out[1] - leg[1]) < 0.015
        assert 0.0 <= out[2] < 0.5 * math.pi


def _tour_contacts(world_file, world, sensor, rng) -> np.ndarray:
    """Every contact of the world file's tour as rows ``root x, y, bearing, r, normal``."""
    rows = []
    for pose in world_file.robot_poses():
        sweeps = observe(world, pose, sensor, rng=rng).sweeps
        hit = sweeps[np.isfinite(sweeps[:, 3])]
        rows.append(np.column_stack([np.tile(pose[:2], (len(hit), 1)), hit[:, [1, 3, 4]]]))
    return np.concatenate(rows)
