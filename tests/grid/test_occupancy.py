"""Tests of bayesmap.grid.OccupancyGrid: transforms, windows, entropy, .npz files."""

from __future__ import annotations

import io

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from bayesmap.errors import ConfigError, FormatError, InputError
from bayesmap.grid import OccupancyGrid, binary_entropy_bits


def test_shape_extent_and_layers() -> None:
    grid = OccupancyGrid(20.0, 10.0, 0.5, origin=(-3.0, 2.0), prior=0.2)
    assert grid.shape == (20, 40)
    assert grid.extent == (-3.0, 17.0, 2.0, 12.0)
    assert grid.probability.shape == grid.entropy.shape == (20, 40)
    assert np.all(grid.probability == 0.2) and np.all(grid.entropy == 1.0)


def test_cell_zero_is_lower_left_corner() -> None:
    grid = OccupancyGrid(4.0, 3.0, 1.0, origin=(10.0, 20.0))
    rows, cols = grid.world_to_cell([10.0, 10.999, 13.999, 9.999], [20.0, 20.5, 22.999, 20.0])
    assert rows.tolist() == [0, 0, 2, 0]
    assert cols.tolist() == [0, 0, 3, -1]
    assert grid.in_bounds(rows, cols).tolist() == [True, True, True, False]
    x, y = grid.cell_centers([0, 2], [0, 3])
    assert x.tolist() == [10.5, 13.5] and y.tolist() == [20.5, 22.5]


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 39),
    st.integers(0, 59),
    st.floats(-50, 50),
    st.floats(-50, 50),
    st.sampled_from([0.05, 0.1, 0.25, 0.5, 1.0]),
)
def test_centers_map_back_to_their_cells(
    row: int, col: int, ox: float, oy: float, res: float
) -> None:
    grid = OccupancyGrid(60 * res, 40 * res, res, origin=(ox, oy))
    x, y = grid.cell_centers(row, col)
    rows, cols = grid.world_to_cell(x, y)
    assert (int(rows), int(cols)) == (row, col)


@settings(max_examples=60, deadline=None)
@given(st.floats(-3, 23), st.floats(-3, 13), st.floats(0, 4))
def test_window_holds_every_cell_within_radius(x: float, y: float, radius: float) -> None:
    grid = OccupancyGrid(20.0, 10.0, 0.5)
    window = grid.window(x, y, radius)
    rows, cols = np.indices(grid.shape)
    xc, yc = grid.cell_centers(rows, cols)
    inside = np.hypot(xc - x, yc - y) <= radius
    mask = np.zeros(grid.shape, dtype=bool)
    mask[window.rows, window.cols] = True
    assert not np.any(inside & ~mask)
    wx, wy = grid.window_centers(window)
    assert wx.shape == window.shape == wy.shape
    if window.size:
        np.testing.assert_allclose(wx, xc[window.rows, window.cols])
        np.testing.assert_allclose(wy, yc[window.rows, window.cols])


def test_window_size_does_not_depend_on_map_size() -> None:
    small = OccupancyGrid(20.0, 20.0, 0.5).window(10.2, 10.2, 2.0)
    large = OccupancyGrid(200.0, 200.0, 0.5).window(100.2, 100.2, 2.0)
    assert small.shape == large.shape == (9, 9)


def test_window_off_the_map_is_empty() -> None:
    grid = OccupancyGrid(20.0, 20.0, 0.5)
    window = grid.window(-10.0, 5.0, 2.0)
    assert window.size == 0
    assert (
        grid.window_centers(window)[0].shape == (9, 0) or grid.window_centers(window)[0].size == 0
    )


def test_set_probability_keeps_minimum_entropy_until_contradicted() -> None:
    grid = OccupancyGrid(5.0, 5.0, 1.0, prior=0.2, initial_entropy=1.0)
    window = grid.window(2.5, 2.5, 0.4)
    assert window.shape == (1, 1)
    grid.set_probability(window, [[0.9]])
    first = float(grid.entropy[2, 2])
    assert first == pytest.approx(float(binary_entropy_bits(0.9)))
    grid.set_probability(window, [[0.95]])  # agrees: the minimum is kept
    second = float(grid.entropy[2, 2])
    assert second == pytest.approx(float(binary_entropy_bits(0.95))) and second < first
    grid.set_probability(window, [[0.5]])  # contradicts: certainty is not locked
    assert grid.probability[2, 2] == 0.5 and grid.entropy[2, 2] == 1.0
    grid.set_probability(window, [[0.99]])
    assert grid.entropy[2, 2] == pytest.approx(float(binary_entropy_bits(0.99)))


def test_first_sighting_painted_free_is_not_locked_certain() -> None:
    """A cell read free (0.03) and then an obstacle (0.6, 0.97) ends certain *occupied*."""
    grid = OccupancyGrid(5.0, 5.0, 1.0, prior=0.2)
    window = grid.window(2.5, 2.5, 0.4)
    for p in (0.03, 0.6, 0.97):
        grid.set_probability(window, [[p]])
    assert grid.entropy[2, 2] == pytest.approx(float(binary_entropy_bits(0.97)))
    grid.set_probability(window, [[0.6]])
    assert grid.entropy[2, 2] == pytest.approx(float(binary_entropy_bits(0.6)))
    with pytest.raises(InputError):
        grid.set_probability(window, [[1.5]])
    with pytest.raises(InputError):
        grid.set_probability(window, np.zeros((2, 2)))


def test_binary_entropy_in_bits() -> None:
    p = np.linspace(0.001, 0.999, 101)
    expected = -(p * np.log(p) + (1 - p) * np.log(1 - p)) / np.log(2)
    np.testing.assert_allclose(binary_entropy_bits(p), expected, rtol=1e-12)
    assert binary_entropy_bits([0.0, 0.5, 1.0]).tolist() == [0.0, 1.0, 0.0]


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(width=0.0, height=1.0, resolution=0.5),
        dict(width=1.0, height=1.0, resolution=-1.0),
        dict(width=1.0, height=1.0, resolution=0.5, prior=1.2),
    ],
)
def test_bad_config_raises(kwargs: dict[str, float]) -> None:
    with pytest.raises(ConfigError):
        OccupancyGrid(**kwargs)


def test_npz_round_trip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    grid = OccupancyGrid(6.0, 4.0, 0.5, origin=(1.0, -2.0), prior=0.2)
    rng = np.random.default_rng(3)
    grid.set_probability(
        grid.window(3.0, 0.0, 1.0), rng.uniform(size=grid.window(3.0, 0.0, 1.0).shape)
    )
    path = grid.save_npz(tmp_path / "map.npz")
    back = OccupancyGrid.load_npz(path)
    assert back.shape == grid.shape and back.origin == grid.origin and back.resolution == 0.5
    assert back.prior == 0.2
    np.testing.assert_array_equal(back.probability, grid.probability)
    np.testing.assert_array_equal(back.entropy, grid.entropy)


def test_npz_bad_files_raise_format_error(tmp_path) -> None:  # type: ignore[no-untyped-def]
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip at all")
    with pytest.raises(FormatError):
        OccupancyGrid.load_npz(junk)
    partial = tmp_path / "partial.npz"
    np.savez(partial, probability=np.zeros((2, 2)))
    with pytest.raises(FormatError, match="missing"):
        OccupancyGrid.load_npz(partial)


def _saved_grid_bytes() -> bytes:
    grid = OccupancyGrid(3.0, 2.0, 0.5, origin=(1.0, -1.0), prior=0.2)
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


_GRID_BYTES = _saved_grid_bytes()


@settings(max_examples=80, deadline=None)
@given(
    st.integers(0, len(_GRID_BYTES)),
    st.lists(st.tuples(st.integers(0, len(_GRID_BYTES) - 1), st.integers(0, 255)), max_size=4),
)
@example(cut=len(_GRID_BYTES), flips=[])  # the file untouched: it loads
def test_npz_corrupt_bytes_raise_only_format_error(
    tmp_path_factory: pytest.TempPathFactory, cut: int, flips: list[tuple[int, int]]
) -> None:
    data = bytearray(_GRID_BYTES[:cut] if cut < len(_GRID_BYTES) else _GRID_BYTES)
    for where, value in flips:
        if where < len(data):
            data[where] = value
    path = tmp_path_factory.mktemp("npz") / "map.npz"
    path.write_bytes(bytes(data))
    try:
        grid = OccupancyGrid.load_npz(path)
    except FormatError:
        return
    assert np.all((grid.probability >= 0) & (grid.probability <= 1))


@pytest.mark.parametrize(
    "arrays",
    [
        {"resolution": np.array([0.5, 0.5])},
        {"probability": np.full((2, 2), 1.5)},
        {"entropy": np.full((2, 2), np.nan)},
        {"prior": np.array("high")},
    ],
)
def test_npz_bad_arrays_raise_format_error(tmp_path, arrays) -> None:  # type: ignore[no-untyped-def]
    good = {
        "probability": np.full((2, 2), 0.2),
        "entropy": np.ones((2, 2)),
        "resolution": np.float64(0.5),
        "origin": np.zeros(2),
        "prior": np.float64(0.2),
    }
    path = tmp_path / "bad.npz"
    np.savez(path, **{**good, **arrays})
    with pytest.raises(FormatError):
        OccupancyGrid.load_npz(path)
    npy = tmp_path / "plain.npy"
    np.save(npy, np.zeros(3))
    with pytest.raises(FormatError):
        OccupancyGrid.load_npz(npy)


def test_set_probability_with_mask_touches_only_marked_cells() -> None:
    grid = OccupancyGrid(4.0, 4.0, 1.0, prior=0.2)
    window = grid.window(2.0, 2.0, 1.0)
    mask = np.zeros(window.shape, dtype=bool)
    mask[0, 0] = True
    grid.set_probability(window, np.full(window.shape, 0.9), mask=mask)
    assert grid.probability[window.row0, window.col0] == 0.9
    assert np.count_nonzero(grid.probability != 0.2) == 1
    assert np.count_nonzero(grid.entropy < 1.0) == 1


def test_unobserved_cells_are_those_still_at_the_prior() -> None:
    grid = OccupancyGrid(2.0, 2.0, 1.0, prior=0.2)
    grid.probability[0, 1] = 0.05
    assert grid.unobserved().tolist() == [[True, False], [True, True]]
