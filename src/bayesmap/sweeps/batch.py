"""Batch inference on a Dask cluster: many evidence cases, partitioned across workers.

The cases are pandas DataFrames, one column per observed variable holding state names
(blank = unobserved), as :mod:`bayesmap.bn.cases` reads them from CSV or Parquet. Each
table is split into partitions with ``dask.dataframe``; every worker rebuilds the network
from its XMLBIF text (workers receive data, not live objects) and answers its partition
with :func:`bayesmap.bn.cases.posterior_frame` — the engine's batched exact posterior (Post
et al. 2016 eqs. 1–3). The answer is the table a single machine computes, row for row.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np
import pandas as pd

from bayesmap import bn
from bayesmap.bn import io as bn_io
from bayesmap.bn.cases import case_array, column_name, posterior_frame
from bayesmap.errors import InputError
from bayesmap.sweeps.runner import dask_client

__all__ = ["posterior_batch", "posterior_batches"]


def _answer(partition: pd.DataFrame, network: str, targets: list[str]) -> pd.DataFrame:
    """The posteriors of ``targets`` for one partition (runs on a worker)."""
    return posterior_frame(bn_io.loads(network, "xmlbif"), partition, targets)


def posterior_batches(
    net: bn.BayesNet,
    tables: Iterable[pd.DataFrame],
    targets: Sequence[str],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    partitions: int | None = None,
) -> Iterator[pd.DataFrame]:
    """``P(target = state | case)`` for each table of cases in turn, on one Dask cluster.

    Parameters
    ----------
    net
        The network.
    tables
        Tables of cases (e.g. the chunks of :func:`bayesmap.bn.cases.read_cases`).
    targets
        The queried variables.
    scheduler
        Address of a Dask scheduler; ``None`` starts a ``LocalCluster`` of ``workers``.
    partitions
        How many pieces to split each table into (default: two per worker).

    Yields
    ------
    One DataFrame per table, with its index and one column per target state (named by
    :func:`bayesmap.bn.cases.column_name`), equal to the single-machine answer.
    """
    import dask.dataframe as dd

    targets = list(targets)
    for target in targets:
        if target not in net:
            raise InputError(f"target {target!r} is not a variable of {net.name!r}")
    network = bn_io.dumps(net, "xmlbif")
    meta = pd.DataFrame(
        {column_name(t, s): pd.Series(dtype=np.float64) for t in targets for s in net.states(t)}
    )
    with dask_client(scheduler, workers) as client:
        n = partitions or 2 * max(len(client.scheduler_info()["workers"]), 1)
        for cases in tables:
            case_array(net, cases.head(0))  # unknown columns fail here, before any work
            pieces = max(1, min(n, len(cases) or 1))
            frame = dd.from_pandas(cases, npartitions=pieces, sort=False)  # type: ignore[no-untyped-call]
            answer: Any = frame.map_partitions(_answer, network, targets, meta=meta)
            result: pd.DataFrame = client.compute(answer).result()
            yield result


def posterior_batch(
    net: bn.BayesNet,
    targets: Sequence[str],
    cases: pd.DataFrame,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    partitions: int | None = None,
) -> pd.DataFrame:
    """One table of cases answered on a Dask cluster (see :func:`posterior_batches`)."""
    return next(
        posterior_batches(
            net, [cases], targets, scheduler=scheduler, workers=workers, partitions=partitions
        )
    )
