"""World files (JSON Schema) and the stress-world generator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely

from bayesmap.errors import ConfigError, FormatError
from bayesmap.sim.rover_worlds import generate_world, load_world, save_world
from bayesmap.sim.world2d import world_distance, world_ray_cast, world_truth

ISSUE_EXAMPLE = {
    "size": [20.0, 20.0],
    "resolution": 0.5,
    "obstacles": [[[14.0, 16.0], [15.0, 16.0], [15.0, 17.0], [14.0, 17.0]]],
    "start": [1.0, 1.0, 0.0],
}


def test_the_issue_example_loads(tmp_path: Path) -> None:
    path = tmp_path / "w.json"
    path.write_text(json.dumps(ISSUE_EXAMPLE))
    spec = load_world(path)
    np.testing.assert_array_equal(spec.world.boxes, [[14.0, 16.0, 15.0, 17.0]])
    assert spec.start == (1.0, 1.0, 0.0) and spec.resolution == 0.5
    assert spec.world.name == "w"


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"size": [20.0]}, "size"),
        ({"start": [1.0, 1.0]}, "start"),
        ({"obstacles": [[[3, 3], [5, 5], [5, 3], [3, 5]]]}, r"obstacles\[0\].*simple polygon"),
        ({"obstacles": [[[3, 3], [4, 4], [5, 5]]]}, r"obstacles\[0\].*positive area"),
        ({"obstacles": [[[3, 3], [3, 3], [3, 3]]]}, r"obstacles\[0\]"),
        ({"start": [14.5, 16.5, 0.0]}, "start"),
        ({"start": [30.0, 1.0, 0.0]}, "outside"),
        ({"colour": "red"}, "colour"),
        ({"resolution": 50}, r"resolution.*50 m.*cm or mm"),  # a cell side in cm
        ({"resolution": 0.05}, r"resolution.*0.05 m, finer than the 0.1 m"),
        ({"size": [2000.0, 20.0]}, r"size\[0\].*maximum of 200"),  # a side in dm
    ],
)
def test_bad_worlds_name_the_field(tmp_path: Path, change: dict, words: str) -> None:  # type: ignore[type-arg]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({**ISSUE_EXAMPLE, **change}))
    with pytest.raises(FormatError, match=words):
        load_world(path)


def test_an_obstacle_outside_the_area_is_kept_with_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    far = [[1400.0, 1600.0], [1500.0, 1600.0], [1500.0, 1700.0]]  # the example's box in dm
    path = tmp_path / "w.json"
    path.write_text(json.dumps({**ISSUE_EXAMPLE, "obstacles": [*ISSUE_EXAMPLE["obstacles"], far]}))
    spec = load_world(path)
    assert spec.world.n_obstacles == 2
    assert "obstacles[1]: lies wholly outside the 20 x 20 m area" in caplog.text
    assert "obstacles[0]" not in caplog.text


def test_an_area_of_no_whole_number_of_cells_gets_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "w.json"
    path.write_text(json.dumps({**ISSUE_EXAMPLE, "size": [30.0, 1.2], "obstacles": []}))
    load_world(path)
    assert "the 30 x 1.2 m area is not a whole number of 0.5 m cells" in caplog.text
    assert "the map covers only 30 x 1 m of it" in caplog.text
    caplog.clear()
    for size in ([20.0, 20.0], [20.0, 20.3]):  # whole cells; a map a little larger
        path.write_text(json.dumps({**ISSUE_EXAMPLE, "size": size}))
        load_world(path)
    assert not caplog.records


def test_generated_worlds_refuse_a_cell_side_the_planner_cannot_afford() -> None:
    with pytest.raises(ConfigError, match="0.05 m, finer than"):
        generate_world(0, size=20.0, resolution=0.05)


def test_broken_json_reports_the_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.json"
    path.write_text('{\n "size": [20, 20],\n "start": [1, 1 0]\n}')
    with pytest.raises(FormatError, match="line 3"):
        load_world(path)


def test_polygons_of_any_shape_load_and_are_obstacles(tmp_path: Path) -> None:
    triangle = [[3.0, 3.0], [6.0, 3.0], [4.0, 6.0]]
    ell = [[10, 10], [14, 10], [14, 11], [11, 11], [11, 14], [10, 14]]  # concave
    path = tmp_path / "w.json"
    path.write_text(json.dumps({**ISSUE_EXAMPLE, "obstacles": [triangle, ell]}))
    world = load_world(path).world
    assert world.boxes.shape == (0, 4) and len(world.polygons) == 2
    assert world_distance(world, 4.0, 4.0) == 0.0  # inside the triangle
    assert world_distance(world, 12.5, 12.5) == pytest.approx(1.5)  # in the L's notch
    # the simulated rangers see the tilted face; the truth covers the concave shape
    hit = world_ray_cast(world, [[12.5, 12.5]], [np.pi])
    assert hit[0] == pytest.approx(1.5)
    truth = world_truth(world, (40, 40), 0.5, (0.0, 0.0))
    assert truth[20, 20] and truth[26, 20] and not truth[25, 25]  # (10.25, 10.25) (10.25, 13.25)


@pytest.mark.parametrize("seed", range(8))
def test_generated_worlds_keep_passages_and_round_trip(tmp_path: Path, seed: int) -> None:
    spec = generate_world(seed)
    world = spec.world
    side = world.width
    assert 20.0 <= side <= 60.0 and world.n_obstacles >= 3
    solid = shapely.union_all(
        [shapely.box(*b) for b in world.boxes] + [shapely.Polygon(p) for p in world.polygons]
    )
    xmin, ymin, xmax, ymax = solid.bounds
    assert min(xmin, ymin) >= 1.2 - 1e-9 and max(xmax, ymax) <= side - 1.2 + 1e-9
    assert world_distance(world, *spec.start[:2]) >= 1.7
    path = save_world(tmp_path / "w.json", spec)
    back = load_world(path)
    np.testing.assert_allclose(back.world.boxes, np.round(world.boxes, 3))
    assert back.world.width == round(side, 3)
    document = json.loads(path.read_text(encoding="utf-8"))
    lengths = np.array(
        [*document["size"], *document["start"][:2]]
        + [v for polygon in document["obstacles"] for corner in polygon for v in corner]
    )
    np.testing.assert_array_equal(lengths, np.round(lengths, 3))  # millimetres in the file
    assert len(back.world.polygons) == len(world.polygons)
    assert back.world.name == spec.world.name


def test_generator_draws_obstacles_at_any_angle() -> None:
    worlds = [generate_world(seed, size=30.0).world for seed in range(6)]
    tilted = [p for w in worlds for p in w.polygons]
    assert tilted
    edges = np.concatenate([np.diff(np.vstack([p, p[:1]]), axis=0) for p in tilted])
    angles = np.degrees(np.arctan2(edges[:, 1], edges[:, 0])) % 90.0
    assert ((angles > 5.0) & (angles < 85.0)).any()


def test_generator_is_reproducible() -> None:
    a, b = generate_world(3, size=25.0), generate_world(3, size=25.0)
    np.testing.assert_array_equal(a.world.boxes, b.world.boxes)
    assert a.world.width == 25.0
