"""Networks compiled to portable C99, in float, double or Q-format fixed point.

Post et al. 2016 (§3) wrote their engine in bare C with fixed-point maths so that it would
run on the rover's low-power ARM computer. :func:`generate` turns a :class:`BayesNet` and
a declared question pattern — target variables, the variables that may be observed, the
variables that take soft evidence — into ``PREFIX.h`` and ``PREFIX.c``:

- CPTs (and the prior marginals that replace evidence-free ancestral sub-networks) are
  ``static const`` arrays in the ``(child, *parents)`` C layout;
- for every target and every subset of observed variables the engine's plan is built at
  generation time (barren nodes pruned, d-separated parts dropped, evidence slicing) and
  its contraction is written out as loops with constant bounds: no dynamic memory, no
  recursion, no libm;
- in fixed point the code repeats the engine's block floating point step by step
  (:mod:`bayesmap.bn.fixed_point`), so its answers are bit for bit the raw integers of
  :meth:`BayesNet.posterior_fixed` on the same question; in float/double it agrees with
  the float engine to rounding.

Examples
--------
>>> from bayesmap.bn import BayesNet
>>> from bayesmap.bn.codegen import generate
>>> net = BayesNet("rain")
>>> _ = net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
>>> _ = net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
>>> code = generate(net, ["Rain"], ["Wet"], "q16.16", name="rain")
>>> "int rain_posterior_Rain(" in code.header
True
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bayesmap import _io
from bayesmap.bn.codegen.emit import Arith, Spec, header, identifier, source
from bayesmap.bn.codegen.program import (
    SOFT_SUFFIX,
    Eliminate,
    Program,
    SoftNetwork,
    check_pattern,
    trace,
)
from bayesmap.bn.model import BayesNet
from bayesmap.bn.plans import QueryKind
from bayesmap.bn.suggest import unknown
from bayesmap.errors import ConfigError

__all__ = ["SOFT_SUFFIX", "Arith", "CSources", "SoftNetwork", "generate"]


@dataclass(frozen=True)
class CSources:
    """The generated C: ``{prefix}.h`` and ``{prefix}.c``, and what they answer.

    Attributes
    ----------
    prefix
        File stem and prefix of every public C name.
    header, source
        The text of the two files.
    arith
        The number type.
    targets, evidence, soft, data
        Variable names of the targets, the evidence slots, the soft-evidence slots and the
        data-node table slots, in the order the C API takes them.
    states
        Number of states of each target, evidence and soft variable.
    data_sizes
        Number of entries of each data node's table.
    functions
        Number of pattern functions (targets × subsets of the evidence slots).
    """

    prefix: str
    header: str
    source: str
    arith: Arith
    targets: tuple[str, ...]
    evidence: tuple[str, ...]
    soft: tuple[str, ...]
    data: tuple[str, ...]
    states: dict[str, int]
    data_sizes: dict[str, int]
    functions: int

    def write(self, directory: str | Path) -> tuple[Path, Path]:
        """Write both files (atomically) into ``directory``; return their paths."""
        folder = Path(directory)
        _io.make_folder(folder)
        h = _io.write_text(folder / f"{self.prefix}.h", self.header)
        c = _io.write_text(folder / f"{self.prefix}.c", self.source)
        return h, c


def generate(
    net: BayesNet,
    targets: Sequence[str],
    evidence_vars: Sequence[str],
    arith: str | Arith = "q16.16",
    *,
    soft: Sequence[str] = (),
    name: str | None = None,
) -> CSources:
    """Compile the question pattern ``P(target | evidence_vars, soft)`` of ``net`` to C99.

    Parameters
    ----------
    net
        The network. Data nodes (tables computed at query time) become run-time table
        arguments of the C functions.
    targets
        Variables whose distribution the code answers (one C function each).
    evidence_vars
        Variables that may be observed (each, per call, a state index or not observed);
        at most :data:`~bayesmap.bn.codegen.program.MAX_PATTERN_VARIABLES`.
    arith
        ``"float"``, ``"double"``, ``"q16.16"`` or ``"q8.24"`` (any ``Q<I>.<F>`` of 32 bits
        or fewer).
    soft
        Variables that take soft evidence: a likelihood vector with entries in [0, 1]
        (Pearl's virtual evidence), or ``NULL`` for none.
    name
        Prefix of the files and of the C names; default: the network's name.

    Raises
    ------
    ConfigError
        Unknown variables, a target also declared as evidence, too many evidence
        variables, an unknown arithmetic, an invalid C prefix, or two variables whose C
        names would be the same.
    """
    kind = Arith.parse(arith)
    prefix = name if name is not None else identifier(net.name).lower()
    if identifier(prefix) != prefix:
        raise ConfigError(
            f"{prefix!r} cannot prefix C names: use letters, digits and '_' (not first a digit)"
        )
    targets, evidence_vars, soft = tuple(targets), tuple(evidence_vars), tuple(soft)
    check_pattern(net, targets, evidence_vars)
    for variable in soft:
        if variable not in net:
            raise ConfigError(
                f"network {net.name!r} has no variable {variable!r} (soft evidence); "
                + unknown("variable", variable, net.variables)
            )
    if len(set(soft)) != len(soft):
        raise ConfigError(f"a soft-evidence variable is listed twice in {list(soft)}")
    augmented = SoftNetwork.build(net, soft).net
    engine = augmented._engine  # the engine whose plans and paths the C code repeats
    compiled = engine.compiled
    virtual = {compiled.id(v + SOFT_SUFFIX): compiled.id(v) for v in soft}
    ids = [compiled.id(v) for v in evidence_vars]
    programs: dict[int, list[Program]] = {}
    for target in targets:
        t = compiled.id(target)
        programs[t] = []
        for mask in range(1 << len(ids)):
            observed = {v for k, v in enumerate(ids) if mask >> k & 1} | set(virtual)
            plan = engine.plan(QueryKind.MARGINAL, (t,), frozenset(observed))
            programs[t].append(trace(compiled, plan, engine.fixed_path(plan), virtual))
    priors = {v: engine.prior(v) for v in _prior_vars(programs)}
    data = tuple(
        v for v in range(len(compiled.names)) if v in compiled.sources and v not in virtual
    )
    _check_c_names((*targets, *evidence_vars, *soft, *(compiled.names[v] for v in data)))
    spec = Spec(
        prefix=prefix,
        arith=kind,
        compiled=compiled,
        targets=tuple(compiled.id(t) for t in targets),
        evidence=tuple(ids),
        soft=tuple(compiled.id(v) for v in soft),
        data=data,
        priors=priors,
        network=net.name,
    )
    text = source(spec, programs)
    return CSources(
        prefix=prefix,
        header=header(spec),
        source=text,
        arith=kind,
        targets=targets,
        evidence=evidence_vars,
        soft=soft,
        data=tuple(compiled.names[v] for v in data),
        states={v: compiled.card[compiled.id(v)] for v in (*targets, *evidence_vars, *soft)},
        data_sizes={compiled.names[v]: compiled.cpts[v].size for v in data},
        functions=sum(len(p) for p in programs.values()),
    )


def _check_c_names(names: Sequence[str]) -> None:
    """ConfigError if two variables the C code names would get the same C name (macros
    are upper case, so names that differ only in case clash too)."""
    seen: dict[str, str] = {}
    for name in dict.fromkeys(names):
        ident = identifier(name).upper()
        if ident in seen:
            raise ConfigError(
                f"variables {seen[ident]!r} and {name!r} both become the C name "
                f"{identifier(name)!r}; rename one of them in the network file"
            )
        seen[ident] = name


def _prior_vars(programs: dict[int, list[Program]]) -> set[int]:
    """Variables whose prior marginal some program reads (a replaced sub-network or a check)."""
    found: set[int] = set()
    for progs in programs.values():
        for program in progs:
            views = [c.view for c in program.checks] + [program.result]
            for step in program.steps:
                views += [step.source] if isinstance(step, Eliminate) else [step.a, step.b]
            found.update(
                view.table.var
                for view in views
                if view.table is not None and view.table.kind == "prior"
            )
    return found
