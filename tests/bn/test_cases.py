"""Cases as DataFrames: state names or indices, blanks, chunks, the progress hook."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from tests.bn.helpers import random_net

from bayesmap.bn.cases import case_array, column_name, posterior_frame, run_batch
from bayesmap.errors import InputError


def frame_of(seed: int, n: int = 200) -> tuple[pd.DataFrame, np.ndarray]:
    net = random_net(seed, n_vars=6, max_card=3)
    rng = np.random.default_rng(seed)
    draws = net.sample(n, rng=rng)
    draws[rng.random(draws.shape) < 0.4] = -1
    return net, draws


@pytest.mark.parametrize("seed", range(4))
def test_names_indices_and_blanks_give_the_array_answers(seed: int) -> None:
    net, draws = frame_of(seed)
    names = {
        v: [None if s < 0 else net.states(v)[s] for s in draws[:, j]]
        for j, v in enumerate(net.variables)
    }
    by_name = pd.DataFrame(names, index=np.arange(len(draws)) + 1000)
    by_index = pd.DataFrame(
        {
            v: pd.array(np.where(draws[:, j] < 0, None, draws[:, j]), dtype="Int64")
            for j, v in enumerate(net.variables)
        }
    )
    target = net.variables[-1]
    expected = net.posterior_batch(target, draws)
    for frame in (by_name, by_index):
        table, columns = case_array(net, frame)
        np.testing.assert_array_equal(table, draws)
        answer = net.posterior_batch(target, frame)
        assert list(answer.columns) == [column_name(target, s) for s in net.states(target)]
        assert answer.index.equals(frame.index)
        np.testing.assert_allclose(answer.to_numpy(), expected, atol=1e-12)


def test_chunks_and_progress_cover_every_case_once() -> None:
    net, draws = frame_of(9, n=1000)
    frame = pd.DataFrame(draws, columns=list(net.variables)).replace(-1, np.nan)
    calls: list[tuple[int, int]] = []
    targets = list(net.variables[:2])
    chunks = list(
        run_batch(
            net, frame, targets, chunk_rows=300, progress=lambda _d, k, n: calls.append((k, n))
        )
    )
    assert [len(c) for c in chunks] == [300, 300, 300, 100]
    assert calls == [(300, 1000), (600, 1000), (900, 1000), (1000, 1000)]
    whole = pd.concat(chunks)
    pd.testing.assert_frame_equal(whole, posterior_frame(net, frame, targets))


def test_bad_cells_are_named() -> None:
    net, _ = frame_of(2, n=3)
    x = net.variables[0]
    with pytest.raises(InputError, match="row 'b', column"):
        case_array(net, pd.DataFrame({x: ["s0", "nope"]}, index=["a", "b"]))
    with pytest.raises(InputError, match="not a state"):
        case_array(net, pd.DataFrame({x: [0, 7]}))
    with pytest.raises(InputError, match="not a state"):
        case_array(net, pd.DataFrame({x: [0.5]}))
    with warnings.catch_warnings():  # an infinite code is named, not cast with a warning
        warnings.simplefilter("error")
        with pytest.raises(InputError, match="inf is not a state"):
            case_array(net, pd.DataFrame({x: [0.0, np.inf]}))
    with pytest.raises(InputError, match="is not a variable"):
        case_array(net, pd.DataFrame({"zz": [0]}))
