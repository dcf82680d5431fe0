"""``bayesmap rover``: run the micro-rover on a world file, or generate stress worlds.

The simulator, the experiments and matplotlib are imported inside the commands, so that
``bayesmap --help`` and the other command groups start without them.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path
from typing import Annotated, Literal

import typer

from bayesmap.cli._console import console, headline_text, print_error, progress_bar
from bayesmap.errors import BayesmapError

app = typer.Typer(
    help="The micro-rover (Post et al. 2016): run it on a world file, generate worlds.",
    no_args_is_help=True,
)
_console = console(stderr=True)
LengthUnit = Literal["mm", "cm", "m"]
AngleUnit = Literal["rad", "deg", "decideg"]


def _fail(error: BayesmapError) -> typer.Exit:
    print_error(error, out=_console)
    return typer.Exit(1)


@app.command("run")
def run_command(
    world: Annotated[Path, typer.Option("--world", help="WORLD.json (see docs/rover.md).")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    explorer: Annotated[
        Literal["paper", "frontier"], typer.Option("--explorer", help="Target rule.")
    ] = "paper",
    entropy_init: Annotated[
        Literal["flat", "random"],
        typer.Option("--entropy-init", help="Entropy map starts at 1, or 1 - 0.1 U(0, 1)."),
    ] = "flat",
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of every random stream.")] = 0,
    max_steps: Annotated[
        int | None,
        typer.Option(
            "--max-steps",
            min=1,
            help="Cycle budget (default: 12 sweeps of the observable area, docs/rover.md).",
        ),
    ] = None,
) -> None:
    """Drive the rover on WORLD until the stop rule or the budget; write metrics, figures, map."""
    from bayesmap.experiments import rover_world  # the simulator and matplotlib load here

    config = rover_world.Config(
        world=world, explorer=explorer, entropy_init=entropy_init, seed=seed, max_steps=max_steps
    )
    try:
        with progress_bar(_console, first="loading") as hook:
            result = rover_world.run(config, out, progress=hook)
    except BayesmapError as error:
        raise _fail(error) from None
    typer.echo(f"{headline_text(result.headline)}; wrote {out}")


@app.command("generate")
def generate_command(
    out: Annotated[Path, typer.Option("--out", help="Folder for the world files.")],
    count: Annotated[int, typer.Option("--count", min=1, help="How many worlds.")] = 12,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the generator.")] = 0,
    size: Annotated[
        float | None,
        typer.Option("--size", help="Side of the area [m], 5–200 (default: drawn in 20–60)."),
    ] = None,
) -> None:
    """Write COUNT generated stress worlds (walls, L-shapes, corridors, passages, boxes, tilted)."""
    from numpy.random import SeedSequence

    from bayesmap._io import run_folder
    from bayesmap.sim.rover_worlds import generate_world, save_world

    digits = max(2, len(str(count - 1)))
    settings = {"count": count, "seed": seed, "size_m": size}
    command = shlex.join(["bayesmap", *sys.argv[1:]])
    try:  # the folder appears whole, with its manifest, replacing an earlier generation
        with run_folder(out, command=command, configuration=settings, seed=seed) as folder:
            for k in range(count):
                spec = generate_world(
                    SeedSequence([seed, k]),
                    size=size,
                    name=f"rover-generated-v2-s{seed}-{k:0{digits}d}",
                )
                path = save_world(folder.path / f"world_{k:0{digits}d}.json", spec)
                typer.echo(
                    f"{folder.final(path)}: {spec.world.width:.1f} m, "
                    f"{spec.world.n_obstacles} obstacles"
                )
    except BayesmapError as error:
        raise _fail(error) from None


@app.command("map")
def map_command(
    log: Annotated[Path, typer.Argument(help="CSV drive log: columns x, y, heading, ir_0, ...")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    calibration: Annotated[
        Path | None,
        typer.Option(
            "--calibration",
            help="IR fit as JSON {a, b, c}, or CSV of (raw, distance) pairs to fit "
            "(default: the paper's §5.1 fit).",
        ),
    ] = None,
    distance_unit: Annotated[
        LengthUnit, typer.Option("--distance-unit", help="Unit of calibration distances.")
    ] = "m",
    position_unit: Annotated[LengthUnit, typer.Option("--position-unit")] = "m",
    heading_unit: Annotated[AngleUnit, typer.Option("--heading-unit")] = "rad",
    resolution: Annotated[float, typer.Option("--resolution", help="Cell side [m].")] = 0.5,
    strict: Annotated[bool, typer.Option("--strict", help="Abort at the first bad row.")] = False,
) -> None:
    """Replay a logged drive through the rover's sensing and mapping; write the maps."""
    from bayesmap.experiments import rover_log

    try:
        with progress_bar(_console, first=f"reading {log.name}", percent=True) as hook:
            summary = rover_log.map_log(
                log,
                out,
                calibration=calibration,
                distance_unit=distance_unit,
                position_unit=position_unit,
                heading_unit=heading_unit,
                resolution=resolution,
                strict=strict,
                progress=hook,
                command=shlex.join(["bayesmap", *sys.argv[1:]]),
            )
    except BayesmapError as error:
        raise _fail(error) from None
    typer.echo(
        f"{summary['rows']} rows ({summary['rows_skipped']} skipped), coverage "
        f"{summary['coverage']:.3f}; wrote {out}"
    )


@app.command("schema")
def schema_command() -> None:
    """Print the JSON Schema of WORLD.json files."""
    from bayesmap.sim.rover_worlds import WORLD_SCHEMA

    typer.echo(json.dumps(WORLD_SCHEMA, indent=2))
