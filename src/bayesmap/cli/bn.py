"""``bayesmap bn``: inspect, query, draw and convert Bayesian-network files.

Messages print literally (no Rich markup is read from network or user text); a usage
mistake (a malformed or repeated option, options that contradict each other) exits with
code 2, a failed question (unknown variable, impossible evidence, bad file) with code 1,
each as one line on stderr.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer

from bayesmap.cli._console import USAGE, console, print_error, print_note, progress_bar
from bayesmap.cli.codegen import codegen
from bayesmap.errors import BayesmapError, InputError

if TYPE_CHECKING:
    from collections.abc import Iterator

    import pandas as pd

    from bayesmap import bn
    from bayesmap._typing import ProgressHook

# The engine (numpy, opt_einsum, lxml) is imported inside the commands, so that
# ``bayesmap --help`` and the other command groups start without it.

app = typer.Typer(
    help="Inspect, query, draw and convert network files (XMLBIF, BIF, XBN, NET, XDSL, UAI).",
    no_args_is_help=True,
    rich_markup_mode=None,
)
app.command()(codegen)


def _fail(message: object, code: int = 1) -> NoReturn:
    """Print ``error: message`` as one literal line on stderr and exit with ``code``."""
    print_error(" ".join(str(message).split()))
    raise typer.Exit(code)


def _pairs(option: str, items: list[str] | None) -> dict[str, str]:
    """``NAME=VALUE`` options as a dict; malformed or repeated names are usage errors."""
    pairs: dict[str, str] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            what = "VARIABLE=STATE" if option == "--evidence" else "VARIABLE=w1,w2,..."
            _fail(f"{option} must be {what}, got {item!r}", USAGE)
        if name in pairs:
            _fail(f"{option} gives {name!r} twice ({pairs[name]!r} and {value!r})", USAGE)
        pairs[name] = value
    return pairs


def _likelihood(name: str, text: str) -> list[float] | dict[str, float]:
    """``w1,w2,...`` (one weight per state) or ``state:w,state:w`` (every state named)."""
    weights: dict[str, float] = {}
    plain: list[float] = []
    for part in text.split(","):
        state, sep, number = part.rpartition(":")
        try:
            value = float(number)
        except ValueError:
            _fail(f"--soft {name}: {number.strip()!r} is not a number", USAGE)
        if sep:
            weights[state.strip()] = value
        else:
            plain.append(value)
    if weights and plain:
        _fail(f"--soft {name}: write all weights as state:weight, or none", USAGE)
    return weights or plain


def _load(file: Path) -> bn.BayesNet:
    from bayesmap import bn

    try:
        return bn.read(file)
    except BayesmapError as error:
        _fail(error)


@app.command()
def info(
    file: Annotated[
        Path,
        typer.Argument(
            help="Network file (.xml/.xmlbif/.bifxml, .bif, .xbn, .net, .xdsl, .uai; .gz ok)."
        ),
    ],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """Show a network's variables, states, parents, node kinds and table sizes."""
    net = _load(file)
    rows: list[dict[str, Any]] = []
    for name in net.variables:
        kind = net.kind(name)
        rows.append(
            {
                "name": name,
                "kind": kind.value if kind is not None else None,
                "states": list(net.states(name)),
                "parents": list(net.parents(name)),
                "cpt_size": int(net.cpt(name).size),
            }
        )
    if as_json:
        typer.echo(json.dumps({"name": net.name, "variables": rows}, indent=2))
        return
    from rich.table import Table

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
    console().print(table)


@app.command()
def query(
    file: Annotated[Path, typer.Argument(help="Network file.")],
    target: Annotated[
        list[str] | None,
        typer.Option(
            "--target",
            "-t",
            help="Queried variable; repeat for a joint posterior (or, with --cases, for "
            "more answer columns). Without any: every unobserved variable's posterior.",
        ),
    ] = None,
    evidence: Annotated[
        list[str] | None,
        typer.Option("--evidence", "-e", help="Observation VARIABLE=STATE; repeat for more."),
    ] = None,
    soft: Annotated[
        list[str] | None,
        typer.Option(
            "--soft",
            help="Soft (likelihood) evidence VARIABLE=w1,w2,... (one weight per state, in "
            "state order) or VARIABLE=state:w,...; repeat for more.",
        ),
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
        typer.Option(
            "--probability",
            help="Probability of a proposition, e.g. 'A=yes and not (B=no or C=on)'.",
        ),
    ] = None,
    given: Annotated[
        str | None,
        typer.Option(
            "--given", help="Condition of --probability (a proposition): P(prop | given)."
        ),
    ] = None,
    fixed_point: Annotated[
        str | None,
        typer.Option("--fixed-point", help="Compute in a Q-format, e.g. Q16.16 or Q8.24."),
    ] = None,
    cases: Annotated[
        Path | None,
        typer.Option(
            "--cases",
            help="Batch: a .csv or .parquet table, one column per observed variable, one "
            "row per case, blank = unobserved; needs --target and --out.",
        ),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Batch answers (.csv or .parquet): one column per state."),
    ] = None,
    chunk_rows: Annotated[
        int | None,
        typer.Option("--chunk-rows", min=1, help="Cases per chunk of a batch [default: 65536]."),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="With --cases: answer the batch on the Dask scheduler at this address "
            "(e.g. tcp://10.0.0.5:8786); see docs/cluster.md.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Ask a network: posteriors, MAP, a proposition's probability, or a batch from a file."""
    targets = list(target or [])
    if scheduler is not None and cases is None:
        _fail("--scheduler answers a batch: give --cases and --out too", USAGE)
    if chunk_rows is not None and cases is None:
        _fail("--chunk-rows sizes a batch's chunks: give --cases and --out too", USAGE)
    _check_usage(targets, map_, proposition, given, cases, out, fixed_point, evidence, soft)
    repeated = sorted({t for t in targets if targets.count(t) > 1})
    if repeated:
        _fail(f"--target {repeated[0]!r} is given twice", USAGE)
    observed = _pairs("--evidence", evidence)
    weights = {name: _likelihood(name, text) for name, text in _pairs("--soft", soft).items()}
    both = sorted(set(observed) & set(weights))
    if both:
        _fail(f"{both[0]!r} has both --evidence and --soft; give one", USAGE)
    net = _load(file)
    if cases is not None and out is not None:
        _batch(net, targets, cases, out, chunk_rows, scheduler)
        return
    try:
        result = _answer(net, targets, observed, weights, map_, proposition, given, fixed_point)
    except BayesmapError as error:
        _fail(error)
    if as_json:
        typer.echo(json.dumps(result, indent=2))
        return
    _print(result)


def _check_usage(
    targets: list[str],
    map_: bool,
    proposition: str | None,
    given: str | None,
    cases: Path | None,
    out: Path | None,
    fixed_point: str | None,
    evidence: list[str] | None,
    soft: list[str] | None,
) -> None:
    """Refuse options that contradict each other (exit code 2)."""
    if map_ and proposition is not None:
        _fail("--map and --probability ask different questions; give one", USAGE)
    if proposition is not None and targets:
        _fail("--probability takes no --target (name the variables in the proposition)", USAGE)
    if given is not None and proposition is None:
        _fail("--given is the condition of --probability; give --probability too", USAGE)
    if (cases is None) != (out is None):
        _fail("--cases and --out go together: the answers of a batch go to a file", USAGE)
    if cases is not None:
        if not targets:
            _fail("--cases needs --target (the variables whose posteriors to write)", USAGE)
        extra = [
            name
            for name, used in (
                ("--map", map_),
                ("--probability", proposition is not None),
                ("--fixed-point", fixed_point is not None),
                ("--evidence", bool(evidence)),
                ("--soft", bool(soft)),
            )
            if used
        ]
        if extra:
            _fail(f"--cases takes its evidence from the file; drop {', '.join(extra)}", USAGE)


def _batch(
    net: bn.BayesNet,
    targets: list[str],
    cases: Path,
    out: Path,
    chunk_rows: int | None,
    scheduler: str | None,
) -> None:
    """Stream a cases file through the network into an answers file, with a progress bar;
    with ``scheduler``, each chunk is answered across that Dask cluster's workers."""
    from bayesmap.bn import cases as batch

    chunk_rows = chunk_rows or batch.CHUNK_ROWS
    try:
        for t in targets:
            net.variable(t)
        for path in (cases, out):
            batch.check_suffix(path)
        if out.resolve() == cases.resolve():
            raise InputError(f"--out {out} is the cases file; name another file for the answers")
        total = batch.count_cases(cases)
        columns = [batch.column_name(t, s) for t in targets for s in net.states(t)]
        with progress_bar(console(stderr=True), first="cases", remaining=True) as hook:
            chunks = batch.read_cases(cases, chunk_rows=chunk_rows)
            if scheduler is None:
                answers = batch.run_batch(
                    net, chunks, targets, chunk_rows=chunk_rows, total=total, progress=hook
                )
            else:
                from bayesmap.sweeps.batch import posterior_batches

                answers = _counted(
                    posterior_batches(net, chunks, targets, scheduler=scheduler), hook, total
                )
            rows = batch.write_posteriors(out, answers, columns)
    except BayesmapError as error:
        _fail(error)
    print_note(f"wrote {out} ({rows} cases, {len(columns)} columns)")


def _counted(
    tables: Iterator[pd.DataFrame], hook: ProgressHook, total: int
) -> Iterator[pd.DataFrame]:
    """``tables`` passed on, reporting the rows done so far to ``hook``."""
    done = 0
    for table in tables:
        done += len(table)
        hook("cases", done, total)
        yield table


def _answer(
    net: bn.BayesNet,
    targets: list[str],
    evidence: dict[str, str],
    soft: dict[str, Any],
    map_: bool,
    proposition: str | None,
    given: str | None,
    fixed_point: str | None,
) -> dict[str, Any]:
    from bayesmap import bn

    result: dict[str, Any] = {"network": net.name, "evidence": evidence}
    if soft:
        result["soft"] = soft
    if fixed_point is not None:
        result["fixed_point"] = str(bn.QFormat.parse(fixed_point))
    if proposition is not None:
        prop = bn.parse(proposition, bar=False)
        condition = None if given is None else bn.parse(given, bar=False)
        result["proposition"] = str(prop)
        if condition is not None:
            result["given"] = str(condition)
        if fixed_point is not None:
            answer = net.probability_fixed(prop, evidence, fixed_point, given=condition, soft=soft)
            result["probability"] = float(answer.values)
            result["error_bound"] = float(answer.bound)
        else:
            result["probability"] = net.probability(prop, evidence, given=condition, soft=soft)
        return result
    if map_:
        if fixed_point is not None:
            assignment, answer = (
                net.marginal_map_fixed(targets, evidence, fixed_point, soft=soft)
                if targets
                else net.map_fixed(evidence, fixed_point, soft=soft)
            )
            probability = float(answer.values)
            result["error_bound"] = float(answer.bound)
        elif targets:
            assignment, probability = net.marginal_map(targets, evidence, soft=soft)
        else:
            assignment, probability = net.map(evidence, soft=soft)
        result["map"] = assignment
        result["probability"] = probability
        return result
    if len(targets) > 1:
        return {**result, **_joint(net, targets, evidence, soft, fixed_point)}
    if not targets and fixed_point is None:
        result["posteriors"] = net.posteriors(evidence, soft=soft)
        return result
    if not targets:
        answers = {
            name: _posterior(net, name, evidence, soft, fixed_point)
            for name in net.variables
            if name not in evidence
        }
        result["posteriors"] = {name: a["posterior"] for name, a in answers.items()}
        result["error_bounds"] = {name: a["error_bound"] for name, a in answers.items()}
        return result
    result["target"] = targets[0]
    result.update(_posterior(net, targets[0], evidence, soft, fixed_point))
    return result


def _posterior(
    net: bn.BayesNet,
    target: str,
    evidence: dict[str, str],
    soft: dict[str, Any],
    fixed_point: str | None,
) -> dict[str, Any]:
    """``{"posterior": {state: p}}``, with ``"error_bound"`` per state in fixed point."""
    if fixed_point is None:
        return {"posterior": net.posterior(target, evidence, soft=soft)}
    answer = net.posterior_fixed(target, evidence, fixed_point, soft=soft)
    states = net.states(target)
    return {
        "posterior": dict(zip(states, answer.values.tolist(), strict=True)),
        "error_bound": dict(zip(states, answer.bound.tolist(), strict=True)),
    }


def _joint(
    net: bn.BayesNet,
    targets: list[str],
    evidence: dict[str, str],
    soft: dict[str, Any],
    fixed_point: str | None,
) -> dict[str, Any]:
    import numpy as np

    bound = None
    if fixed_point is not None:
        joint = net.joint_posterior_fixed(targets, evidence, fixed_point, soft=soft)
        table, bound = joint.values, joint.bound
    else:
        table = net.joint_posterior(targets, evidence, soft=soft)
    rows = [
        {
            **{t: net.states(t)[i] for t, i in zip(targets, index, strict=True)},
            "p": float(table[index]),
            **({} if bound is None else {"error_bound": float(bound[index])}),
        }
        for index in np.ndindex(*table.shape)
    ]
    return {"targets": targets, "joint": rows}


def _print(result: dict[str, Any]) -> None:
    from rich.table import Table

    out = console()
    shown = [f"{k}={v}" for k, v in result["evidence"].items()]
    shown += [f"{k}~{v}" for k, v in result.get("soft", {}).items()]
    out.print(f"{result['network']}  evidence: {', '.join(shown) or 'none'}")
    if "fixed_point" in result:
        out.print(f"arithmetic: {result['fixed_point']} fixed point")
    if "proposition" in result:
        bound = f" ± {result['error_bound']:.2g}" if "error_bound" in result else ""
        condition = f"{result['given']}, evidence" if "given" in result else "evidence"
        value = f"{result['probability']:.6g}{bound}"
        out.print(f"P({result['proposition']} | {condition}) = {value}")
        return
    if "map" in result:
        bound = f" ± {result['error_bound']:.2g}" if "error_bound" in result else ""
        out.print(f"MAP probability given the evidence: {result['probability']:.6g}{bound}")
        table = Table(title="MAP")
        table.add_column("variable")
        table.add_column("state")
        for name, state in result["map"].items():
            table.add_row(name, state)
        out.print(table)
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
        out.print(table)
        return
    if "target" in result:
        answers = {result["target"]: (result["posterior"], result.get("error_bound"))}
        title = f"P({result['target']} | evidence)"
    else:
        bounds_of = result.get("error_bounds", {})
        answers = {n: (p, bounds_of.get(n)) for n, p in result["posteriors"].items()}
        title = "P(each variable | evidence)"
    bounded = "error_bound" in result or "error_bounds" in result
    table = Table(title=title, min_width=len(title) + 2)  # the title on one line
    if "target" not in result:
        table.add_column("variable")
    table.add_column("state")
    table.add_column("P", justify="right")
    if bounded:
        table.add_column("± bound", justify="right")
    for name, (posterior, bounds) in answers.items():
        for k, (state, p) in enumerate(posterior.items()):
            first = [] if "target" in result else [name if k == 0 else ""]
            extra = [f"{bounds[state]:.2g}"] if bounds is not None else []
            table.add_row(*first, state, f"{p:.6g}", *extra, end_section=k == len(posterior) - 1)
    out.print(table)


@app.command()
def draw(
    file: Annotated[Path, typer.Argument(help="Network file.")],
    out: Annotated[Path, typer.Option("--out", help="Drawing: .svg or .png.")],
    layout: Annotated[
        str,
        typer.Option(
            "--layout",
            help="auto: Graphviz 'dot' if installed, else the built-in layered layout; "
            "dot; or python.",
        ),
    ] = "auto",
) -> None:
    """Draw a network, nodes coloured by kind: ability green, bus red, classification blue,
    data yellow."""
    import shutil
    import subprocess

    suffix = out.suffix.lower()
    if suffix not in (".svg", ".png"):
        _fail(f"--out must end in .svg or .png, got {out.name!r}", USAGE)
    if layout not in ("auto", "dot", "python"):
        _fail(f"--layout must be auto, dot or python, got {layout!r}", USAGE)
    dot = shutil.which("dot") if layout != "python" else None
    if layout == "dot" and dot is None:
        _fail("--layout dot: the Graphviz 'dot' program is not on PATH")
    net = _load(file)
    from bayesmap._io import write_bytes
    from bayesmap.viz.network import network_image, to_dot

    if dot is not None:
        done = subprocess.run(
            [dot, f"-T{suffix[1:]}"], input=to_dot(net).encode(), capture_output=True, check=False
        )
        if done.returncode != 0:
            _fail(f"dot failed: {done.stderr.decode(errors='replace')}")
        image, how = done.stdout, "Graphviz dot"
    else:
        image, how = network_image(net, suffix), "layered layout"
    write_bytes(out, image)
    print_note(f"wrote {out} ({len(net)} variables, {how})")


@app.command()
def convert(
    source: Annotated[Path, typer.Argument(help="Input network file.")],
    target: Annotated[Path, typer.Argument(help="Output file; the format follows its extension.")],
) -> None:
    """Convert a network between XMLBIF, BIF, XBN, Hugin NET, GeNIe XDSL and UAI (by extension)."""
    from bayesmap import bn

    if target.exists() and source.exists() and target.samefile(source):
        _fail(f"{target} is the input file; write the conversion to another path", code=2)
    net = _load(source)
    try:
        bn.write(net, target)
    except BayesmapError as error:
        _fail(error)
    print_note(f"wrote {target} ({len(net)} variables)")
    if target.suffix.lower() == ".uai":  # the format has numbers only
        print_note(
            f"warning: {target} keeps no variable or state names (UAI has none): they read "
            "back as 0, 1, ...; keep the original to query by name"
        )
