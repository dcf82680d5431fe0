"""``bayesmap sonar``: build maps from real sonar-ring logs."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

import typer

from bayesmap.errors import InputError

app = typer.Typer(
    help="Build occupancy maps from sonar-ring logs, with specular-reading rejection.",
    no_args_is_help=True,
)

LengthUnit = Literal["mm", "cm", "m"]
AngleUnit = Literal["rad", "deg", "decideg"]


def _angles(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(part) for part in text.replace(" ", "").split(",") if part)
    except ValueError:
        raise InputError(f"--angles-deg must be comma-separated numbers, got {text!r}") from None
    if len(values) < 2 or not all(math.isfinite(v) for v in values):
        raise InputError(f"--angles-deg needs at least two finite angles, got {text!r}")
    return tuple(math.radians(v) for v in values)


@app.command("map")
def map_command(
    log: Annotated[
        Path, typer.Argument(help="Log: rows 't x y heading r1..rN' (or 't r1..rN' with --poses).")
    ],
    angles_deg: Annotated[
        str,
        typer.Option(
            "--angles-deg",
            help="Transducer bearings from the heading, in ring order, comma-separated (deg).",
        ),
    ],
    max_range: Annotated[
        float,
        typer.Option(
            "--max-range",
            help="Max range, in --range-unit; a reading at or above it means no echo.",
        ),
    ],
    resolution: Annotated[float, typer.Option("--resolution", help="Map cell side (m).")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    poses: Annotated[
        Path | None, typer.Option("--poses", help="Pose file 't x y heading', joined by timestamp.")
    ] = None,
    range_unit: Annotated[LengthUnit, typer.Option("--range-unit")] = "m",
    position_unit: Annotated[LengthUnit, typer.Option("--position-unit")] = "m",
    heading_unit: Annotated[AngleUnit, typer.Option("--heading-unit")] = "rad",
    beam_width_deg: Annotated[
        float, typer.Option("--beam-width-deg", help="Full cone width (deg).")
    ] = 25.0,
    sigma: Annotated[
        float, typer.Option("--sigma", help="Range noise standard deviation (m).")
    ] = 0.02,
    no_filter: Annotated[
        bool, typer.Option("--no-filter", help="Map every reading (no rejection).")
    ] = False,
    strict: Annotated[bool, typer.Option("--strict", help="Abort at the first bad row.")] = False,
) -> None:
    """Build map.png, map.yaml + map.pgm (ROS map_server) and summary.json from a sonar log."""
    # imported here, so that other commands start without loading matplotlib and the mapper
    from bayesmap._io import write_bytes, write_json
    from bayesmap.grid.ros import write_ros_map
    from bayesmap.sonar.filter import Stage
    from bayesmap.sonar.geometry import SonarGeometry
    from bayesmap.sonar.logs import LENGTH_UNITS, LogUnits, read_sonar_log
    from bayesmap.sonar.pipeline import build_map
    from bayesmap.viz.sonar import map_png

    angles = _angles(angles_deg)
    units = LogUnits(range_unit=range_unit, position_unit=position_unit, heading_unit=heading_unit)
    if not (math.isfinite(max_range) and max_range > 0):
        raise InputError(f"--max-range must be a positive number, got {max_range}")
    geometry = SonarGeometry(
        angles=angles,
        beam_width=math.radians(beam_width_deg),
        max_range=max_range * LENGTH_UNITS[range_unit],
        sigma=sigma,
    )
    data = read_sonar_log(log, len(angles), poses_path=poses, units=units, strict=strict)
    built = build_map(data.poses, data.ranges, geometry, resolution, use_filter=not no_filter)
    grid = built.mapper.grid
    probability = built.mapper.probability()
    observed = built.mapper.observed()
    yaml_path, pgm_path = write_ros_map(
        out / "map", probability, grid.resolution, grid.origin, unknown_mask=~observed
    )
    write_bytes(
        out / "map.png",
        map_png(
            probability * observed + 0.5 * ~observed,
            grid.extent,
            path=data.poses[:, :2],
            title=log.name,
        ),
    )
    stage = built.run.stage
    rejected = {s.name.lower(): int((stage == s).sum()) for s in Stage if s != Stage.ACCEPTED}
    summary = {
        "log": str(log),
        "poses": None if poses is None else str(poses),
        "rows": data.rows,
        "rows_skipped": len(data.skipped),
        "readings": int(data.ranges.size),
        "rejected": rejected,
        "filter": not no_filter,
        "skipped": [
            {"file": row.path, "line": row.line, "reason": row.reason} for row in data.skipped
        ],
        "map": {
            "yaml": yaml_path.name,
            "pgm": pgm_path.name,
            "resolution": grid.resolution,
            "origin": list(grid.origin),
            "shape": list(grid.shape),
        },
    }
    write_json(out / "summary.json", summary)
    typer.echo(
        f"{data.rows} rows ({len(data.skipped)} skipped), {data.ranges.size} readings, "
        f"rejected {sum(rejected.values())} "
        f"({', '.join(f'{k} {v}' for k, v in rejected.items())}); "
        f"wrote {out / 'map.png'}, {yaml_path}, {pgm_path}, {out / 'summary.json'}"
    )
