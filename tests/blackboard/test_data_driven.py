"""The fused mapper's leg detector: where whisked contacts put a leg's centre."""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from bayesmap.blackboard.data_driven import (
    LegVotes,
    _supported_corners,
    fit_to_corner_bearings,
    place_on_legs,
    polish_leg,
    polish_legs,
    polish_table,
    polish_tables,
    table_candidates,
)
from bayesmap.blackboard.fused import FusedMapper
from bayesmap.blackboard.sweep_model import (
    ObjectType,
    SweepModel,
    arena_contains,
    leg_centres,
    wall_contact_density,
)
from bayesmap.experiments.fused_run import fused_params
from bayesmap.sim.tables_world import build_mixed
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
    arena, truth, catalogue, model, contacts, floor = _noisy_desk_tour()
    counts = np.ones(len(contacts))
    legs = leg_centres(truth, catalogue)[0, :, :2]
    offsets = ([0.03, -0.02], [-0.02, -0.03], [0.0, 0.04], [-0.035, 0.0])
    for leg, off in zip(legs, offsets, strict=True):
        start = np.array([leg[0] + off[0], leg[1] + off[1], truth[2]])
        out = polish_leg(start, contacts, counts, floor, 0.05, model)
        assert math.hypot(out[0] - leg[0], out[1] - leg[1]) < 0.015
        assert 0.0 <= out[2] < 0.5 * math.pi


TWO_TYPES = (ObjectType("desk", 1.2, 0.8, 0.1), ObjectType("stool", 0.8, 0.8, 0.08))


def test_placement_on_exact_legs_recovers_the_table_from_any_two_to_four_corners() -> None:
    """Random tables of both types at any angle, their candidate started 3 cm and 0.04 rad
    off: placed on the exact legs of two adjacent corners, two diagonal ones, three or all
    four (the other legs absent), the table comes back to 1e-9."""
    rng = np.random.default_rng(11)
    subsets = ([0, 1], [1, 2], [0, 2], [1, 3], [0, 1, 3], [0, 1, 2, 3])
    for _ in range(40):
        truth = np.array([rng.uniform(2, 4), rng.uniform(2, 4), rng.uniform(0, math.pi), 0.0])
        truth[3] = float(rng.integers(2))
        corners = leg_centres(truth, TWO_TYPES)[0, :, :2]
        start = truth + np.array([0.03, -0.02, 0.04, 0.0])
        for subset in subsets:
            out = place_on_legs(start, corners[subset], TWO_TYPES, 0.1)[0]
            assert math.hypot(out[0] - truth[0], out[1] - truth[1]) < 1e-9
            period = 0.5 * math.pi if truth[3] == 1 else math.pi
            turn = (out[2] - truth[2]) % period
            assert min(turn, period - turn) < 1e-9


def test_placement_is_the_least_squares_fit_of_the_corners_to_noisy_legs() -> None:
    """With legs scattered by 1.5 cm, the closed form equals a numerical least-squares fit of
    the supported corners to their legs (scipy's least_squares from the candidate)."""
    rng = np.random.default_rng(12)
    for _ in range(30):
        truth = np.array([3.0, 3.0, rng.uniform(0, math.pi), float(rng.integers(2))])
        subset = rng.permutation(4)[: int(rng.integers(2, 5))]
        legs = leg_centres(truth, TWO_TYPES)[0, subset, :2] + rng.normal(0, 0.015, (len(subset), 2))
        out = place_on_legs(truth, legs, TWO_TYPES, 0.1)[0]

        def residuals(v: np.ndarray, kind: float, subset: np.ndarray, legs: np.ndarray):
            table = np.array([v[0], v[1], v[2], kind])
            return (leg_centres(table, TWO_TYPES)[0, subset, :2] - legs).ravel()

        fit = optimize.least_squares(
            residuals, truth[:3], args=(truth[3], subset, legs), xtol=1e-12, ftol=1e-12
        ).x
        assert math.hypot(out[0] - fit[0], out[1] - fit[1]) < 1e-6
        period = 0.5 * math.pi if truth[3] == 1 else math.pi
        turn = (out[2] - fit[2]) % period
        assert min(turn, period - turn) < 1e-6


def test_placement_on_fitted_legs_lands_where_the_polish_does() -> None:
    """A desk seen on a whole noisy tour (σ_r = 0.5 m, exact bearings), its legs fitted from
    3–4 cm off (polish_leg) and paired into candidates: each candidate placed on the fitted
    legs in closed form lies within 1.5 cm and 0.015 rad of where a full polish of the
    contacts (polish_table, widened then at the model's scales) takes the same candidate,
    and both within 2 cm and 0.02 rad of the truth."""
    arena, truth, catalogue, model, contacts, floor = _noisy_desk_tour()
    counts = np.ones(len(contacts))
    offsets = ([0.03, -0.02], [-0.02, -0.03], [0.0, 0.04], [-0.035, 0.0])
    fitted = np.array(
        [
            polish_leg(np.array([x + dx, y + dy, truth[2]]), contacts, counts, floor, 0.05, model)
            for (x, y), (dx, dy) in zip(
                leg_centres(truth, catalogue)[0, :, :2], offsets, strict=True
            )
        ]
    )
    candidates, _ = table_candidates(fitted, catalogue, arena, 0.06)
    turned = (candidates[:, 2] - truth[2]) % math.pi
    near = (np.hypot(candidates[:, 0] - truth[0], candidates[:, 1] - truth[1]) < 0.1) & (
        np.minimum(turned, math.pi - turned) < 0.1
    )
    assert near.sum() >= 4  # the true desk from each of its sides and diagonals
    for candidate in candidates[near]:
        placed = place_on_legs(candidate, fitted, catalogue, 0.06)[0]
        polished = polish_table(candidate, contacts, counts, floor, catalogue, model)
        for table, xy, angle in ((polished, 0.015, 0.015), (truth, 0.02, 0.02)):
            assert math.hypot(placed[0] - table[0], placed[1] - table[1]) < xy
            turn = (placed[2] - table[2]) % math.pi
            assert min(turn, math.pi - turn) < angle


def _tour_contacts(world_file, world, sensor, rng) -> np.ndarray:
    """Every contact of the world file's tour as rows ``root x, y, bearing, r, normal``."""
    rows = []
    for pose in world_file.robot_poses():
        sweeps = observe(world, pose, sensor, rng=rng).sweeps
        hit = sweeps[np.isfinite(sweeps[:, 3])]
        rows.append(np.column_stack([np.tile(pose[:2], (len(hit), 1)), hit[:, [1, 3, 4]]]))
    return np.concatenate(rows)


def _noisy_desk_tour() -> tuple[
    tuple[float, float], np.ndarray, tuple[ObjectType, ...], SweepModel, np.ndarray, np.ndarray
]:
    """A desk in a 5 m room seen on a whole tour under the noisy condition: the arena, the
    desk, its catalogue, the mapper's model, every contact and each contact's floor density
    (clutter or a wall, whichever explains it better)."""
    arena = (5.0, 5.0)
    truth = np.array([2.4, 2.6, 0.3, 0.0])
    world_file = WorldFile(
        arena, np.array([[*truth[:3], 1.2, 0.8, 0.1, 0.3]]), catalogue=(("desk", 1.2, 0.8, 0.1),)
    )
    catalogue = (ObjectType("desk", 1.2, 0.8, 0.1),)
    world, sensor = world_file.world(), condition("noisy")
    model = FusedMapper(catalogue, arena, fused_params(sensor)).model
    contacts = _tour_contacts(world_file, world, sensor, np.random.default_rng(5))
    floor = np.maximum(
        model.clutter,
        wall_contact_density(
            contacts[:, :2], contacts[:, 2], contacts[:, 3], contacts[:, 4], model
        ),
    )
    return arena, truth, catalogue, model, contacts, floor


def test_candidate_weights_count_the_corners_a_leg_supports() -> None:
    """A candidate's weight is e^{2(m − 2)}, m its corners with a candidate leg within the
    spacing tolerance: against a corner-by-corner, leg-by-leg count on random legs."""
    catalogue = (ObjectType("desk", 1.2, 0.8, 0.1), ObjectType("stool", 0.8, 0.8, 0.08))
    rng = np.random.default_rng(5)
    for _ in range(5):
        legs = np.column_stack([rng.uniform(0.0, 4.0, (40, 2)), np.ones(40)])
        tables, weights = table_candidates(legs, catalogue, (4.0, 4.0), 0.12)
        assert len(tables) > 0
        corners = leg_centres(tables, catalogue)
        for table_corners, weight in zip(corners, weights, strict=True):
            m = sum(
                any(math.hypot(cx - lx, cy - ly) < 0.12 for lx, ly, _ in legs)
                for cx, cy, _ in table_corners
            )
            assert weight == math.exp(2.0 * (m - 2.0))


def test_corner_support_from_nearby_legs_is_the_support_from_every_leg() -> None:
    """:func:`~bayesmap.blackboard.data_driven._supported_corners`, which tests blocks of
    tables against the legs near them only, answers exactly what the test against every leg
    answers, on random corners and legs (many blocks) and on legs placed a hair inside and
    outside the tolerance of a corner."""
    rng = np.random.default_rng(23)
    tol = 0.12
    for _ in range(5):
        corners = rng.uniform(0.0, 6.0, (300, 4, 2))
        legs = rng.uniform(0.0, 6.0, (180, 2))
        angle = rng.uniform(0.0, 2.0 * math.pi, 40)
        hair = tol * np.where(np.arange(40) % 2 == 0, 1.0 - 1e-12, 1.0 + 1e-12)
        legs = np.vstack(
            [
                legs,
                corners[:40, 0] + hair[:, None] * np.column_stack([np.cos(angle), np.sin(angle)]),
            ]
        )
        dx = corners[:, :, None, 0] - legs[:, 0]
        dy = corners[:, :, None, 1] - legs[:, 1]
        want = np.sqrt((dx * dx + dy * dy).min(axis=2)) < tol
        assert np.array_equal(_supported_corners(corners, legs, tol), want)
        assert want[:40, 0].any() and want.sum() < want.size
    assert not _supported_corners(corners, np.zeros((0, 2)), tol).any()


def test_polishing_many_candidates_in_lockstep_is_polishing_each_alone() -> None:
    """:func:`polish_tables` and :func:`polish_legs` step all their candidates' Nelder–Mead
    runs together (one density call per step): each result equals, bit for bit, the polish
    of that candidate alone, from random starts a few centimetres off the noisy desk and its
    legs, far from it, and with no contacts at all."""
    arena, truth, catalogue, model, contacts, floor = _noisy_desk_tour()
    counts = np.ones(len(contacts))
    rng = np.random.default_rng(17)
    starts = truth + np.column_stack(
        [rng.normal(0.0, 0.04, (8, 2)), rng.normal(0.0, 0.03, 8), np.zeros(8)]
    )
    starts[-1, :2] = (0.9, 4.0)  # no whisker line near its legs
    sets = [contacts] * 7 + [contacts[:0]]
    order = rng.permutation(8)
    for widen, evals in (((1.0,), 12), ((4.0, 1.0), 24)):
        together = polish_tables(
            starts[order],
            [sets[i] for i in order],
            [counts[: len(sets[i])] for i in order],
            [floor[: len(sets[i])] for i in order],
            catalogue,
            model,
            widen=widen,
            max_evals=evals,
        )
        for got, i in zip(together, order, strict=True):
            alone = polish_table(
                starts[i],
                sets[i],
                counts[: len(sets[i])],
                floor[: len(sets[i])],
                catalogue,
                model,
                widen=widen,
                max_evals=evals,
            )
            assert np.array_equal(got, alone)
    legs = leg_centres(truth, catalogue)[0, rng.integers(4, size=8), :2]
    legs = np.column_stack([legs + rng.normal(0.0, 0.03, (8, 2)), rng.uniform(0, 1.5, 8)])
    n = [len(c) for c in sets]
    together = polish_legs(legs, sets, [counts[:k] for k in n], [floor[:k] for k in n], 0.05, model)
    for got, leg, k in zip(together, legs, n, strict=True):
        alone = polish_leg(leg, contacts[:k], counts[:k], floor[:k], 0.05, model)
        assert np.array_equal(got, alone)
    assert np.array_equal(together[-1], legs[-1])  # no contacts: the start
    assert not np.array_equal(together[0], legs[0])


def _box_contacts(box: np.ndarray, side: float, sensor_name: str, seed: int) -> np.ndarray:
    """Contacts ``root x, root y, bearing, r̂, length`` of a tour around one solid box."""
    world = build_mixed(
        box[None, :3], np.array([[side, side, 0.5 * side]]), np.array([0.3]), (6.0, 6.0)
    )
    sensor, rng = condition(sensor_name), np.random.default_rng(seed)
    rows = []
    for angle in np.linspace(0.0, 2.0 * math.pi, 12, endpoint=False):
        for heading in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi):
            pose = np.array(
                [*(box[:2] + 0.9 * np.array([math.cos(angle), math.sin(angle)])), heading]
            )
            sweeps = observe(world, pose, sensor, rng=rng).sweeps
            hit = np.isfinite(sweeps[:, 3])
            rows.append(
                np.column_stack([np.tile(pose[:2], (hit.sum(), 1)), sweeps[hit][:, [1, 3, 2]]])
            )
    return np.concatenate(rows)


def test_a_solid_box_is_fitted_onto_its_corners_bearings() -> None:
    """Started a centimetre and a few degrees off, the fit puts the box where its corner
    contacts' bearings cross, to a tenth of a millimetre, though the ranges carry σ_r and
    contacts that stopped on a face or another object (here: made-up ones) are mixed in."""
    box = np.array([3.0, 3.0, 0.4, 0.0])
    contacts = _box_contacts(box, 0.5, "normal", 1)
    rng = np.random.default_rng(0)
    strays = np.column_stack(
        [
            rng.uniform(2.0, 4.0, (20, 2)),
            rng.uniform(-math.pi, math.pi, 20),
            rng.uniform(0.2, 0.9, 20),
            np.ones(20),
        ]
    )
    contacts = np.vstack([contacts, strays])
    start = box + np.array([0.008, -0.006, 0.04, 0.0])
    fitted = fit_to_corner_bearings(start, contacts, np.ones(len(contacts)), 0.25, 0.02)
    assert np.abs(fitted[:2] - box[:2]).max() < 1e-4
    assert abs(math.remainder(fitted[2] - box[2], 0.5 * math.pi)) < 1e-3
    assert fitted[3] == 0.0
    # too few contacts to pin it: returned as it was
    assert np.array_equal(
        fit_to_corner_bearings(start, contacts[:2], np.ones(2), 0.25, 0.02), start
    )
