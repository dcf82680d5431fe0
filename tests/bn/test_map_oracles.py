"""MAP (eq. 13) and marginal MAP (eq. 14) against other libraries on bnlearn networks.

**MPE oracle: pgmpy's max-product variable elimination, not pyAgrum.** pyAgrum 3.3.1 (the
newest on PyPI) cannot serve: ``LazyPropagation.mpe()`` and ``mpeLog2Posterior()`` raise
``FatalError: Empty tensor`` on alarm, child, insurance, hailfinder and win95pts for every
evidence tried (0–10 observed variables, barren-node and relevant-tensor finder settings,
one thread, all targets, uniform soft evidence on the free variables); with all targets set
it sometimes returns a partial instantiation (1 of alarm's 37 variables). pyAgrum has no
other max-product engine (``ShaferShenoyInference`` and ``VariableElimination`` have no
``mpe``). pgmpy's ``map_query`` builds the joint table of all query variables (10^17
entries for alarm), so it is used for marginal MAP only. What works is pgmpy
``VariableElimination.max_marginal`` — a max-product elimination — used with care:

- on the network as a ``DiscreteMarkovNetwork`` of the CPTs (its Bayesian-network path
  prunes barren nodes, valid for sums, not for maxima);
- evidence as indicator factors, one component at a time: pgmpy drops factors that become
  scalars (an observed family, a finished component), which made its maximum too large on
  andes (4 components) and with evidence;
- with pyAgrum's triangulation order (``JunctionTreeGenerator.eliminationOrder``): pgmpy's
  own MinFill/MinNeighbors orders take 50–80 s on insurance and ask for 189 GiB on
  hailfinder.

Since ties may pick different arg-maxes, the test compares probabilities: the log joint of
our assignment must equal pgmpy's maximum, and our ``P(x | e)`` must be that over ``P(e)``.

**Marginal MAP oracle: pyAgrum.** Its exact joint posterior of the 2–3 query variables
(``addJointTarget``/``jointPosterior``), maximised: our assignment must have the maximal
probability in pyAgrum's table (to 1e-9), and our returned probability must equal it.
"""

from __future__ import annotations

import math
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from tests.bn.helpers import sample_evidence
from tests.bn.test_oracles import load_both, log_joint

from bayesmap.bn import BayesNet

gum = pytest.importorskip("pyagrum")
pgmpy_factors = pytest.importorskip("pgmpy.factors.discrete")
pgmpy_inference = pytest.importorskip("pgmpy.inference")
pgmpy_models = pytest.importorskip("pgmpy.models")

NETWORKS = [
    "alarm",
    "child",
    "insurance",
    "hailfinder",
    "win95pts",
    pytest.param("andes", marks=pytest.mark.slow),  # 4 components; our cold MPE plan ~2 s
]


def pgmpy_mpe_log_value(net: BayesNet, order: list[str], evidence: dict[str, str]) -> float:
    """``log max_x P(x, e)`` by pgmpy's max-product elimination, summed over components."""
    graph = nx.Graph()
    graph.add_nodes_from(net.variables)
    for name in net.variables:
        graph.add_edges_from((name, p) for p in net.parents(name))
    total = 0.0
    for component in nx.connected_components(graph):
        model = pgmpy_models.DiscreteMarkovNetwork()
        model.add_nodes_from(component)
        factors = []
        for name in component:
            family = [name, *net.parents(name)]
            model.add_edges_from((a, b) for i, a in enumerate(family) for b in family[i + 1 :])
            states = {v: list(net.states(v)) for v in family}
            factors.append(
                pgmpy_factors.DiscreteFactor(
                    family, net.cpt(name).shape, net.cpt(name), state_names=states
                )
            )
            if name in evidence:
                states = list(net.states(name))
                indicator = [1.0 if s == evidence[name] else 0.0 for s in states]
                factors.append(
                    pgmpy_factors.DiscreteFactor(
                        [name], [len(states)], indicator, state_names={name: states}
                    )
                )
        model.add_factors(*factors)
        local = [v for v in order if v in component]
        engine = pgmpy_inference.VariableElimination(model)
        best = engine.max_marginal([local[-1]], elimination_order=local[:-1], show_progress=False)
        total += math.log(best) if best > 0 else -math.inf
    return total


@pytest.mark.parametrize("name", NETWORKS)
def test_mpe_agrees_with_pgmpy_max_product(name: str, tmp_path: Path) -> None:
    net, g = load_both(name, tmp_path)
    order = [g.variable(i).name() for i in gum.JunctionTreeGenerator().eliminationOrder(g)]
    rng = np.random.default_rng(11)
    for n_evidence in (0, 3, 6):
        evidence = sample_evidence(net, rng, n_evidence)
        ours, probability = net.map(evidence)
        assert set(ours) == set(net.variables) - set(evidence)
        value = log_joint(net, {**evidence, **ours})
        assert value == pytest.approx(pgmpy_mpe_log_value(net, order, evidence), abs=1e-9)
        expected = math.exp(value) / net.probability_of_evidence(evidence)
        assert probability == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("name", NETWORKS)
def test_marginal_map_agrees_with_pyagrum(name: str, tmp_path: Path) -> None:
    net, g = load_both(name, tmp_path)
    rng = np.random.default_rng(13)
    for n_query in (2, 3):
        evidence = sample_evidence(net, rng, 3)
        free = [v for v in net.variables if v not in evidence]
        query = [str(v) for v in rng.choice(free, size=n_query, replace=False)]
        engine = gum.LazyPropagation(g)
        engine.setEvidence(evidence)
        engine.addJointTarget(set(query))
        engine.makeInference()
        table = engine.jointPosterior(set(query))
        names = [table.variable(i).name() for i in range(table.nbrDim())]
        values = table.toarray()  # axes: pyAgrum stores the first variable fastest
        axes = names[::-1]
        ours, probability = net.marginal_map(query, evidence)
        index = tuple(list(g.variable(v).labels()).index(ours[v]) for v in axes)
        assert values[index] == pytest.approx(values.max(), abs=1e-9)
        assert probability == pytest.approx(values.max(), abs=1e-6)
