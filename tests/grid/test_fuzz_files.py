"""Fuzzed grid files (.npz, ROS YAML, PGM/PNG): a grid or a BayesmapError, within budget."""

from __future__ import annotations

import io

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from _fuzzing import FUZZ, mutated, read_within_budget
from bayesmap.errors import BayesmapError
from bayesmap.grid.occupancy import OccupancyGrid
from bayesmap.grid.ros import RosMap, read_ros_map, write_ros_map


def _npz_seed() -> bytes:
    grid = OccupancyGrid(1.0, 0.75, 0.25, origin=(-1.0, 2.0), prior=0.3)
    grid.probability[1, 2] = 0.9
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer,
        probability=grid.probability,
        entropy=grid.entropy,
        resolution=np.float64(grid.resolution),
        origin=np.asarray(grid.origin),
        prior=np.float64(grid.prior),
    )
    return buffer.getvalue()


def _png_seed() -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(np.arange(12, dtype=np.uint8).reshape(3, 4) * 20).save(buffer, "PNG")
    return buffer.getvalue()


@FUZZ
@given(data=st.data())
def test_mutated_npz_grids(tmp_path_factory, data: st.DataObject) -> None:
    path = tmp_path_factory.mktemp("npz") / "grid.npz"
    path.write_bytes(data.draw(mutated([_npz_seed()])))
    outcome = read_within_budget(lambda: OccupancyGrid.load_npz(path))
    assert isinstance(outcome, (OccupancyGrid, BayesmapError))


@FUZZ
@given(data=st.data())
def test_mutated_ros_maps(tmp_path_factory, data: st.DataObject) -> None:
    folder = tmp_path_factory.mktemp("ros")
    yaml, pgm = write_ros_map(folder / "map", np.linspace(0, 1, 12).reshape(3, 4), 0.05)
    (folder / "map.png").write_bytes(_png_seed())
    which = data.draw(st.sampled_from(["yaml", "pgm", "png"]))
    if which == "yaml":
        yaml.write_bytes(data.draw(mutated([yaml.read_bytes()])))
    elif which == "pgm":
        pgm.write_bytes(data.draw(mutated([pgm.read_bytes()])))
    else:
        yaml.write_text(yaml.read_text().replace("map.pgm", "map.png"))
        (folder / "map.png").write_bytes(data.draw(mutated([_png_seed()])))
    outcome = read_within_budget(lambda: read_ros_map(yaml))
    assert isinstance(outcome, (RosMap, BayesmapError))
