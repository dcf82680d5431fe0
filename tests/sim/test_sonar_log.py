"""Tests of the realistic sonar log simulator: stops, people, drift, no-echo code, seeding."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import shapely

from bayesmap.sim.polygons import (
    REALISTIC_WORLDS,
    PolygonWorld,
    random_building,
    random_hall,
    random_office,
    world,
)
from bayesmap.sim.sonar import EchoKind, SonarRing
from bayesmap.sim.sonar_log import Realism, drive, latest_firing, odometry, simulate_log


@pytest.mark.parametrize("name", REALISTIC_WORLDS)
def test_realistic_worlds_have_a_drivable_path(name: str) -> None:
    w = world(name)
    route = np.vstack([w.waypoints, w.waypoints[:1]])
    room = w.free.buffer(-0.25)
    for a, b in zip(route[:-1], route[1:], strict=True):
        if np.any(a != b):
            assert room.contains(shapely.LineString([a, b])), (name, a, b)


def test_drive_turns_in_place_and_stands_still() -> None:
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    realism = Realism(stops=2, stop_seconds=(2.0, 2.0), ring_rate=10.0)
    poses, moved = drive(square, realism, rng=np.random.default_rng(0))
    still = ~moved
    assert still.sum() == 2 * 20
    turning = np.flatnonzero(np.all(np.diff(poses[:, :2], axis=0) == 0, axis=1))
    assert len(turning) > still.sum()  # turning in place at the corners too
    step = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    assert step.max() == pytest.approx(realism.speed / realism.ring_rate, rel=1e-6)


def test_odometry_drifts_with_distance_and_is_exact_without_noise() -> None:
    poses, _ = drive(
        np.array([[0.0, 0.0], [10.0, 0.0]]), Realism(stops=0), rng=np.random.default_rng(0)
    )
    exact = Realism(odometry_scale_sd=0, heading_noise=0, turn_scale_sd=0)
    same = odometry(poses, exact, rng=np.random.default_rng(1))
    assert np.allclose(same[:, :2], poses[:, :2], atol=1e-9)
    assert np.allclose(np.sin(same[:, 2] - poses[:, 2]), 0.0, atol=1e-9)
    noisy = odometry(poses, Realism(heading_noise=0.02), rng=np.random.default_rng(1))
    error = np.hypot(*(noisy[:, :2] - poses[:, :2]).T)
    assert error[-1] > error[len(error) // 10] > 0


def test_simulated_log_has_people_stops_no_echo_code_and_truth() -> None:
    ring = SonarRing.pioneer(16)
    realism = Realism(people=3)
    log = simulate_log(world("sonar-office-v2"), ring, realism, rng=7)
    again = simulate_log(world("sonar-office-v2"), ring, realism, rng=7)
    assert np.array_equal(log.ranges, again.ranges) and np.array_equal(log.odometry, again.odometry)
    code = realism.no_echo_code * ring.max_range
    quiet = log.kind >= EchoKind.LOST
    quiet &= log.kind != EchoKind.PERSON
    assert np.all(log.ranges[quiet] == code)
    # Echoes are ranges below the max (bar the odd one noise pushes over: then no echo).
    assert (log.ranges[~quiet] < ring.max_range).mean() > 0.99
    assert (log.kind == EchoKind.PERSON).any() and (log.kind == EchoKind.BOUNCE).any()
    assert np.array_equal(log.specular, np.isin(log.kind, [EchoKind.BOUNCE, EchoKind.LOST]))
    # Standing still with nobody about, a transducer repeats its echo to the millimetre.
    alone = simulate_log(world("sonar-office-v2"), ring, Realism(people=0), rng=7)
    still = np.flatnonzero(np.all(np.diff(alone.poses, axis=0) == 0, axis=1))
    assert len(still) > 20
    assert np.array_equal(alone.ranges[still + 1], alone.ranges[still])


def test_transducers_firing_in_turn_repeat_their_last_reading() -> None:
    times = np.arange(40) / 8.0  # 8 rings a second, a bank firing in 0.32 s
    source = latest_firing(times, 16, 0.32)
    assert np.array_equal(source[0], np.zeros(16))
    assert np.array_equal(source[:, :8], source[:, 8:])  # the two banks fire side by side
    for k in range(16):
        fresh = np.flatnonzero(source[:, k] == np.arange(40))
        # a fresh reading every 2 or 3 rings (0.32 s / 0.125 s), held until the next one
        assert set(np.diff(fresh[1:]).tolist()) <= {2, 3}
        assert np.all(source[:, k] <= np.arange(40))
    assert (source == np.arange(40)[:, None]).mean() < 0.5  # most readings are stale
    ring = SonarRing.pioneer(16)
    fresh_log = simulate_log(world("sonar-office-v2"), ring, Realism(), rng=7)
    log = simulate_log(world("sonar-office-v2"), ring, Realism(firing_cycle=0.32), rng=7)
    held = latest_firing(log.times, ring.n, 0.32)
    columns = np.arange(ring.n)[None, :]
    # the same drive, each value the fresh log's reading of the ring it was taken at
    assert np.array_equal(log.odometry, fresh_log.odometry)
    assert np.array_equal(log.ranges, fresh_log.ranges[held, columns])
    assert np.array_equal(log.kind, fresh_log.kind[held, columns])
    assert np.array_equal(log.specular, fresh_log.specular[held, columns])
    moving = np.any(np.diff(log.poses, axis=0) != 0, axis=1)
    assert (log.ranges[1:][moving] == log.ranges[:-1][moving]).mean() > 0.5


@pytest.mark.parametrize("generate", [random_building, random_hall, random_office])
@pytest.mark.parametrize("seed", range(8))
def test_random_worlds_are_drivable(generate: Callable[[int], PolygonWorld], seed: int) -> None:
    w = generate(seed)
    route = np.vstack([w.waypoints, w.waypoints[:1]])
    room = w.free.buffer(-0.25)
    for a, b in zip(route[:-1], route[1:], strict=True):
        if np.any(a != b):
            assert room.contains(shapely.LineString([a, b]))
    assert generate(seed).segments.tolist() == w.segments.tolist()


@pytest.mark.parametrize("seed", range(8))
def test_random_halls_and_offices_hold_what_they_promise(seed: int) -> None:
    hall, office = random_hall(seed), random_office(seed)
    x0, y0, x1, y1 = hall.free.bounds
    assert 12.0 <= x1 - x0 <= 22.0 and 8.0 <= y1 - y0 <= 14.0
    assert len(hall.free.interiors) >= 2  # pillars stand in the hall
    x0, y0, x1, y1 = office.free.bounds
    assert 7.0 <= x1 - x0 <= 12.0 and 6.0 <= y1 - y0 <= 9.5
    assert len(office.free.interiors) >= 1  # desks stand in the office
