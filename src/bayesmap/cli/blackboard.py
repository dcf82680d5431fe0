"""``bayesmap blackboard``: map the tables of a room from a world file (fused or per pose) or
from a logged whisker tour."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated, Literal

import typer

from bayesmap.cli._console import console as make_console
from bayesmap.cli._console import headline_text, print_error, print_note, progress_bar
from bayesmap.errors import BayesmapError

app = typer.Typer(
    help="Map four-legged tables with a whiskered robot (Fox & Prescott 2011 and past it).",
    no_args_is_help=True,
)
console = make_console(stderr=True)

Condition = Literal["normal", "noiseless", "noisy"]
Mode = Literal["fused", "paper"]


@app.command("run")
def run_command(
    world: Annotated[
        Path, typer.Option("--world", help="World file (JSON, see docs/blackboard.md).")
    ],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    condition: Annotated[Condition, typer.Option("--condition", help="Sensor noise.")] = "normal",
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of noise and chain.")] = 0,
    mode: Annotated[
        Mode, typer.Option("--mode", help="fused map or the paper's per-pose maps.")
    ] = "fused",
) -> None:
    """Drive the robot through WORLD's poses; write metrics.json, map.json and map.png."""
    from bayesmap.experiments import blackboard_world  # the mapper loads only when it runs

    config = blackboard_world.Config(world=world, condition=condition, seed=seed, mode=mode)
    try:
        with progress_bar(console, first=f"{mode} {condition}", elapsed=True) as hook:
            result = blackboard_world.run(config, out, progress=hook)
    except BayesmapError as error:
        print_error(" ".join(str(error).split()), out=console)
        raise typer.Exit(1) from error
    numbers = headline_text({k: v for k, v in result.headline.items() if k != "note"})
    print_note(f"wrote {out}/metrics.json, map.json, map.png: {numbers}", out=console)
    if "note" in result.headline:
        print_note(f"note: {result.headline['note']}", out=console)


@app.command("map")
def map_command(
    log: Annotated[
        Path,
        typer.Argument(
            help="Sweep log (CSV or .parquet): pose, x, y, heading, start, stop, length, "
            "range, normal [, texture]; see docs/blackboard.md."
        ),
    ],
    world: Annotated[
        Path,
        typer.Option(
            "--world",
            help="Room file (JSON): the arena and the catalogue of table types; tables it "
            "lists are the truth the map is scored against.",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    sigma_range: Annotated[
        float, typer.Option("--sigma-range", min=0.0, help="Contact range noise [m].")
    ] = 0.02,
    sigma_normal: Annotated[
        float, typer.Option("--sigma-normal", min=0.0, help="Contact normal noise [rad].")
    ] = 0.05,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the sampler.")] = 0,
    length_unit: Annotated[
        Literal["m", "cm", "mm"], typer.Option("--length-unit", help="Unit of x, y, length, range.")
    ] = "m",
    angle_unit: Annotated[
        Literal["rad", "deg"],
        typer.Option("--angle-unit", help="Unit of heading, start, stop, normal."),
    ] = "rad",
) -> None:
    """Map the tables of a logged whisker tour; write metrics.json, map.json and map.png."""
    from bayesmap.experiments import blackboard_log  # the mapper loads only when it runs

    try:
        with progress_bar(console, first=f"mapping {log.name}", elapsed=True) as hook:
            metrics = blackboard_log.map_log(
                log,
                world,
                out,
                sigma_range=sigma_range,
                sigma_normal=sigma_normal,
                seed=seed,
                length_unit=length_unit,
                angle_unit=angle_unit,
                progress=hook,
                command=shlex.join(["bayesmap", *sys.argv[1:]]),
            )
    except BayesmapError as error:
        print_error(" ".join(str(error).split()), out=console)
        raise typer.Exit(1) from error
    for hint in metrics["warnings"]:
        print_note(f"warning: {hint}", out=console)
    scores: dict[str, object] = {
        k: metrics[k] for k in ("fused_precision", "fused_recall") if k in metrics
    }
    numbers = f": {headline_text(scores)}" if scores else ""
    left_off = (
        f" ({metrics['doubtful']} more left off as doubtful, dashed in map.png)"
        if metrics["doubtful"]
        else ""
    )
    print_note(
        f"{metrics['poses']} poses, {metrics['contacts']} contacts, {metrics['objects']} "
        f"objects mapped{left_off}; wrote {out}/metrics.json, map.json, map.png{numbers}",
        out=console,
    )


@app.command("world")
def world_command(
    out: Annotated[Path, typer.Argument(help="World file to write (JSON).")],
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the layout.")] = 0,
    stress: Annotated[
        bool, typer.Option("--stress/--plain", help="Tables by walls and in close pairs.")
    ] = True,
) -> None:
    """Generate a world: 4–10 tables of mixed sizes at any angle in a 4–10 m arena."""
    from bayesmap.sim.whisker_worlds import StressOptions, generate_world, save_world

    if out.suffix.lower() != ".json":  # a world file is JSON: never write one over a log
        raise typer.BadParameter(f"a world file ends in .json, got {str(out)!r}", param_hint="OUT")
    options = StressOptions() if stress else StressOptions(near_wall=0.0, close_pairs=0.0)
    save_world(generate_world(seed, options), out)
    print_note(f"wrote {out}", out=console)
