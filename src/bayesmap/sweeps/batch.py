"""Batch inference on a Dask cluster: many evidence cases, partitioned across workers.

The cases are a pandas DataFrame, one column per observed variable holding state names
(missing = unobserved). :func:`posterior_batch` splits it into partitions with
``dask.dataframe``; every worker rebuilds the network from its XMLBIF text (workers receive
data, not live objects) and answers its partition with
:meth:`bayesmap.bn.BayesNet.posterior_batch` — the engine's batched exact posterior (Post et
al. 2016 eqs. 1–3, one contraction per evidence pattern). The answer is the same table a
single machine computes, row for row.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from bayesmap import bn
from bayesmap.bn import io as bn_io
from bayesmap.errors import InputError
from bayesmap.sweeps.runner import dask_client

__all__ = ["cases_to_indices", "posterior_batch"]


def cases_to_indices(net: bn.BayesNet, cases: pd.DataFrame) -> np.ndarray:
    """``(n_cases, n_columns)`` state indices of ``cases`` (−1 where a value is missing).

    Raises
    ------
    InputError
        Naming the column (and the row) of an unknown variable or state.
    """
    out = np.full(cases.shape, -1, dtype=np.int64)
    for j, column in enumerate(cases.columns):
        if column not in net:
            raise InputError(
                f"cases column {column!r} is not a variable of {net.name!r}; "
                f"its variables are {list(net.variables)}"
            )
        states = {state: k for k, state in enumerate(net.states(column))}
        values = cases[column]
        missing = values.isna().to_numpy()
        for i, value in enumerate(values.to_numpy()):
            if missing[i]:
                continue
            index = states.get(str(value))
            if index is None:
                raise InputError(
                    f"cases row {cases.index[i]!r}, column {column!r}: unknown state "
                    f"{value!r}; the states are {list(states)}"
                )
            out[i, j] = index
    return out


def _answer(partition: pd.DataFrame, network: str, target: str) -> pd.DataFrame:
    """Posterior of ``target`` for one partition (runs on a worker)."""
    net = bn_io.loads(network, "xmlbif")
    columns = [f"P({target}={state})" for state in net.states(target)]
    if partition.empty:
        return pd.DataFrame(columns=columns, index=partition.index, dtype=np.float64)
    values = net.posterior_batch(
        target, cases_to_indices(net, partition), columns=list(partition.columns)
    )
    return pd.DataFrame(values, columns=columns, index=partition.index)


def posterior_batch(
    net: bn.BayesNet,
    target: str,
    cases: pd.DataFrame,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    partitions: int | None = None,
) -> pd.DataFrame:
    """``P(target | case)`` for every row of ``cases``, computed on a Dask cluster.

    Parameters
    ----------
    net
        The network.
    target
        The queried variable.
    cases
        One row per case, one column per observed variable, state names as values;
        missing values are unobserved.
    scheduler
        Address of a Dask scheduler; ``None`` starts a ``LocalCluster`` of ``workers``.
    partitions
        How many pieces to split the cases into (default: two per worker).

    Returns
    -------
    A DataFrame with the index of ``cases`` and one column ``P(target=state)`` per state.
    """
    import dask.dataframe as dd

    if target not in net:
        raise InputError(f"target {target!r} is not a variable of {net.name!r}")
    cases_to_indices(net, cases.head(0))  # unknown columns fail here, before any work
    network = bn_io.dumps(net, "xmlbif")
    meta = pd.DataFrame(
        {f"P({target}={state})": pd.Series(dtype=np.float64) for state in net.states(target)}
    )
    with dask_client(scheduler, workers) as client:
        n = partitions or 2 * max(len(client.scheduler_info()["workers"]), 1)
        pieces = max(1, min(n, len(cases) or 1))
        frame = dd.from_pandas(cases, npartitions=pieces, sort=False)  # type: ignore[no-untyped-call]
        answer: Any = frame.map_partitions(_answer, network, target, meta=meta)
        result: pd.DataFrame = client.compute(answer).result()
    return result
