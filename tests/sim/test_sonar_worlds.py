"""Sonar world files: a generated building survives a round trip; bad files name the fault."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely

from bayesmap.errors import FormatError
from bayesmap.sim.sonar_worlds import generate_world, load_world, save_world, to_json

CORRIDOR = {
    "name": "corridor",
    "outline": [[0, 0], [12, 0], [12, 2], [0, 2]],
    "obstacles": [[[5, 0.8], [5.6, 0.8], [5.6, 1.2], [5, 1.2]]],
    "waypoints": [[0.8, 1.0], [4.0, 1.5], [11.2, 1.0]],
}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_generated_building_reads_back_as_the_same_world(tmp_path, seed):
    world = generate_world(np.random.default_rng(seed))
    back = load_world(save_world(world, tmp_path / "WORLD.json"))
    assert back.name == world.name
    assert shapely.equals(back.free, world.free)
    np.testing.assert_array_equal(back.waypoints, world.waypoints)
    assert to_json(back) == to_json(world)
    other = generate_world(np.random.default_rng(seed + 10))
    assert not shapely.equals(other.free, world.free)


def test_a_hand_written_world_has_its_obstacle_as_a_hole(tmp_path):
    path = tmp_path / "corridor.json"
    path.write_text(json.dumps(CORRIDOR))
    world = load_world(path)
    assert world.name == "corridor" and len(world.free.interiors) == 1
    assert world.free.area == pytest.approx(24.0 - 0.6 * 0.4)
    assert len(world.segments) == 8  # four walls and the box's four faces


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"outline": [[0, 0], [4, 4], [4, 0], [0, 4]]}, r"outline: .*\(Self-intersection"),
        ({"outline": [[0, 0], [4, 0], [8, 0]]}, "outline: .*vertices lie on one line"),
        ({"obstacles": [[[50, 50], [51, 50], [51, 51]]]}, r"obstacles\[0\]: lies wholly outside"),
        ({"waypoints": [[0.8, 1.0], [20.0, 1.0]]}, r"waypoints\[1\] \(20, 1\)"),
        ({"waypoints": [[0.8, 1.0], [5.3, 1.0]]}, r"waypoints\[1\]"),  # inside the box
        ({"outline": [[0, 0], [1, 0]]}, "outline"),
        ({"extra": 1}, "extra"),
    ],
)
def test_bad_worlds_are_refused_naming_the_file_and_what_is_wrong(tmp_path, change, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({**CORRIDOR, **change}))
    with pytest.raises(FormatError, match=message) as error:
        load_world(path)
    assert "bad.json" in str(error.value)


def test_unreadable_files_are_format_errors(tmp_path):
    with pytest.raises(FormatError, match="cannot read"):
        load_world(tmp_path / "missing.json")
    (tmp_path / "broken.json").write_text("{")
    with pytest.raises(FormatError, match="not JSON"):
        load_world(tmp_path / "broken.json")
