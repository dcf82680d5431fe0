"""The ``bayesmap`` command: parse, call the library, report; no logic of its own.

Sub-commands live one module per group (``bn``, ``sonar``) and are mounted here.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    Task,
    TaskID,
    TextColumn,
)
from rich.table import Table
from rich.text import Text

from bayesmap import __version__
from bayesmap.cli import bn as bn_commands
from bayesmap.cli import rover as rover_commands
from bayesmap.cli import sonar as sonar_commands
from bayesmap.errors import BayesmapError
from bayesmap.experiments import EXPERIMENTS, ExperimentResult, load

app = typer.Typer(
    name="bayesmap",
    help="Bayesian mapping and decision-making with sparse, noisy, local sensors.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
app.add_typer(bn_commands.app, name="bn")
app.add_typer(sonar_commands.app, name="sonar")
app.add_typer(rover_commands.app, name="rover")
console = Console(stderr=True)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"bayesmap {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = False,
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log progress details.")] = False,
) -> None:
    """Bayesian mapping and decision-making with sparse, noisy, local sensors."""
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )


@app.command()
def reproduce(
    experiments: Annotated[
        list[str] | None,
        typer.Argument(
            help="Experiments to run (default: all). Known: see 'bayesmap reproduce --list'."
        ),
    ] = None,
    out: Annotated[
        Path, typer.Option("--out", help="Output folder; each experiment writes DIR/<name>/.")
    ] = Path("results"),
    list_: Annotated[bool, typer.Option("--list", help="List the experiments and exit.")] = False,
) -> None:
    """Run the paper experiments at their default size; write figures, maps and metrics."""
    if list_:
        for name in EXPERIMENTS:
            doc = (load(name).__doc__ or "").strip()
            typer.echo(f"{name}\t{doc.splitlines()[0] if doc else ''}")
        return
    names = list(experiments) if experiments else list(EXPERIMENTS)
    unknown = [name for name in names if name not in EXPERIMENTS]
    if unknown:
        console.print(
            f"[red]error:[/red] unknown experiment(s) {', '.join(unknown)}; "
            f"choose from: {', '.join(EXPERIMENTS) or 'none'}"
        )
        raise typer.Exit(2)
    results: list[tuple[ExperimentResult, float]] = []
    with Progress(
        TextColumn("[bold]{task.fields[experiment]}[/bold]"),
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        _ExperimentTime(),
        console=console,
        transient=False,
    ) as progress:
        for name in names:
            module = load(name)
            task = progress.add_task("starting", total=None, experiment=name)

            def hook(description: str, completed: int, total: int, _task: TaskID = task) -> None:
                progress.update(_task, description=description, completed=completed, total=total)

            started = time.perf_counter()
            try:
                result = module.run(module.Config(), out / name, progress=hook)
            except BayesmapError as error:
                console.print(f"[red]error in {name}:[/red] {error}")
                raise typer.Exit(1) from error
            results.append((result, time.perf_counter() - started))
            progress.update(task, description="done")
            progress.stop_task(task)
    _print_summary(results)


class _ExperimentTime(ProgressColumn):
    """Time since the experiment started, until it is stopped.

    An experiment reports several stages (runs, conditions) through one task, each counting
    up to its own total; rich's elapsed-time column freezes at the first stage that
    completes, this one runs until the whole experiment is done.
    """

    def render(self, task: Task) -> Text:
        seconds = int(task.elapsed or 0)
        return Text(f"{seconds // 60}:{seconds % 60:02d}", style="progress.elapsed")


def _print_summary(
    results: list[tuple[ExperimentResult, float]], out: Console | None = None
) -> None:
    """Where each experiment wrote its figures and metrics, then its headline numbers.

    The table keeps to what fits a narrow terminal (folders, counts, the summary file); the
    headlines follow as wrapped lines, one experiment each.
    """
    out = out or Console()
    table = Table(title="bayesmap reproduce: where the results are")
    table.add_column("experiment")
    table.add_column("folder", overflow="fold")
    table.add_column("figures", justify="right")
    table.add_column("metrics", justify="right")
    table.add_column("read first", overflow="fold")
    table.add_column("time", justify="right")
    for result, seconds in results:
        summaries = [path for path in result.metrics if path.suffix == ".md"]
        table.add_row(
            result.name,
            str(result.out_dir),
            str(len(result.figures)),
            str(len(result.metrics)),
            summaries[0].name if summaries else "",
            f"{seconds:.1f} s",
        )
    out.print(table)
    for result, _ in results:
        numbers = ", ".join(f"{key} {_fmt(value)}" for key, value in result.headline.items())
        out.print(f"[bold]{result.name}[/bold]: {numbers}", highlight=False)


def _fmt(value: float | int | str) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def main() -> None:
    """Entry point of the ``bayesmap`` console script."""
    try:
        app()
    except BayesmapError as error:
        console.print(f"[red]error:[/red] {error}")
        raise SystemExit(1) from error


__all__ = ["app", "main"]
