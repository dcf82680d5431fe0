"""The fused mapper's model: where a table may stand in the arena, and its densities against
their pair-by-pair computation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from bayesmap.blackboard.evidence import EvidenceStore
from bayesmap.blackboard.fused import FusedMapper
from bayesmap.blackboard.sweep_model import (
    ACROSS_CUT,
    ObjectType,
    SweepModel,
    arena_contains,
    contact_cutoff,
    contact_squares,
    into_arena,
    leg_centres,
    leg_contact_density,
    leg_contact_density_pairs,
    legs_swept,
    legs_swept_pairs,
    log_posterior,
    tables_overlap,
    wall_contact_density,
)
from bayesmap.experiments.fused_run import fused_params
from bayesmap.sim.tables_world import build_mixed
from bayesmap.sim.whiskers import condition, observe

CATALOGUE = (ObjectType("desk", 1.2, 0.8, 0.1), ObjectType("stool", 0.8, 0.8, 0.08))
ARENA = (5.0, 4.0)


def test_into_arena_moves_a_table_across_a_wall_the_least_distance_inside() -> None:
    # a desk turned 90° whose outline crosses the right wall by 2 cm and the floor by 1 cm
    table = np.array([[5.0 - 0.4 + 0.02, 0.6 - 0.01, 0.5 * math.pi, 0.0]])
    assert not arena_contains(table, CATALOGUE, ARENA)[0]
    inside, moved = into_arena(table, CATALOGUE, ARENA)
    assert arena_contains(inside, CATALOGUE, ARENA)[0]
    assert np.allclose(inside[0], [4.6, 0.6, 0.5 * math.pi, 0.0])
    assert math.isclose(moved[0], math.hypot(0.02, 0.01))


def test_into_arena_leaves_a_table_inside_alone_and_flags_one_that_cannot_fit() -> None:
    tables = np.array([[2.5, 2.0, 0.3, 1.0], [2.5, 2.0, 0.0, 0.0]])
    inside, moved = into_arena(tables, CATALOGUE, (5.0, 0.7))
    assert np.allclose(inside[0, 2:], tables[0, 2:])
    assert moved[1] == math.inf  # a desk 0.8 m wide cannot stand in a 0.7 m corridor
    same, still = into_arena(tables, CATALOGUE, ARENA)
    assert np.array_equal(same, tables)
    assert np.all(still == 0.0)


def _outline(table: np.ndarray) -> Polygon:
    kind = CATALOGUE[int(table[3])]
    c, s = math.cos(table[2]), math.sin(table[2])
    return Polygon(
        [
            (table[0] + c * u - s * v, table[1] + s * u + c * v)
            for u, v in (
                (0.5 * kind.length, 0.5 * kind.width),
                (-0.5 * kind.length, 0.5 * kind.width),
                (-0.5 * kind.length, -0.5 * kind.width),
                (0.5 * kind.length, -0.5 * kind.width),
            )
        ]
    )


@pytest.mark.parametrize("rows", [1, 3, 8, 9, 60])
def test_tables_overlap_matches_shapely_for_few_and_many_rows(rows: int) -> None:
    """Both ways of testing (pair by pair for a few rows, numpy passes for many) agree with
    the outlines' intersection area."""
    rng = np.random.default_rng(rows)
    for _ in range(40):
        p = np.array([*rng.uniform(0, 2.5, 2), rng.uniform(0, math.pi), rng.integers(2)])
        q = np.column_stack(
            [
                rng.uniform(0, 2.5, (rows, 2)),
                rng.uniform(0, math.pi, rows),
                rng.integers(2, size=rows),
            ]
        )
        want = [_outline(p).intersection(_outline(t)).area > 1e-12 for t in q]
        assert tables_overlap(p, q, CATALOGUE).tolist() == want


MODEL = SweepModel(0.02, 0.01, 0.1, 0.05, 0.05, 0.02, -math.inf, ARENA)
NOISY_MODEL = MODEL._replace(sigma_r=0.5, sigma_phi=math.pi / 8, reach=1.0)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _gauss(x: float, sigma: float) -> float:
    return math.exp(-0.5 * (x / sigma) ** 2) / (math.sqrt(2.0 * math.pi) * sigma)


def _leg_density_one(
    root: np.ndarray,
    psi: float,
    r_hat: float,
    phi_hat: float,
    leg: np.ndarray,
    theta: float,
    model: SweepModel,
) -> float:
    """ρ_leg of one contact under one leg, pair by pair on plain floats (the docstring of
    :func:`leg_contact_density`, with its three cuts)."""
    x, y, h = (float(v) for v in leg)
    dx, dy = float(root[0]) - x, float(root[1]) - y
    r_near = min(r_hat, model.reach)
    if math.hypot(dx + r_near * math.cos(psi), dy + r_near * math.sin(psi)) > contact_cutoff(
        h, model
    ):
        return 0.0
    if (
        abs(dx * math.sin(psi) - dy * math.cos(psi))
        > ACROSS_CUT * model.sigma_perp + math.sqrt(2.0) * h
    ):
        return 0.0
    c, s = math.cos(theta), math.sin(theta)
    ox, oy = c * dx + s * dy, c * dy - s * dx  # the root in the leg's frame
    ux, uy = c * math.cos(psi) + s * math.sin(psi), c * math.sin(psi) - s * math.cos(psi)
    ux = ux if abs(ux) >= 1e-12 else 1e-12
    uy = uy if abs(uy) >= 1e-12 else 1e-12
    slabs = [
        sorted(((-h - o) / u, (h - o) / u)) for o, u in ((ox, ux), (oy, uy))
    ]  # entry and exit of each slab along the line
    t_near, t_far = max(slabs[0][0], slabs[1][0]), min(slabs[0][1], slabs[1][1])
    if t_near <= t_far and t_near >= 0.0:
        along, e_perp, nearest = t_near, 0.0, t_near
    else:
        along = -(ox * ux + oy * uy)
        e_perp = max(abs(ux * oy - uy * ox) - h * (abs(ux) + abs(uy)), 0.0)
        nearest = along - math.sqrt(2.0) * h
    if nearest > model.reach or e_perp > ACROSS_CUT * model.sigma_perp:
        return 0.0
    faces = (math.pi if ux > 0 else 0.0, -0.5 * math.pi if uy > 0 else 0.5 * math.pi)
    d_phi = min(abs(_wrap(phi_hat - theta - face)) for face in faces)
    fold = _gauss(r_hat - along, model.sigma_r) + _gauss(r_hat + along, model.sigma_r)
    return fold * _gauss(e_perp, model.sigma_perp) * _gauss(d_phi, model.sigma_phi)


def _contacts_near_legs(
    rng: np.random.Generator, model: SweepModel
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """1–8 random legs (rows ``x, y, half side``) and their angles, and 1–59 contacts
    (whisker roots, bearings, ranges, face normals) aimed near random legs among them."""
    m, j = int(rng.integers(1, 60)), int(rng.integers(1, 9))
    legs = np.column_stack([rng.uniform(1.0, 3.0, (j, 2)), rng.uniform(0.03, 0.06, j)])
    theta = rng.uniform(0.0, math.pi, j)
    root = rng.uniform(0.5, 3.5, (m, 2))
    aim = legs[rng.integers(j, size=m), :2] - root
    bearing = np.arctan2(aim[:, 1], aim[:, 0]) + rng.normal(0.0, 0.03, m)
    r_hat = np.abs(np.hypot(aim[:, 0], aim[:, 1]) + rng.normal(0.0, model.sigma_r, m))
    phi_hat = rng.uniform(-math.pi, math.pi, m)
    return legs, theta, root, bearing, r_hat, phi_hat


@pytest.mark.parametrize("model", [MODEL, NOISY_MODEL], ids=["normal", "noisy"])
def test_leg_density_on_near_pairs_is_the_density_pair_by_pair(model: SweepModel) -> None:
    """The vectorised ρ_leg, which evaluates only the (contact, leg) pairs that pass the cheap
    cuts, equals the density computed pair by pair on plain floats, zeros included, on
    random contacts aimed near random legs."""
    rng = np.random.default_rng(11)
    for _ in range(40):
        legs, theta, root, bearing, r_hat, phi_hat = _contacts_near_legs(rng, model)
        j = len(legs)
        got = leg_contact_density(root, bearing, r_hat, phi_hat, legs, theta, model)
        want = np.array(
            [
                [
                    _leg_density_one(root[i], psi, r_hat[i], phi_hat[i], legs[k], theta[k], model)
                    for k in range(j)
                ]
                for i, psi in enumerate(bearing)
            ]
        )
        assert np.array_equal(got > 0, want > 0)
        assert np.allclose(got, want, rtol=1e-9, atol=0.0)
    assert (got > 0).any()


def test_free_space_on_pairs_within_reach_is_the_count_pair_by_pair() -> None:
    """:func:`legs_swept`, which computes angles only for (leg, sweep) pairs within reach,
    equals the sector test made pair by pair on plain floats."""
    rng = np.random.default_rng(12)
    margin = 0.01
    for _ in range(40):
        m, j = int(rng.integers(1, 80)), int(rng.integers(1, 9))
        legs = np.column_stack([rng.uniform(1.0, 3.0, (j, 2)), rng.uniform(0.03, 0.06, j)])
        root = rng.uniform(0.0, 4.0, (m, 2))
        start = rng.uniform(-4.0, 4.0, m)
        stop = start + rng.uniform(-2.0, 2.0, m)
        length = rng.uniform(0.5, 1.2, m)
        want = np.zeros((j, m))
        for k in range(j):
            for i in range(m):
                dx, dy = legs[k, 0] - root[i, 0], legs[k, 1] - root[i, 1]
                d, radius = math.hypot(dx, dy), math.sqrt(2.0) * legs[k, 2] + margin
                if not (d > radius and d - legs[k, 2] < length[i] - margin):
                    continue
                turn = _wrap(stop[i] - start[i])
                rel = _wrap(math.atan2(dy, dx) - start[i]) * (1.0 if turn >= 0 else -1.0)
                gamma = math.asin(min(radius / d, 1.0))
                want[k, i] = float(gamma <= rel <= abs(turn) - gamma)
        assert np.array_equal(legs_swept(legs, root, start, stop, length, margin), want)
    assert want.any()


@pytest.mark.parametrize("model", [MODEL, NOISY_MODEL], ids=["normal", "noisy"])
def test_pair_densities_are_the_grids_entries_bit_for_bit(model: SweepModel) -> None:
    """:func:`leg_contact_density_pairs` and :func:`legs_swept_pairs`, one row per (contact,
    leg) or (leg, sweep) pair, answer exactly (not just closely) what the contact × leg
    grids of :func:`leg_contact_density` and :func:`legs_swept` hold for those pairs, on
    random contacts aimed near random legs and random sweeps."""
    rng = np.random.default_rng(13)
    for _ in range(40):
        legs, theta, root, bearing, r_hat, phi_hat = _contacts_near_legs(rng, model)
        m, j = len(root), len(legs)
        grid = leg_contact_density(root, bearing, r_hat, phi_hat, legs, theta, model)
        i, k = rng.integers(m, size=3 * m), rng.integers(j, size=3 * m)  # pairs, repeats too
        pairs = leg_contact_density_pairs(
            root[i], bearing[i], r_hat[i], phi_hat[i], legs[k], theta[k], model
        )
        assert np.array_equal(pairs, grid[i, k])
        start = rng.uniform(-4.0, 4.0, m)
        stop = start + rng.uniform(-2.0, 2.0, m)
        length = rng.uniform(0.5, 1.2, m)
        swept = legs_swept(legs, root, start, stop, length)
        got = legs_swept_pairs(legs[k], root[i], start[i], stop[i], length[i])
        assert np.array_equal(got, swept[k, i])
    assert (grid > 0).any() and swept.any()


@pytest.mark.parametrize("reach", [0.3, 0.1 * 3, 0.7, 1.0])
def test_a_whisker_touching_with_its_tip_is_within_reach(reach: float) -> None:
    """A whisker first touches with its tip, at exactly its reach; rounding must not push
    the wall or leg beyond it (contacts of a corridor's walls were lost to clutter so)."""
    model = MODEL._replace(reach=reach)
    bearing = np.linspace(-1.2, 1.2, 241)
    tip = np.column_stack([np.full_like(bearing, ARENA[0]), np.full_like(bearing, 2.0)])
    root = tip - reach * np.column_stack([np.cos(bearing), np.sin(bearing)])
    r_hat, phi_hat = np.full_like(bearing, reach), np.full_like(bearing, math.pi)
    assert (wall_contact_density(root, bearing, r_hat, phi_hat, model) > 0).all()
    farther = root - 1e-4 * np.column_stack([np.cos(bearing), np.sin(bearing)])
    assert (wall_contact_density(farther, bearing, r_hat, phi_hat, model) == 0).all()
    leg = np.array([[1.0, 2.0, 0.05]])  # x, y, half side: the tip touches its west face
    root = np.array([[1.0 - 0.05 - reach, 2.0]])
    one = np.array([reach])
    density = leg_contact_density(
        root, np.zeros(1), one, np.array([math.pi]), leg, np.zeros(1), model
    )
    assert density.shape == (1, 1) and density[0, 0] > 0


def test_a_solid_box_is_one_square_with_no_seams() -> None:
    """Whiskers touch a square type whose legs are half its side on one square, the
    object: its four legs would have corners at the seams, mid-face, where no whisker
    stops. With them, two boxes half a side apart (their seams on the true corners)
    explained a box's contacts better than the box itself; now the box scores higher."""
    box = ObjectType("box", 0.5, 0.5, 0.25)
    assert box.solid and not ObjectType("stool", 0.8, 0.8, 0.08).solid
    assert box.contact_half_side == 0.25
    at = np.array([[2.0, 2.0, 0.3, 0.0]])
    assert contact_squares(at, (box,))[0].tolist() == [[2.0, 2.0, 0.25]] * 4
    assert leg_centres(at, (box,))[0, :, 2].tolist() == [0.125] * 4  # F3's four quarters
    sensor = condition("normal")
    model = FusedMapper((box,), (4.0, 4.0), fused_params(sensor)).model
    margins = []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        truth = np.array([2.0, 2.0, rng.uniform(0.0, 0.5 * math.pi), 0.0])
        world = build_mixed(
            truth[None, :3], np.array([[0.5, 0.5, 0.25]]), np.array([0.3]), (4.0, 4.0)
        )
        store = EvidenceStore()
        for angle in np.linspace(0.0, 2.0 * math.pi, 10, endpoint=False):
            for heading in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi):
                pose = np.array(
                    [2.0 + 0.85 * math.cos(angle), 2.0 + 0.85 * math.sin(angle), heading]
                )
                store.add(pose, observe(world, pose, sensor, rng=rng).sweeps)
        half = 0.25 * np.array([math.cos(truth[2]), math.sin(truth[2]), 0.0, 0.0])
        pair = np.vstack([truth - half, truth + half])
        margins.append(
            log_posterior(truth[None], (box,), model, store.rows_, store.counts_)
            - log_posterior(pair, (box,), model, store.rows_, store.counts_)
        )
    assert min(margins) > 10.0, margins
