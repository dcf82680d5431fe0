"""Tests of the sonar simulator: ray casting, direct echoes, bounces, loss, noise, seeding."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import box

from bayesmap.errors import ConfigError, InputError
from bayesmap.sim.polygons import PolygonWorld, _make, path_poses, world
from bayesmap.sim.scenarios import names
from bayesmap.sim.sonar import EchoKind, SonarRing, cast_rays, h, observe


def _box_world(width: float = 4.0, height: float = 4.0) -> PolygonWorld:
    return _make("test-box", box(0.0, 0.0, width, height), [], [(1.0, 1.0), (2.0, 2.0)])


def test_cast_rays_against_brute_force() -> None:
    segments = np.array([[1.0, -1.0, 1.0, 1.0], [3.0, -5.0, 3.0, 5.0]])
    origins = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [2.0, 0.0]])
    dirs = np.array([[1.0, 0.0], [-1.0, 0.0], [math.cos(0.5), math.sin(0.5)], [1.0, 0.0]])
    t, idx = cast_rays(origins, dirs, segments)
    assert t[0] == pytest.approx(1.0) and idx[0] == 0
    assert math.isinf(t[1]) and idx[1] == -1
    assert t[2] == pytest.approx(1.0 / math.cos(0.5)) and idx[2] == 0
    assert t[3] == pytest.approx(1.0) and idx[3] == 1


def test_facing_a_wall_gives_its_perpendicular_distance() -> None:
    ring = SonarRing(angles=(0.0, math.pi / 2), radius=0.0, fan=33)
    scan = h(_box_world(), np.array([[1.0, 1.0, 0.0]]), ring)
    assert scan.kind.tolist() == [[EchoKind.DIRECT, EchoKind.DIRECT]]
    assert scan.ranges[0, 0] == pytest.approx(3.0, rel=1e-3)
    assert scan.ranges[0, 1] == pytest.approx(3.0, rel=1e-3)
    assert not scan.specular.any()


def test_glancing_wall_is_lost_or_bounces_and_is_marked_specular() -> None:
    ring = SonarRing(angles=(math.radians(45.0), math.radians(60.0)), radius=0.0)
    w = _make("test-corridor", box(0.0, 0.0, 40.0, 1.0), [], [(1.0, 0.5), (2.0, 0.5)])
    scan = h(w, np.array([[1.0, 0.5, 0.0]]), ring)
    assert np.all(scan.specular)
    assert set(scan.kind.ravel().tolist()) <= {EchoKind.LOST, EchoKind.BOUNCE}
    assert np.all(scan.ranges[scan.kind == EchoKind.LOST] == ring.max_range)


def test_bounce_reports_the_whole_path_length() -> None:
    # A 45° mirror wall sends a pulse heading +x straight up onto a wall it meets head-on.
    w = _make("test-mirror", box(0.0, 0.0, 10.0, 10.0), [], [(1.0, 1.0), (2.0, 2.0)])
    mirror = np.array([[3.0, 0.0, 4.0, 1.0]])  # 45°: +x becomes +y
    w2 = PolygonWorld(
        "test-mirror", w.free, np.vstack([mirror, [[0.0, 2.5, 10.0, 2.5]]]), w.waypoints
    )
    ring = SonarRing(angles=(0.0, math.pi), radius=0.0, fan=1, beam_width=math.radians(10))
    scan = h(w2, np.array([[1.0, 0.5, 0.0]]), ring)
    assert scan.kind[0, 0] == EchoKind.BOUNCE
    # To the mirror at x = 3.5 (2.5 m), then up from y = 0.5 to y = 2.5 (2 m).
    assert scan.ranges[0, 0] == pytest.approx(4.5)
    assert scan.specular[0, 0]


def test_same_seed_same_readings_and_noise_statistics() -> None:
    w = world("sonar-room-v1")
    poses = path_poses(w.waypoints, 0.2)
    ring = SonarRing()
    a = observe(w, poses, ring, rng=3)
    b = observe(w, poses, ring, rng=3)
    c = observe(w, poses, ring, rng=4)
    assert np.array_equal(a.ranges, b.ranges)
    assert not np.array_equal(a.ranges, c.ranges)
    clean = h(w, poses, ring)
    echo = (
        (clean.ranges < ring.max_range)
        & (clean.ranges > 0.5)
        & (clean.ranges < ring.max_range - 0.5)
    )
    error = a.ranges[echo] - clean.ranges[echo]
    assert abs(error.mean()) < 4 * ring.sigma / math.sqrt(error.size)
    assert error.std() == pytest.approx(ring.sigma, rel=0.1)


def test_every_registered_world_has_specular_readings_and_valid_paths() -> None:
    for name in names(PolygonWorld):
        w = world(name)
        poses = path_poses(w.waypoints, 0.5)
        scan = h(w, poses, SonarRing())
        assert 0.1 < scan.specular.mean() < 0.9
        assert np.all(scan.ranges <= SonarRing().max_range)


def test_front_arc_and_ring_sizes_and_bad_parameters() -> None:
    assert SonarRing.front_arc().n == 8
    assert SonarRing.ring(12).n == 12
    with pytest.raises(ConfigError):
        SonarRing(critical_angle=2.0)
    with pytest.raises(ConfigError):
        world("no-such-world")
    with pytest.raises(InputError):
        h(world("sonar-room-v1"), np.zeros((2, 2)), SonarRing())
