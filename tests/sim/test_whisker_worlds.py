"""World files (schema, load/save, errors), the stress-world generator, simulated sweeps."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap.errors import FormatError
from bayesmap.sim.tables_world import rectangle_corners
from bayesmap.sim.whisker_worlds import (
    POSE_CLEARANCE,
    TOUR_SPACING,
    StressOptions,
    TourGrid,
    default_tour,
    generate_world,
    load_world,
    parse_world,
    save_world,
)
from bayesmap.sim.whiskers import SWEEP_COLUMNS, WhiskerParams, condition, observe

EXAMPLE = {
    "arena": {"width": 7.0, "height": 7.0},
    "tables": [
        {"x": 1.59, "y": 0.58, "theta": 0.01, "length": 1.2, "width": 0.8, "leg": 0.1},
        {
            "x": 4.0,
            "y": 4.0,
            "theta": 0.7,
            "length": 0.8,
            "width": 0.8,
            "leg": 0.08,
            "texture": 0.4,
        },
    ],
    "poses": {"grid": 10, "margin": 0.45, "headings": 4},
}


def _polygons(tables: np.ndarray) -> list[shapely.Polygon]:
    corners = rectangle_corners(
        tables[:, 0], tables[:, 1], tables[:, 2], tables[:, 3], tables[:, 4]
    )
    return [shapely.Polygon(c) for c in corners]


def test_the_documented_example_loads_and_round_trips(tmp_path) -> None:
    path = tmp_path / "world.json"
    path.write_text(json.dumps(EXAMPLE))
    world = load_world(path)
    assert world.arena == (7.0, 7.0)
    assert world.tables.shape == (2, 7) and world.tables[0, 6] == 0.3
    assert [c[1:] for c in world.catalogue] == [(1.2, 0.8, 0.1), (0.8, 0.8, 0.08)]
    save_world(world, tmp_path / "again.json")
    again = load_world(tmp_path / "again.json")
    assert np.array_equal(again.tables, world.tables) and again.catalogue == world.catalogue
    poses = world.robot_poses()
    assert poses.shape[1] == 3 and len(poses) % 4 == 0 and len(poses) < 400
    # grid positions inside a table are skipped
    for polygon in _polygons(world.tables):
        assert not any(polygon.contains(shapely.Point(x, y)) for x, y in poses[:, :2])


def test_the_default_tour_keeps_the_papers_density_on_any_arena() -> None:
    """The paper's 10 × 10 in its 6 m arena; a larger room gets more positions, never more
    than TOUR_SPACING apart, and a corridor's short side fewer (not 10 within 0.3 m)."""
    assert default_tour((6.0, 6.0), margin=0.48) == TourGrid(10, 10, 0.48, 4)
    assert default_tour((4.0, 5.0))[:2] == (10, 10)
    rng = np.random.default_rng(7)
    for side in rng.uniform(1.0, 40.0, size=(60, 2)):
        columns, rows, margin, _ = default_tour((side[0], side[1]))
        for length, count in zip(side, (columns, rows), strict=True):
            usable = length - 2 * margin
            assert usable / (count - 1) <= TOUR_SPACING + 1e-9
            assert count >= 10 or usable < 9 * POSE_CLEARANCE
            assert count <= 10 or usable > 9 * TOUR_SPACING


def test_a_world_without_a_grid_gets_the_default_tour_and_says_it_in_its_file(tmp_path) -> None:
    bare = {key: value for key, value in EXAMPLE.items() if key != "poses"}
    world = parse_world(bare, "bare.json")
    assert world.tour() == default_tour((7.0, 7.0)) == TourGrid(12, 12, 0.45, 4)
    assert world.to_json()["poses"] == {"grid": 12, "margin": 0.45, "headings": 4}
    poses = world.robot_poses()
    assert np.isclose(np.diff(np.unique(poses[:, 0])).max(), 6.1 / 11)
    spaced = parse_world({**bare, "poses": {"spacing": 1.0, "headings": 2}}, "spaced.json")
    assert spaced.tour() == TourGrid(8, 8, 0.45, 2)
    strip = parse_world({**bare, "poses": {"grid": [12, 3], "margin": 0.5}}, "strip.json")
    assert strip.tour() == TourGrid(12, 3, 0.5, 4)
    assert strip.to_json()["poses"]["grid"] == [12, 3]
    save_world(strip, tmp_path / "strip.json")
    assert np.array_equal(load_world(tmp_path / "strip.json").robot_poses(), strip.robot_poses())


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda w: w["tables"][1].pop("x"), r"tables\[1\]: 'x' is a required property"),
        (lambda w: w["arena"].update(width=-1), r"arena\.width"),
        (lambda w: w["tables"][0].update(x=0.3), r"tables\[0\]: the table crosses a wall"),
        (
            lambda w: w["tables"][1].update(x=1.7, y=0.7),
            r"tables\[1\]: the table overlaps tables\[0\]",
        ),
        (lambda w: w["tables"][0].update(leg=0.5), r"tables\[0\]: each leg must be at most half"),
        (
            lambda w: w.update(poses=[[8.0, 1.0, 0.0]]),
            r"poses\[0\]: a pose must be finite and inside",
        ),
        (lambda w: w.update(walls=[]), r"the document: Additional properties"),
        (lambda w: w["arena"].update(width=7000.0), r"arena: a side of 7000 m .* in cm or mm"),
        (lambda w: w["arena"].update(width=math.inf), r"arena: the sides must be finite"),
        (
            lambda w: w["tables"][0].update(length=0.5, width=0.9),
            r"tables\[0\]: width 0.9 is more than length 0.5",
        ),
        (
            lambda w: w.update(catalogue=[{"length": 0.6, "width": 1.0, "leg": 0.05}]),
            r"catalogue\[0\]: length must be the longer side",
        ),
        (
            lambda w: w.update(catalogue=[{"length": 1200, "width": 800, "leg": 100}]),
            r"catalogue\[0\]: 1200 x 800 m does not fit in the 7 x 7 m arena .*cm or mm",
        ),
        (
            lambda w: w.update(
                catalogue=[
                    {"name": "desk", "length": 1.2, "width": 0.8, "leg": 0.1},
                    {"name": "desk", "length": 0.8, "width": 0.8, "leg": 0.08},
                ]
            ),
            r"catalogue\[1\]: has the name of catalogue\[0\] \('desk'\)",
        ),
        (
            lambda w: w.update(
                catalogue=[
                    {"name": "a", "length": 1.2, "width": 0.8, "leg": 0.05},
                    {"name": "b", "length": 1.2, "width": 0.8, "leg": 0.05},
                ]
            ),
            r"catalogue\[1\]: has the size of catalogue\[0\]",
        ),
        (
            lambda w: w.update(poses=[[3.0, 2.0, 0.0], [4.0, 4.0, 0.0]]),
            r"poses\[1\]: the robot cannot stand inside a table",
        ),
        (
            lambda w: w.update(poses={"grid": 100000}),
            r"poses\.grid: a 100,000 x 100,000 grid of 4 headings is 40,000,000,000 poses",
        ),
        (
            lambda w: w.update(poses={"grid": [10, 0]}),
            r"poses\.grid\[1\]: 0 is less than the minimum of 1",
        ),
        (
            lambda w: w.update(poses={"grid": 10, "spacing": 0.5}),
            r"poses: give grid or spacing, not both",
        ),
        (
            lambda w: w.update(poses={"spacing": 0.01}),
            r"poses\.spacing: a 611 x 611 grid of 4 headings is 1,493,284 poses",
        ),
        (
            lambda w: (w.pop("poses"), w["arena"].update(width=100.0, height=100.0)),
            r"poses: a 167 x 167 grid .*; give poses\.grid or a wider poses\.spacing",
        ),
        (
            lambda w: w.update(poses=[[1.0, 1.0, 0.0]] * 100_001),
            r"poses: 100,001 poses are more than a run takes \(100,000\)",
        ),
    ],
)
def test_bad_world_files_name_the_element(change, message) -> None:
    world = json.loads(json.dumps(EXAMPLE))
    change(world)
    with pytest.raises(FormatError, match=message):
        parse_world(world, "room.json")


def test_a_table_of_no_catalogue_size_is_named_in_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    world = json.loads(json.dumps(EXAMPLE))
    world["catalogue"] = [{"name": "desk", "length": 1.2, "width": 0.8, "leg": 0.1}]
    parse_world(world, "room.json")
    assert "room.json: no catalogue type has the size of tables[1]," in caplog.text
    assert "tables[0]" not in caplog.text


def test_not_json_names_line_and_column(tmp_path) -> None:
    path = tmp_path / "broken.json"
    path.write_text('{"arena": {"width": 7.0,\n "height": }')
    with pytest.raises(FormatError, match=r"broken.json, line 2: not JSON"):
        load_world(path)
    with pytest.raises(FormatError, match="cannot read"):
        load_world(tmp_path / "missing.json")
    path.write_text('{"arena": {"width": 7.0,\n "height": NaN}, "tables": []}')
    with pytest.raises(FormatError, match=r"broken.json, line 2: NaN is not a number"):
        load_world(path)


@settings(max_examples=40, deadline=None)
@given(
    st.recursive(
        st.none() | st.booleans() | st.floats() | st.text(max_size=5),
        lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c, max_size=3),
        max_leaves=8,
    )
)
def test_any_json_value_is_accepted_or_a_format_error(value) -> None:
    try:
        parse_world(value, "fuzz")
    except FormatError:
        pass


@pytest.mark.parametrize("seed", range(6))
def test_generated_worlds_are_valid_and_stress_the_mapper(seed: int, tmp_path) -> None:
    world = generate_world(np.random.default_rng(seed))
    options = StressOptions()
    assert all(4.0 <= side <= 10.0 for side in world.arena)
    assert 4 <= len(world.tables) <= 10
    assert {tuple(r) for r in world.tables[:, 3:6].tolist()} <= set(options.sizes)
    save_world(world, tmp_path / "w.json")
    assert np.allclose(load_world(tmp_path / "w.json").tables, world.tables)  # passes every check
    polygons = _polygons(world.tables)
    box = shapely.box(0, 0, *world.arena).exterior
    gaps = [p.distance(box) for p in polygons]
    assert min(gaps) >= options.min_gap - 1e-3
    pairs = [polygons[i].distance(polygons[j]) for i in range(len(polygons)) for j in range(i)]
    assert min(pairs) >= options.min_gap - 1e-3


def test_stress_options_produce_wall_huggers_and_close_pairs_across_seeds() -> None:
    near_wall = close_pair = mixed = 0
    for seed in range(10):
        world = generate_world(np.random.default_rng(100 + seed))
        polygons = _polygons(world.tables)
        box = shapely.box(0, 0, *world.arena).exterior
        near_wall += any(0.1 - 1e-3 <= p.distance(box) <= 0.2 + 1e-3 for p in polygons)
        close_pair += any(
            polygons[i].distance(polygons[j]) < 0.4 for i in range(len(polygons)) for j in range(i)
        )
        mixed += len({tuple(r) for r in world.tables[:, 3:5].tolist()}) > 1
    # a world of n tables is all one size with chance 2 · 0.5ⁿ (1 in 8 for four)
    assert near_wall >= 8 and close_pair >= 6 and mixed >= 6


def test_plain_worlds_keep_away_from_walls_and_each_other() -> None:
    plain = StressOptions(near_wall=0.0, close_pairs=0.0, min_gap=0.3)
    world = generate_world(np.random.default_rng(3), plain)
    polygons = _polygons(world.tables)
    assert min(p.distance(shapely.box(0, 0, *world.arena).exterior) for p in polygons) >= 0.3 - 1e-3


@pytest.mark.parametrize("name", ["normal", "noiseless", "noisy"])
def test_every_sweep_is_reported_and_no_contact_lies_behind_the_root(name: str) -> None:
    world_file = generate_world(np.random.default_rng(1))
    world = world_file.world()
    sensor = condition(name, WhiskerParams())
    rng = np.random.default_rng(0)
    poses = world_file.robot_poses()
    for pose in poses[:: max(1, len(poses) // 60)]:
        reading = observe(world, pose, sensor, rng=rng)
        sweeps = reading.sweeps
        assert sweeps.shape == (len(sensor.rest_angles), len(SWEEP_COLUMNS))
        hit = reading.contacts.hit
        assert np.isnan(sweeps[~hit, 3:]).all() and np.isfinite(sweeps[hit, 3:5]).all()
        assert (sweeps[hit, 3] >= 0).all()  # folded at the root
        # the contact point lies ahead of the root, along the stop bearing
        ahead = np.cos(sweeps[:, 1] - reading.contacts.direction)
        assert np.allclose(ahead, 1.0)
        turn = np.abs(np.angle(np.exp(1j * (sweeps[:, 1] - sweeps[:, 0]))))
        assert (turn <= 2 * sensor.sweep + 1e-9).all()
        assert np.allclose(sweeps[:, 2], sensor.whisker_length)
    assert math.isfinite(sweeps[:, 0].sum())


def test_a_solid_box_is_touched_on_its_outline_only() -> None:
    """Legs of half the width meet: the square is a solid box, and no whisker reaches into
    it (every true contact point on it lies on its outline)."""
    solid = dict(
        EXAMPLE,
        tables=[{"x": 3.5, "y": 3.5, "theta": 0.4, "length": 0.5, "width": 0.5, "leg": 0.25}],
    )
    world_file = parse_world(solid, "box.json")
    assert [entry[1:] for entry in world_file.catalogue] == [(0.5, 0.5, 0.25)]
    outline = _polygons(world_file.tables)[0]
    world = world_file.world()
    sensor = condition("noiseless", WhiskerParams())
    rng = np.random.default_rng(0)
    touched = 0
    for pose in world_file.robot_poses():
        contacts = observe(world, pose, sensor, rng=rng).contacts
        on_box = contacts.hit & (shapely.distance(outline, shapely.points(contacts.point)) < 0.05)
        points = shapely.points(contacts.point[on_box])
        assert (shapely.distance(outline.exterior, points) < 1e-6).all()
        touched += int(on_box.sum())
    assert touched > 50


def test_listed_headings_are_wrapped_into_one_turn() -> None:
    listed = dict(EXAMPLE, poses=[[3.0, 2.0, 1e300], [3.0, 3.0, -7.0], [3.0, 4.0, 0.5]])
    headings = parse_world(listed, "w.json").robot_poses()[:, 2]
    assert ((headings >= 0) & (headings < 2 * math.pi)).all()
    assert headings[1:].tolist() == pytest.approx([2 * math.pi - 7.0 + 2 * math.pi, 0.5])
