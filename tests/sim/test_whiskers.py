"""The tables microworld and the whisker simulator (Fox & Prescott 2011 §II-A, §III)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bayesmap.errors import ConfigError, InputError, ModelError
from bayesmap.geometry import wrap_angle
from bayesmap.sim.tables_world import (
    WALL,
    WorldParams,
    build,
    initial,
    leg_centres,
    pose_sequence,
    rectangle_corners,
    world_params,
)
from bayesmap.sim.whiskers import NO_CONTACT, WhiskerParams, condition, h, observe

PARAMS = world_params("whisker-tables-v1")
WHISKERS = WhiskerParams()


@pytest.fixture(scope="module")
def world():
    return initial(PARAMS, rng=np.random.default_rng(7))


def _leg_square(world, table, leg):
    p = world.params
    centre = leg_centres(world.tables[table], p.table_length, p.table_width, p.leg_width)[0, leg]
    return rectangle_corners(centre[0], centre[1], world.tables[table, 2], p.leg_width, p.leg_width)


def _distance_to_polygon(point, corners):
    a, b = corners, np.roll(corners, -1, axis=0)
    e = b - a
    u = np.clip(np.einsum("ij,ij->i", point - a, e) / np.einsum("ij,ij->i", e, e), 0, 1)
    return np.min(np.hypot(*(a + u[:, None] * e - point).T))


def _first_hit_brute_force(world, pose, whisker, params, steps=1500):
    """Rotate the whisker in small steps; return the first ray hit (oracle for h)."""
    rest = pose[2] + params.rest_angles[whisker]
    side = math.copysign(1.0, params.rest_angles[whisker])
    angles = rest + side * params.sweep - side * np.linspace(0, 2 * params.sweep, steps)
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    a, e = world.segments[:, :2], world.segments[:, 2:] - world.segments[:, :2]
    q = a[None] - pose[:2]
    den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (q[..., 0] * e[None, :, 1] - q[..., 1] * e[None, :, 0]) / den
        u = (q[..., 0] * d[:, None, 1] - q[..., 1] * d[:, None, 0]) / den
    t = np.where((t >= 0) & (t <= params.whisker_length) & (u >= 0) & (u <= 1), t, np.inf)
    best = t.min(axis=1)
    hits = np.flatnonzero(np.isfinite(best))
    if not len(hits):
        return None
    i = hits[0]
    return pose[:2] + best[i] * d[i]


def test_world_is_deterministic_and_keeps_its_gaps(world):
    again = initial(PARAMS, rng=np.random.default_rng(7))
    np.testing.assert_array_equal(world.tables, again.tables)
    assert world.tables.shape == (6, 3)
    corners = rectangle_corners(*world.tables.T, PARAMS.table_length, PARAMS.table_width)
    assert corners.min() >= PARAMS.wall_clearance
    assert corners.max() <= PARAMS.arena_size - PARAMS.wall_clearance
    centres = world.tables[:, :2]
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1) + 99 * np.eye(6)
    assert gaps.min() >= math.hypot(PARAMS.table_length, PARAMS.table_width)
    legs = leg_centres(world.tables, PARAMS.table_length, PARAMS.table_width, PARAMS.leg_width)
    positions = pose_sequence(PARAMS)[:, :2]
    assert np.linalg.norm(positions[:, None] - legs.reshape(-1, 2)[None], axis=-1).min() > 0.2
    assert not np.array_equal(world.tables, initial(PARAMS, rng=np.random.default_rng(8)).tables)


def test_a_layout_that_dead_ends_is_started_again():
    # SeedSequence(2014)'s world stream places five tables that leave no room for a sixth
    stream = np.random.default_rng(np.random.SeedSequence(2014).spawn(1)[0])
    world = initial(PARAMS, rng=stream)
    assert world.tables.shape == (6, 3)
    centres = world.tables[:, :2]
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1) + 99 * np.eye(6)
    assert gaps.min() >= math.hypot(PARAMS.table_length, PARAMS.table_width)
    crowded = replace(PARAMS, n_tables=12)
    with pytest.raises(ModelError, match="could not place 12 tables"):
        initial(crowded, rng=np.random.default_rng(0))


def test_segments_have_outward_normals_and_labels(world):
    assert len(world.segments) == 6 * 16 + 4
    assert (world.table == WALL).sum() == 4
    mid = 0.5 * (world.segments[:, :2] + world.segments[:, 2:])
    outward = mid + 1e-3 * np.column_stack([np.cos(world.normal), np.sin(world.normal)])
    for k in np.flatnonzero(world.table >= 0):
        square = _leg_square(world, world.table[k], world.leg[k])
        centre = square.mean(axis=0)
        assert np.linalg.norm(outward[k] - centre) > np.linalg.norm(mid[k] - centre)
    walls = world.table == WALL
    assert np.all((outward[walls] > 0) & (outward[walls] < PARAMS.arena_size))


def test_pose_sequence_is_the_fixed_serpentine_tour():
    poses = pose_sequence(PARAMS)
    assert poses.shape == (400, 3)
    positions = poses[::4, :2]
    assert len(np.unique(positions, axis=0)) == 100
    np.testing.assert_allclose(poses[:4, 2], [0, np.pi / 2, np.pi, 3 * np.pi / 2])
    np.testing.assert_array_equal(poses[0::4, :2], poses[3::4, :2])
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    spacing = (PARAMS.arena_size - 2 * PARAMS.grid_margin) / (PARAMS.grid_size - 1)
    np.testing.assert_allclose(steps, spacing)


def test_contacts_lie_on_the_touched_leg_with_its_face_normal(world):
    for pose in pose_sequence(PARAMS)[::3]:
        c = h(world, pose, WHISKERS)
        assert np.all(c.r[c.hit] <= WHISKERS.whisker_length + 1e-9)
        for w in np.flatnonzero(c.table >= 0):
            square = _leg_square(world, c.table[w], c.leg[w])
            assert _distance_to_polygon(c.point[w], square) < 1e-9
            face = np.mod(c.normal[w] - world.tables[c.table[w], 2], np.pi / 2)
            assert min(face, np.pi / 2 - face) < 1e-9
            towards_root = pose[:2] - c.point[w]
            assert np.dot([np.cos(c.normal[w]), np.sin(c.normal[w])], towards_root) > 0
        assert np.all(c.table[~c.hit] == NO_CONTACT)


def test_first_contact_matches_a_brute_force_sweep(world):
    poses = pose_sequence(PARAMS)
    checked = 0
    for pose in poses[::13]:
        c = h(world, pose, WHISKERS)
        for w in range(len(WHISKERS.rest_angles)):
            oracle = _first_hit_brute_force(world, pose, w, WHISKERS)
            if oracle is None:
                assert not c.hit[w]
                continue
            assert c.hit[w]
            # one sweep step moves the tip by 2·sweep/steps·length ≈ 1 mm
            assert np.linalg.norm(oracle - c.point[w]) < 0.02
            checked += 1
    assert checked > 50


def test_wall_contact_by_hand():
    walls_only = build(np.zeros((0, 3)), WorldParams(n_tables=0))
    pose = np.array([5.5, 3.0, 0.0])
    c = h(walls_only, pose, WHISKERS)
    assert np.all(c.table[c.hit] == WALL)
    np.testing.assert_allclose(c.point[c.hit, 0], 6.0)
    # the east wall faces −x: its normal is −π in the one convention, [−π, π)
    np.testing.assert_array_equal(c.normal[c.hit], -np.pi)
    # the ±12° whiskers start 57° off the heading and already reach the wall there
    start = np.radians(57.0)
    np.testing.assert_allclose(c.r[2], 0.5 / math.cos(start))
    np.testing.assert_allclose(c.point[2, 1], 3.0 + 0.5 * math.tan(start))
    centre = h(walls_only, np.array([3.0, 3.0, 0.0]), WHISKERS)
    assert not centre.hit.any()


def test_contact_statistics_match_the_paper():
    """Fox & Prescott §III: 4.2 ± 1.7 whiskers touch tables at poses with a table contact.

    Across worlds the mean varies by about ±0.15 (3.99–4.36 over seeds 0–7), so each
    world must lie within 0.35 of 4.2 and the average of five within 0.2.
    """
    means, stds = [], []
    for seed in range(5):
        w = initial(PARAMS, rng=np.random.default_rng(seed))
        counts = np.array([(h(w, p, WHISKERS).table >= 0).sum() for p in pose_sequence(PARAMS)])
        touched = counts[counts > 0]
        means.append(touched.mean())
        stds.append(touched.std())
    assert np.all(np.abs(np.array(means) - 4.2) < 0.35)
    assert abs(np.mean(means) - 4.2) < 0.2
    assert abs(np.mean(stds) - 1.7) < 0.2


def test_observe_noiseless_equals_h_and_is_deterministic(world):
    pose = pose_sequence(PARAMS)[137]
    quiet = condition("noiseless")
    reading = observe(world, pose, quiet, rng=np.random.default_rng(0))
    c = h(world, pose, quiet)
    np.testing.assert_allclose(reading.shapelets[:, :2], c.point[c.hit])
    np.testing.assert_allclose(reading.shapelets[:, 3], c.texture[c.hit])
    np.testing.assert_array_equal(reading.table, c.table[c.hit])
    noisy = condition("noisy")
    a = observe(world, pose, noisy, rng=np.random.default_rng(3))
    b = observe(world, pose, noisy, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(a.shapelets, b.shapelets)
    assert np.all((a.shapelets[:, 2] >= -np.pi) & (a.shapelets[:, 2] < np.pi))
    assert np.all((a.shapelets[:, 3] > 0) & (a.shapelets[:, 3] < 1))


def test_observe_noise_has_the_stated_standard_deviations(world):
    poses = pose_sequence(PARAMS)
    pose = next(p for p in poses if h(world, p, WHISKERS).hit.sum() >= 3)
    params = WhiskerParams(sigma_r=0.1, sigma_theta=0.2, sigma_tau=0.05)
    c = h(world, pose, params)
    rng = np.random.default_rng(11)
    radial, normal, texture = [], [], []
    for _ in range(3000):
        s = observe(world, pose, params, rng=rng).shapelets
        radial.append(np.hypot(*(s[:, :2] - pose[:2]).T) - c.r[c.hit])
        normal.append(np.angle(np.exp(1j * (s[:, 2] - c.normal[c.hit]))))
        texture.append(s[:, 3] - c.texture[c.hit])
    for values, sigma in ((radial, 0.1), (normal, 0.2), (texture, 0.05)):
        values = np.concatenate(values)
        assert abs(values.mean()) < 4 * sigma / math.sqrt(len(values))
        assert abs(values.std() / sigma - 1) < 0.05


def test_conditions_and_bad_input():
    noisy = condition("noisy")
    assert noisy.sigma_r == 0.5 and noisy.sigma_theta == pytest.approx(np.pi / 8)
    assert condition("noiseless").sigma_r == 0.0
    with pytest.raises(ConfigError, match="choose from"):
        condition("foggy")
    with pytest.raises(ConfigError):
        WhiskerParams(whisker_length=0)
    with pytest.raises(ConfigError):
        world_params("whisker-tables-v0")
    with pytest.raises(InputError):
        h(initial(PARAMS, rng=np.random.default_rng(0)), np.array([1.0, 2.0]), WHISKERS)


def test_contacts_do_not_depend_on_which_turn_a_normal_is_stored_in(world):
    """Normals ±π (and any angle plus whole turns) give the same contacts: ``h`` wraps them."""
    turned = replace(world, normal=world.normal + 2.0 * np.pi * np.where(world.normal < 0, 1, -1))
    for pose in pose_sequence(PARAMS)[::40]:
        a, b = h(world, pose, WHISKERS), h(turned, pose, WHISKERS)
        np.testing.assert_array_equal(a.hit, b.hit)
        np.testing.assert_array_equal(a.table, b.table)
        np.testing.assert_allclose(a.point, b.point, rtol=0, atol=1e-12)
        gap = np.abs(wrap_angle(a.normal[a.hit] - b.normal[b.hit]))
        assert np.all(gap < 1e-12)
        assert np.all((a.normal[a.hit] >= -np.pi) & (a.normal[a.hit] < np.pi))
