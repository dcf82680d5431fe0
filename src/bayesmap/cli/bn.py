"""``bayesmap bn``: inspect, query and convert Bayesian-network files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from bayesmap import bn
from bayesmap.cli.codegen import codegen
from bayesmap.errors import BayesmapError, InputError

app = typer.Typer(
    help="Inspect, query and convert Bayesian-network files (XMLBIF, BIF, XBN).",
    no_args_is_help=True,
)
app.command()(codegen)
_err = Console(stderr=True)


def _fail(error: BayesmapError) -> typer.Exit:
    _err.print(f"[red]error:[/red] {error}")
    return typer.Exit(1)


def _evidence(items: list[str] | None) -> dict[str, str]:
    evidence: dict[str, str] = {}
    for item in items or []:
        name, sep, state = item.partition("=")
        if not sep or not name.strip() or not state.strip():
            raise InputError(f"--evidence must be VARIABLE=STATE, got {item!r}")
        evidence[name.strip()] = state.strip()
    return evidence


@app.command()
def info(
    file: Annotated[
        Path, typer.Argument(help="Network file (.xml/.xmlbif/.bifxml, .bif, .xbn; .gz ok).")
    ],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """Show a network's variables, states, parents, node kinds and table sizes."""
    try:
        net = bn.read(file)
    except BayesmapError as error:
        raise _fail(error) from error
    kinds = {name: net.kind(name) for name in net.variables}
    rows: list[dict[str, Any]] = [
        {
            "name": name,
            "kind": kind.value if kind is not None else None,
            "states": list(net.states(name)),
            "parents": list(net.parents(name)),
            "cpt_size": int(net.cpt(name).size),
        }
        for name, kind in kinds.items()
    ]
    if as_json:
        typer.echo(json.dumps({"name": net.name, "variables": rows}, indent=2))
        return
    table = Table(title=f"{net.name}: {len(net)} variables, {len(net.edges())} edges")
    for column in ("variable", "kind", "states", "parents", "CPT size"):
        table.add_column(column)
    for row in rows:
        table.add_row(
            row["name"],
            row["kind"] or "",
            ", ".join(row["states"]),
            ", ".join(row["parents"]),
            str(row["cpt_size"]),
        )
    Console().print(table)


@app.command()
def query(
    file: Annotated[Path, typer.Argument(help="Network file.")],
    target: Annotated[
        list[str] | None,
        typer.Option("--target", "-t", help="Queried variable; repeat for a joint posterior."),
    ] = None,
    evidence: Annotated[
        list[str] | None,
        typer.Option("--evidence", "-e", help="Observation VARIABLE=STATE; repeat for more."),
    ] = None,
    map_: Annotated[
        bool,
        typer.Option(
            "--map",
            help="MAP instead of posteriors: over all unobserved variables, or marginal MAP "
            "over the --target variables.",
        ),
    ] = False,
    proposition: Annotated[
        str | None,
        typer.Option("--probability", help="Probability of a proposition, e.g. 'A=yes & !B=no'."),
    ] = None,
    fixed_point: Annotated[
        str | None,
        typer.Option("--fixed-point", help="Compute in a Q-format, e.g. Q16.16 or Q8.24."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Ask a network a question: posteriors, MAP, or the probability of a proposition."""
    try:
        net = bn.read(file)
        observed = _evidence(evidence)
        result = _answer(net, target or [], observed, map_, proposition, fixed_point)
    except BayesmapError as error:
        raise _fail(error) from error
    if as_json:
        typer.echo(json.dumps(result, indent=2))
        return
    _print(result)


def _answer(
    net: bn.BayesNet,
    targets: list[str],
    evidence: dict[str, str],
    map_: bool,
    proposition: str | None,
    fixed_point: str | None,
) -> dict[str, Any]:
    result: dict[str, Any] = {"network": net.name, "evidence": evidence}
    if fixed_point is not None:
        result["fixed_point"] = str(bn.QFormat.parse(fixed_point))
    if proposition is not None:
        result["proposition"] = proposition
        if fixed_point is not None:
            answer = net.probability_fixed(proposition, evidence, fixed_point)
            result["probability"] = float(answer.values)
            result["error_bound"] = float(answer.bound)
        else:
            result["probability"] = net.probability(proposition, evidence)
        return result
    if map_:
        if fixed_point is not None:
            assignment, answer = (
                net.marginal_map_fixed(targets, evidence, fixed_point)
                if targets
                else net.map_fixed(evidence, fixed_point)
            )
            probability = float(answer.values)
            result["error_bound"] = float(answer.bound)
        elif targets:
            assignment, probability = net.marginal_map(targets, evidence)
        else:
            assignment, probability = net.map(evidence)
        result["map"] = assignment
        result["probability"] = probability
        return result
    if not targets:
        raise InputError("give --target VARIABLE (or --map, or --probability)")
    if len(targets) > 1:
        bound = None
        if fixed_point is not None:
            joint = net.joint_posterior_fixed(targets, evidence, fixed_point)
            table, bound = joint.values, joint.bound
        else:
            table = net.joint_posterior(targets, evidence)
        result["targets"] = targets
        result["joint"] = [
            {
                **{t: net.states(t)[i] for t, i in zip(targets, index, strict=True)},
                "p": float(table[index]),
                **({} if bound is None else {"error_bound": float(bound[index])}),
            }
            for index in np.ndindex(*table.shape)
        ]
        return result
    result["target"] = targets[0]
    if fixed_point is not None:
        answer = net.posterior_fixed(targets[0], evidence, fixed_point)
        states = net.states(targets[0])
        result["posterior"] = dict(zip(states, answer.values.tolist(), strict=True))
        result["error_bound"] = dict(zip(states, answer.bound.tolist(), strict=True))
    else:
        result["posterior"] = net.posterior(targets[0], evidence)
    return result


def _print(result: dict[str, Any]) -> None:
    console = Console()
    shown = ", ".join(f"{k}={v}" for k, v in result["evidence"].items()) or "none"
    console.print(f"[bold]{result['network']}[/bold]  evidence: {shown}")
    if "fixed_point" in result:
        console.print(f"arithmetic: {result['fixed_point']} fixed point")
    bound = f" ± {result['error_bound']:.2g}" if "error_bound" in result else ""
    if "proposition" in result:
        console.print(f"P({result['proposition']} | evidence) = {result['probability']:.6g}{bound}")
        return
    if "map" in result:
        console.print(f"MAP probability given the evidence: {result['probability']:.6g}{bound}")
        table = Table(title="MAP")
        table.add_column("variable")
        table.add_column("state")
        for name, state in result["map"].items():
            table.add_row(name, state)
        console.print(table)
        return
    if "joint" in result:
        table = Table(title="joint posterior")
        for name in result["targets"]:
            table.add_column(name)
        table.add_column("P", justify="right")
        bounded = "error_bound" in result["joint"][0]
        if bounded:
            table.add_column("± bound", justify="right")
        for row in result["joint"]:
            extra = [f"{row['error_bound']:.2g}"] if bounded else []
            table.add_row(*(row[t] for t in result["targets"]), f"{row['p']:.6g}", *extra)
        console.print(table)
        return
    table = Table(title=f"P({result['target']} | evidence)")
    table.add_column("state")
    table.add_column("P", justify="right")
    if "error_bound" in result:
        table.add_column("± bound", justify="right")
    for state, p in result["posterior"].items():
        extra = [f"{result['error_bound'][state]:.2g}"] if "error_bound" in result else []
        table.add_row(state, f"{p:.6g}", *extra)
    console.print(table)


@app.command()
def convert(
    source: Annotated[Path, typer.Argument(help="Input network file.")],
    target: Annotated[Path, typer.Argument(help="Output file; the format follows its extension.")],
) -> None:
    """Convert a network between XMLBIF, BIF and XBN (by file extension)."""
    try:
        net = bn.read(source)
        bn.write(net, target)
    except BayesmapError as error:
        raise _fail(error) from error
    _err.print(f"wrote {target} ({len(net)} variables)")
