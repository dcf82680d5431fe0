"""``bayesmap sweep`` and ``bayesmap report``: experiment grids on Dask, and their HTML page."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Annotated

import typer
from rich.text import Text

from bayesmap.cli._console import USAGE, print_error, progress_bar
from bayesmap.cli._console import console as make_console
from bayesmap.errors import BayesmapError, ConfigError

console = make_console(stderr=True)


def _error(message: str, code: int = 1) -> typer.Exit:
    print_error(" ".join(message.split()))
    return typer.Exit(code)


def _quiet_dask() -> None:
    """Keep Dask's narration of its cluster's start and shutdown (INFO, WARNING) off the
    terminal, where the progress bar says enough; its errors still show."""
    import distributed  # noqa: F401  (configures its loggers, whose levels are set below)

    for name in list(logging.root.manager.loggerDict):
        if name == "distributed" or name.startswith("distributed."):
            logging.getLogger(name).setLevel(logging.ERROR)


def _worlds(text: str | None) -> int | Path | None:
    if text is None:
        return None
    return int(text) if text.strip().isdigit() else Path(text)


def sweep(
    experiment: Annotated[str, typer.Argument(help="Experiment to sweep (see reproduce --list).")],
    out: Annotated[Path, typer.Option("--out", help="The sweep's folder (resumed if present).")],
    worlds: Annotated[
        str | None,
        typer.Option(
            "--worlds",
            help="N generated worlds, or a folder of WORLD.json files (default: built-in); "
            "the worlds are written to OUT/worlds/.",
        ),
    ] = None,
    seeds: Annotated[int, typer.Option("--seeds", help="Run seeds per world and condition.")] = 1,
    condition: Annotated[
        list[str] | None,
        typer.Option(
            "--condition",
            help="NAME or NAME:KEY=VALUE, repeatable; each name is one arm of the comparison.",
        ),
    ] = None,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="KEY=VALUE (YAML value) applied to every run; repeatable."),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Dask scheduler address, e.g. tcp://10.0.0.5:8786, or the file of "
            "dask scheduler --scheduler-file.",
        ),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option("--workers", help="Local worker processes (default: one per core)."),
    ] = None,
    serial: Annotated[
        bool, typer.Option("--serial", help="Run every task in this process, without Dask.")
    ] = False,
    root_seed: Annotated[
        int,
        typer.Option("--root-seed", min=0, help="Seed of the worlds and of every run's seed."),
    ] = 0,
) -> None:
    """Run an experiment over worlds × seeds × conditions; write tables and report.html."""
    # Dask, pandas and the report load only when a sweep runs, so `bayesmap --help` is quick.
    from bayesmap.experiments import load
    from bayesmap.sweeps import aggregate, expand, run_sweep
    from bayesmap.sweeps.grid import parse_condition, parse_setting
    from bayesmap.sweeps.report import paired_lines, sections_from_sweep, write_report
    from bayesmap.sweeps.runner import scheduler_problem

    if not serial:
        _quiet_dask()
    try:  # a command line that cannot make a sweep: a usage error, before any run
        module = load(experiment)
        parsed = [parse_setting(item) for item in set_ or []]
        settings = dict(parsed)
        if len(settings) < len(parsed):
            keys = [key for key, _ in parsed]
            repeated = next(key for key in keys if keys.count(key) > 1)
            raise ConfigError(f"--set {repeated} is given more than once; give it once")
        conditions: dict[str, dict[str, object]] = {}
        for item in condition or []:
            name, setting = parse_condition(item)
            conditions.setdefault(name, {})
            if setting is not None:
                conditions[name][setting[0]] = setting[1]
        problem = None if scheduler is None else scheduler_problem(scheduler)
        if problem is not None:
            raise ConfigError(problem)
        if workers is not None and workers < 1:
            raise ConfigError(f"--workers must be at least 1, got {workers}")
        if scheduler is not None and (serial or workers is not None):
            raise ConfigError(
                "--scheduler runs the tasks on that cluster's workers; give it without "
                + ("--serial" if serial else "--workers")
            )
        if serial and workers is not None:
            raise ConfigError("--serial runs every task in this process; give it without --workers")
        plan = expand(
            experiment,
            module,
            worlds=_worlds(worlds),
            seeds=seeds,
            root_seed=root_seed,
            settings=settings,
            conditions=conditions or None,
            out_dir=out,
        )
    except BayesmapError as error:
        raise _error(str(error), USAGE) from error
    try:
        where = (
            "in this process"
            if serial
            else f"on the scheduler at {scheduler}"
            if scheduler
            else "on a local cluster"
        )
        console.print(
            Text(
                f"{experiment}: {len(plan.points)} grid point(s), {len(plan.tasks)} distinct "
                f"run(s), {where}"
            )
        )
        if plan.worlds:
            console.print(
                Text(f"worlds: {len(plan.worlds)} WORLD.json file(s) in {out / 'worlds'}")
            )
        with progress_bar(
            console, first="runs, 0 failed", elapsed=True, remaining=True, transient=False
        ) as hook:
            outcome = run_sweep(
                plan, out, scheduler=scheduler, workers=workers, serial=serial, progress=hook
            )
        finished = bool(outcome.ran or outcome.skipped)
        if finished:
            table = aggregate.tidy(plan, out)
            aggregate.write_tables(table, out)
            sections = sections_from_sweep(out)
            report = write_report(sections, out / "report.html", title=f"{experiment} sweep")
    except BayesmapError as error:
        raise _error(str(error)) from error
    console.print(
        Text(
            f"ran {len(outcome.ran)}, skipped {len(outcome.skipped)} already complete, "
            f"failed {len(outcome.failed)} in {outcome.seconds:.1f} s"
        )
    )
    spent = outcome.account()
    if spent.tasks:
        console.print(
            Text(
                f"{spent.workers} worker process(es) busy {spent.busy:.0%} of the time; the "
                f"runs took {spent.task_wall_s:.1f} s, {spent.task_cpu_s:.1f} s of it on a CPU"
            )
        )
    for key, message in outcome.failed.items():
        console.print(Text.assemble(("failed ", "red"), f"{key}: {message}"))
    if not finished:
        console.print(Text("no run finished: no tables and no report were written"))
        raise typer.Exit(1)
    lines = paired_lines(sections[0])
    if lines:
        console.print(Text("paired comparisons (same worlds and seeds), mean difference:"))
        for line in lines:
            console.print(Text(f"  {line}"))
    console.print(Text(f"tables: {out / 'tidy.parquet'}, summary.parquet, paired.parquet (+ CSV)"))
    console.print(Text(f"report: {report}"))
    if outcome.failed:
        raise typer.Exit(1)


def report(
    sweep_dir: Annotated[Path, typer.Argument(help="A sweep's folder (bayesmap sweep --out).")],
    out: Annotated[Path, typer.Option("--out", help="The HTML file to write.")] = Path(
        "report.html"
    ),
) -> None:
    """Write one self-contained HTML page of a sweep's tables and figures."""
    from bayesmap.sweeps.report import sections_from_sweep, write_report

    if out.suffix.lower() not in (".html", ".htm"):
        raise _error(f"--out {out}: the report is an HTML page; give a path ending in .html", USAGE)
    if sweep_dir.is_file():
        raise _error(
            f"{sweep_dir} is a file; give the sweep's folder (bayesmap sweep --out)", USAGE
        )
    try:
        sections = sections_from_sweep(sweep_dir)
        path = write_report(sections, out, title=f"{sections[0].experiment} sweep")
    except BayesmapError as error:
        raise _error(str(error)) from error
    console.print(Text(f"wrote {path}"))
