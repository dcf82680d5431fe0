"""``bayesmap reproduce``: run the paper experiments, then print where their results are."""

from __future__ import annotations

import shlex
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

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

from bayesmap.cli._console import console as make_console
from bayesmap.cli._console import print_error, styled
from bayesmap.errors import BayesmapError

if TYPE_CHECKING:
    from bayesmap.experiments import ExperimentResult

console = make_console(stderr=True)


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
    """Run the paper experiments at their default size; write figures, maps and metrics.

    Each experiment's folder appears only once it is complete, with a manifest.json
    listing every file (size, SHA-256); an interrupted run leaves the previous one intact.
    """
    from bayesmap.experiments import EXPERIMENTS, load  # pydantic and the experiments

    if list_:
        for name in EXPERIMENTS:
            doc = (load(name).__doc__ or "").strip()
            typer.echo(f"{name}\t{doc.splitlines()[0] if doc else ''}")
        return
    names = list(experiments) if experiments else list(EXPERIMENTS)
    unknown = [name for name in names if name not in EXPERIMENTS]
    if unknown:
        print_error(
            f"unknown experiment(s) {', '.join(unknown)}; "
            f"choose from: {', '.join(EXPERIMENTS) or 'none'}",
            out=console,
        )
        raise typer.Exit(2)
    results: list[tuple[ExperimentResult, float]] = []
    configs: dict[str, dict[str, object]] = {}
    with Progress(
        TextColumn("{task.fields[experiment]}", style="bold", markup=False),
        TextColumn("{task.description}", markup=False),
        BarColumn(),
        MofNCompleteColumn(),
        _ExperimentTime(),
        _StageRemaining(),
        console=console,
        transient=False,
    ) as progress:
        for name in names:
            module = load(name)
            config = module.Config()
            task = progress.add_task("starting", total=None, experiment=name, stage_start=None)

            def hook(description: str, completed: int, total: int, _task: TaskID = task) -> None:
                current = progress.tasks[progress.task_ids.index(_task)]
                if current.description != description or current.fields["stage_start"] is None:
                    progress.update(_task, stage_start=(time.monotonic(), completed))
                progress.update(_task, description=description, completed=completed, total=total)

            started = time.perf_counter()
            try:
                result = module.run(
                    config,
                    out / name,
                    progress=hook,
                    command=shlex.join(["bayesmap", "reproduce", name, "--out", str(out)]),
                )
            except BayesmapError as error:
                print_error(error, label=f"error in {name}", out=console)
                raise typer.Exit(1) from error
            results.append((result, time.perf_counter() - started))
            configs[name] = config.model_dump(mode="json")
            progress.update(task, description="done", stage_start=None)
            progress.stop_task(task)
    _print_summary(results)
    from bayesmap.sweeps.report import section_from_run, write_report  # Jinja2 on demand

    sections = [section_from_run(r.name, r, configs[r.name]) for r, _ in results]
    report = write_report(sections, out / "report.html", title="bayesmap reproduce")
    console.print(Text(f"report: {report}"))


class _ExperimentTime(ProgressColumn):
    """Time since the experiment started, until it is stopped.

    An experiment reports several stages (runs, conditions) through one task, each counting
    up to its own total; rich's elapsed-time column freezes at the first stage that
    completes, this one runs until the whole experiment is done.
    """

    def render(self, task: Task) -> Text:
        seconds = int(task.elapsed or 0)
        return Text(f"{seconds // 60}:{seconds % 60:02d}", style="progress.elapsed")


class _StageRemaining(ProgressColumn):
    """Estimated time left in the current stage, from that stage's own pace.

    Stages (runs, conditions) count up to their own totals, so an estimate over the whole
    experiment's history would mix paces; this one restarts with every stage.
    """

    def render(self, task: Task) -> Text:
        start = task.fields.get("stage_start")
        if start is None or not task.total or task.finished:
            return Text("")
        since, first = start
        done = task.completed - first
        if done <= 0:
            return Text("stage ETA –:––", style="progress.remaining")
        seconds = int((time.monotonic() - since) * (task.total - task.completed) / done)
        return Text(f"stage ETA {seconds // 60}:{seconds % 60:02d}", style="progress.remaining")


def _print_summary(
    results: list[tuple[ExperimentResult, float]], out: Console | None = None
) -> None:
    """Where each experiment wrote its figures and metrics, then its headline numbers.

    The table keeps to what fits a narrow terminal (folders, counts, the summary file); the
    headlines follow as wrapped lines, one experiment each.
    """
    out = out or make_console()
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
        out.print(styled((result.name, "bold"), f": {numbers}"))


def _fmt(value: float | int | str) -> str:
    return f"{value:.3g}" if isinstance(value, float) else str(value)
