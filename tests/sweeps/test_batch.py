"""Batch posteriors on a LocalCluster equal the single-machine batch, row for row."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from bayesmap import bn
from bayesmap.bn.cases import posterior_frame
from bayesmap.sweeps.batch import posterior_batch


def _net():
    net = bn.BayesNet("sprinkler")
    net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
    # CPTs are laid out (child, *parents)
    net.add_variable("Sprinkler", ["off", "on"], parents=["Rain"], cpt=[[0.6, 0.99], [0.4, 0.01]])
    net.add_variable(
        "Wet",
        ["dry", "wet"],
        parents=["Rain", "Sprinkler"],
        cpt=[[[1.0, 0.1], [0.2, 0.01]], [[0.0, 0.9], [0.8, 0.99]]],
    )
    return net


def _cases(n, rng):
    sprinkler = rng.choice(["off", "on", None], size=n)
    wet = rng.choice(["dry", "wet", None], size=n)
    return pd.DataFrame({"Sprinkler": sprinkler, "Wet": wet}, index=[f"case{i}" for i in range(n)])


@pytest.mark.slow
def test_a_local_cluster_gives_the_single_machine_answer():
    net = _net()
    cases = _cases(500, np.random.default_rng(4))
    got = posterior_batch(net, ["Rain", "Sprinkler"], cases, workers=2, partitions=7)
    expected = posterior_frame(net, cases, ["Rain", "Sprinkler"])
    assert list(got.index) == list(cases.index)
    assert list(got.columns) == ["Rain=no", "Rain=yes", "Sprinkler=off", "Sprinkler=on"]
    # each partition is one batch to the engine, whose contraction for a group of evidence
    # patterns may round in another order than one big batch: equal to the last few bits
    np.testing.assert_allclose(got.to_numpy(), expected.to_numpy(), rtol=1e-12, atol=0)


@pytest.mark.slow
def test_bn_query_cases_on_a_scheduler_writes_the_single_machine_file(tmp_path):
    """``bn query --cases --scheduler`` on a local cluster writes the answers a single
    machine writes (here the cluster is started in-process: ``--scheduler`` takes its
    address), to rounding."""
    from distributed import Client, LocalCluster
    from typer.testing import CliRunner

    from bayesmap.cli import app

    net = _net()
    network = tmp_path / "sprinkler.xml"
    bn.write(net, network)
    cases = _cases(300, np.random.default_rng(5))
    cases.to_csv(tmp_path / "cases.csv", index=False)
    args = ["bn", "query", str(network), "--cases", str(tmp_path / "cases.csv"), "-t", "Rain"]
    runner = CliRunner()
    assert runner.invoke(app, [*args, "--out", str(tmp_path / "one.csv")]).exit_code == 0
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster,
        Client(cluster),
    ):
        result = runner.invoke(
            app,
            [*args, "--out", str(tmp_path / "many.csv"), "--scheduler", cluster.scheduler_address],
        )
    assert result.exit_code == 0, result.output
    one, many = (pd.read_csv(tmp_path / name) for name in ("one.csv", "many.csv"))
    assert list(many.columns) == list(one.columns) == ["Rain=no", "Rain=yes"]
    np.testing.assert_allclose(many.to_numpy(), one.to_numpy(), rtol=1e-12, atol=0)
