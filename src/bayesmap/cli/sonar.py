"""``bayesmap sonar``: build maps from real sonar-ring logs.

Every user mistake ends in one plain line on stderr (``error: ...``), exit code 1, or 2 for
options that do not go together; messages are printed literally (no markup), so ``[m]`` in a
message stays ``[m]``.
"""

from __future__ import annotations

import math
import shlex
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Literal, NoReturn

import numpy as np
import typer

from bayesmap._io import RunFolder, run_folder, write_bytes, write_json
from bayesmap.cli._console import USAGE, console, headline_text, print_note, progress_bar
from bayesmap.errors import BayesmapError, InputError
from bayesmap.limits import cell_side_problem
from bayesmap.sonar.bags import bag_kind
from bayesmap.sonar.carmen import Clock, is_carmen_log, read_carmen_log
from bayesmap.sonar.filter import Stage
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.logs import LENGTH_UNITS, LogUnits, RingLog, SonarLog, read_sonar_log
from bayesmap.sonar.pipeline import (
    DEFAULT_CELL_SIDE,
    DEFAULT_PIPELINE,
    PIPELINES,
    BuiltMap,
    build_map,
)
from bayesmap.sonar.player import is_player_log, read_player_log
from bayesmap.sonar.ring import PRESETS, load_ring, preset_with_bearings, reach_problem

app = typer.Typer(
    help="Build occupancy maps from sonar-ring logs, with specular-reading rejection.",
    no_args_is_help=True,
)

LengthUnit = Literal["mm", "cm", "m"]
AngleUnit = Literal["rad", "deg", "decideg"]
TimeUnit = Literal["s", "ms", "us", "ns"]
LogFormat = Literal["auto", "text", "player", "carmen"]
LogKind = Literal["text", "player", "carmen", "bag"]
_LOGGED_RING = {"player": "Player", "carmen": "CARMEN"}
"""The log formats that describe their own ring, by the name of the tool that writes them."""
_err = console(stderr=True)


def _say(message: str) -> None:
    """Print ``message`` to stderr exactly as written."""
    print_note(message, out=_err)


def _usage(message: str) -> NoReturn:
    """End a command line whose options do not go together: one line, exit code 2."""
    _say(f"error: {message}")
    raise typer.Exit(USAGE)


@contextmanager
def _user_errors() -> Iterator[None]:
    try:
        yield
    except BayesmapError as error:
        _say(f"error: {error}")
        raise typer.Exit(1) from None


def _angles(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(part) for part in text.replace(" ", "").split(","))
    except ValueError:
        _usage(f"--angles-deg must be comma-separated numbers, one per transducer, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        _usage(f"--angles-deg angles must be finite, got {text!r}")
    if len(values) < 2:
        _usage(f"--angles-deg needs at least two angles, got {text!r}")
    return tuple(math.radians(v) for v in values)


def _geometry(
    ring: str | None,
    angles_deg: str | None,
    max_range: float | None,
    beam_width_deg: float | None,
    sigma: float | None,
    range_unit: str,
    logged: SonarGeometry | None = None,
) -> SonarGeometry:
    """The ring from ``--ring`` or ``--angles-deg`` (else the ring a Player or CARMEN log
    describes, ``logged``), with the command line's overrides."""
    if ring is not None and angles_deg is not None:
        _usage("give the ring either as --ring or as --angles-deg, not both")
    _check_overrides(max_range, beam_width_deg, sigma)
    metres = LENGTH_UNITS[range_unit]
    if max_range is not None and (problem := reach_problem(max_range * metres)) is not None:
        raise InputError(
            f"--max-range {max_range:g} in --range-unit {range_unit} is "
            f"{max_range * metres:g} m, {problem}; is --range-unit right?"
        )
    if ring is not None:
        geometry = load_ring(ring)
    elif angles_deg is not None:
        if max_range is None:
            raise InputError("--max-range is needed with --angles-deg (in --range-unit)")
        angles = _angles(angles_deg)
        known = preset_with_bearings(angles)
        if known is not None:
            _say(
                f"warning: these are the bearings of the {known} ring, but --angles-deg puts "
                "every transducer at the robot's centre; on a Pioneer they sit 0.15-0.26 m out, "
                f"and --ring {known} places them so (the maps need it)"
            )
        geometry = SonarGeometry(angles=angles, max_range=max_range * metres)
    elif logged is not None:
        geometry = logged
    else:
        raise InputError(
            "give the ring either as --ring (a YAML ring file or one of: "
            f"{', '.join(PRESETS)}) or as --angles-deg"
        )
    if max_range is not None:
        geometry = replace(
            geometry,
            max_range=max_range * metres,
            min_range=min(geometry.min_range, 0.5 * max_range * metres),
        )
    if sigma is not None:
        geometry = replace(geometry, sigma=sigma * metres)
    if beam_width_deg is not None:
        geometry = replace(geometry, beam_width=math.radians(beam_width_deg))
    return geometry


def _check_overrides(
    max_range: float | None, beam_width_deg: float | None, sigma: float | None
) -> None:
    for name, value in (
        ("--max-range", max_range),
        ("--sigma", sigma),
        ("--beam-width-deg", beam_width_deg),
    ):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a positive number, got {value}")
    if beam_width_deg is not None and not beam_width_deg < 180.0:
        raise InputError(
            f"--beam-width-deg must be below 180 (a half turn), got {beam_width_deg:g}"
        )


def _check_ranges(data: SonarLog, geometry: SonarGeometry, range_unit: str, log: Path) -> None:
    """Warn when the ranges and the max range look like different units, and when readings
    measured nothing (:func:`~bayesmap.sonar.pipeline.map_log` leaves them unmapped)."""
    unmeasured = int(geometry.measured_nothing(data.ranges).sum())
    if unmeasured:
        _say(
            f"warning: {log}: {unmeasured} of {data.ranges.size} readings "
            f"({100 * unmeasured / data.ranges.size:.1f} %) are 0, negative or below the "
            f"ring's min range ({geometry.min_range:g} m): they measured nothing and are "
            "not mapped"
        )
    echo = geometry.echo(data.ranges)
    if echo.mean() < 0.05:
        _say(
            f"warning: {100 * (1 - echo.mean()):.0f} % of readings are at or above the max range "
            f"({geometry.max_range:g} m): is --max-range in --range-unit ({range_unit})?"
        )
    elif np.median(data.ranges[echo]) < 0.02 * geometry.max_range:
        _say(
            f"warning: the median echo is {np.median(data.ranges[echo]):.3g} m against a max "
            f"range of {geometry.max_range:g} m: is --range-unit ({range_unit}) right?"
        )


@app.command("map")
def map_command(
    log: Annotated[
        Path,
        typer.Argument(
            help="Log: rows 't x y heading r1..rN' (or 't r1..rN' with --poses), a Player "
            "log, or a ROS bag (with --topics)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", help="Output folder (created if missing).")],
    resolution: Annotated[
        float, typer.Option("--resolution", help="Map cell side (m).")
    ] = DEFAULT_CELL_SIDE,
    ring: Annotated[
        str | None,
        typer.Option(
            "--ring",
            help="Ring file (YAML: each transducer's x, y, heading...) or preset: "
            f"{', '.join(PRESETS)}. Default for a Player or CARMEN log: the ring it describes.",
        ),
    ] = None,
    angles_deg: Annotated[
        str | None,
        typer.Option(
            "--angles-deg",
            help="Instead of --ring: transducer bearings (deg), in ring order, all at the centre.",
        ),
    ] = None,
    max_range: Annotated[
        float | None,
        typer.Option(
            "--max-range",
            help="Max range in --range-unit; a reading at or above it means no echo "
            "(default: the ring file's; for a ring from a Player or CARMEN log, the presets' "
            "5 m).",
        ),
    ] = None,
    poses: Annotated[
        Path | None, typer.Option("--poses", help="Pose file 't x y heading', joined by timestamp.")
    ] = None,
    range_unit: Annotated[LengthUnit, typer.Option("--range-unit")] = "m",
    position_unit: Annotated[LengthUnit, typer.Option("--position-unit")] = "m",
    heading_unit: Annotated[AngleUnit, typer.Option("--heading-unit")] = "rad",
    time_unit: Annotated[
        TimeUnit, typer.Option("--time-unit", help="Unit of the timestamps (text logs).")
    ] = "s",
    beam_width_deg: Annotated[
        float | None, typer.Option("--beam-width-deg", help="Full cone width (deg).")
    ] = None,
    sigma: Annotated[
        float | None,
        typer.Option("--sigma", help="Range noise standard deviation, in --range-unit."),
    ] = None,
    pipeline: Annotated[
        str,
        typer.Option(
            "--pipeline",
            help=f"One of: {', '.join(PIPELINES)}. 'default': the filter and a one-pass map, "
            "then one forward-model sweep over the whole log; 'streaming': the one-pass map "
            "alone (less CPU); the rest: single filter stages and unfiltered baselines.",
        ),
    ] = DEFAULT_PIPELINE,
    no_filter: Annotated[
        bool,
        typer.Option("--no-filter", help="Map every reading (the pipeline without its filter)."),
    ] = False,
    strict: Annotated[bool, typer.Option("--strict", help="Abort at the first bad row.")] = False,
    pose_tolerance: Annotated[
        float, typer.Option("--pose-tolerance", min=0.0, help="Nearest-pose tolerance (s).")
    ] = 0.05,
    max_pose_gap: Annotated[
        float,
        typer.Option(
            "--max-pose-gap", min=0.0, help="Interpolate poses across gaps up to this (s)."
        ),
    ] = 1.0,
    max_cells: Annotated[
        int, typer.Option("--max-cells", min=1, help="Refuse maps with more cells than this.")
    ] = 25_000_000,
    topics: Annotated[
        str | None,
        typer.Option(
            "--topics",
            help="LOG is a ROS bag (ROS 1, ROS 2 or MCAP): its sensor_msgs/Range topics, one "
            "per transducer in ring order, comma-separated; or the one topic the ring shares "
            "(see --frames); or one PointCloud/PointCloud2 topic, a ring per message (RosAria).",
        ),
    ] = None,
    frames: Annotated[
        str | None,
        typer.Option(
            "--frames",
            help="Bag whose transducers share Range topics: their header frame_ids, in ring "
            "order, comma-separated (--topics then names the shared topic or topics).",
        ),
    ] = None,
    pose_topic: Annotated[
        str, typer.Option("--pose-topic", help="Bag: nav_msgs/Odometry topic, or /tf.")
    ] = "/odom",
    tf_frames: Annotated[
        str, typer.Option("--tf-frames", help="Bag with --pose-topic /tf: 'parent,child'.")
    ] = "odom,base_link",
    log_format: Annotated[
        LogFormat,
        typer.Option(
            "--format",
            help="LOG's format: 'text' rows, a 'player' log (Player/Stage writelog), a 'carmen' "
            "log (CARMEN's logger; both in metres and radians), or 'auto': player when LOG "
            "opens with '## Player version', carmen when with '# CARMEN Logfile' or a CARMEN "
            "message, else text.",
        ),
    ] = "auto",
    sonar_index: Annotated[
        int | None,
        typer.Option("--sonar-index", min=0, help="Player log: the sonar device's index [0]."),
    ] = None,
    position_index: Annotated[
        int | None,
        typer.Option(
            "--position-index", min=0, help="Player log: the odometry's position2d index [0]."
        ),
    ] = None,
    clock: Annotated[
        Clock | None,
        typer.Option(
            "--clock",
            help="CARMEN log: which stamp times a message, 'ipc' (when it was sent) or "
            "'logger' (seconds since logging began) [ipc].",
        ),
    ] = None,
) -> None:
    """Build map.png, map.yaml + map.pgm (ROS map_server) and summary.json from a sonar log."""
    with _user_errors():
        if frames is not None and topics is None:
            _usage("--frames is for ROS bags: give --topics, the Range topic(s) the frames share")
        for option, seconds in (
            ("--pose-tolerance", pose_tolerance),
            ("--max-pose-gap", max_pose_gap),
        ):
            if not math.isfinite(seconds):
                _usage(f"{option} must be a number of seconds, got {seconds}")
        kind = _log_kind(
            log,
            log_format,
            topics,
            poses,
            {"--sonar-index": sonar_index, "--position-index": position_index, "--clock": clock},
            (range_unit, position_unit, heading_unit, time_unit),
        )
        if pipeline not in PIPELINES:
            _usage(f"--pipeline {pipeline!r} is not one of: {', '.join(PIPELINES)}")
        if out.exists() and not out.is_dir():
            raise InputError(f"--out {out} is a file; name a folder (it is created if missing)")
        problem = cell_side_problem(resolution)
        if problem is not None:
            raise InputError(f"--resolution {problem}")
        geometry: SonarGeometry | None = None
        if kind in _LOGGED_RING and ring is None and angles_deg is None:
            _check_overrides(max_range, beam_width_deg, sigma)  # the ring comes with the log
        else:
            geometry = _geometry(ring, angles_deg, max_range, beam_width_deg, sigma, range_unit)
        units = LogUnits(
            range_unit=range_unit,
            position_unit=position_unit,
            heading_unit=heading_unit,
            time_unit=time_unit,
        )
        chosen = PIPELINES[pipeline]
        if no_filter:
            chosen = replace(
                chosen, acceptability=False, agreeability=False, trait_verification=False
            )
        with progress_bar(_err, first=f"reading {log.name}", percent=True) as hook:
            if kind in _LOGGED_RING:
                join = {"time_tolerance": pose_tolerance, "max_pose_gap": max_pose_gap}
                logged = (
                    read_player_log(
                        log,
                        sonar_index=sonar_index or 0,
                        position_index=position_index or 0,
                        strict=strict,
                        progress=hook,
                        **join,
                    )
                    if kind == "player"
                    else read_carmen_log(
                        log, clock=clock or "ipc", strict=strict, progress=hook, **join
                    )
                )
                data = logged.log
                geometry = _logged_ring(
                    _LOGGED_RING[kind], logged, geometry, max_range, beam_width_deg, sigma
                )
            elif topics is not None:
                assert geometry is not None  # given: a bag does not describe its ring
                data = _read_bag(
                    log,
                    topics,
                    frames,
                    pose_topic,
                    tf_frames,
                    geometry,
                    strict,
                    pose_tolerance,
                    max_pose_gap,
                )
            else:
                assert geometry is not None  # given: a text log does not describe its ring
                data = read_sonar_log(
                    log,
                    geometry.n,
                    poses_path=poses,
                    units=units,
                    strict=strict,
                    time_tolerance=pose_tolerance,
                    max_pose_gap=max_pose_gap,
                    progress=hook,
                )
            _check_ranges(data, geometry, range_unit, log)
            built = build_map(
                data.poses,
                data.ranges,
                geometry,
                resolution,
                pipeline=chosen,
                max_cells=max_cells,
                progress=hook,
            )
        settings = {
            "log": str(log),
            "format": kind,
            "poses": None if poses is None else str(poses),
            "pipeline": pipeline,
            "no_filter": no_filter,
            "resolution_m": resolution,
            "range_unit": range_unit,
            "ring": None if ring is None else str(ring),
        }
        command = shlex.join(["bayesmap", *sys.argv[1:]])
        with run_folder(out, command=command, configuration=settings, seed=None) as folder:
            _write_outputs(folder, log, poses, data, built, pipeline, no_filter)


@app.command("run")
def run_command(
    world: Annotated[
        Path, typer.Option("--world", help="WORLD.json (see docs/sonar.md, random buildings).")
    ],
    out: Annotated[Path, typer.Option("--out", help="Output folder (replaced when done).")],
    runs: Annotated[int, typer.Option("--runs", min=1, help="Seeded runs (logs).")] = 3,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of every random stream.")] = 2007,
    pipeline: Annotated[
        list[str] | None,
        typer.Option(
            "--pipeline",
            help=f"Pipelines to compare (repeatable; default all): {', '.join(PIPELINES)}.",
        ),
    ] = None,
    jobs: Annotated[int, typer.Option("--jobs", min=1, help="Worker processes.")] = 1,
) -> None:
    """Simulate sonar logs in WORLD and score every pipeline and baseline: tables and maps."""
    from bayesmap.experiments import sonar as experiment  # the simulator and matplotlib

    with _user_errors():
        names = tuple(pipeline) if pipeline else tuple(PIPELINES)
        unknown = [name for name in names if name not in PIPELINES]
        if unknown:
            _usage(f"unknown pipeline {unknown[0]!r}; choose from {', '.join(PIPELINES)}")
        config = experiment.Config.model_validate(
            {"world": world, "runs": runs, "seed": seed, "pipelines": names, "jobs": jobs}
        )
        with progress_bar(_err, first="loading") as hook:
            result = experiment.run(
                config, out, progress=hook, command=shlex.join(["bayesmap", *sys.argv[1:]])
            )
    typer.echo(f"{headline_text(result.headline)}; wrote {out}")


def _log_kind(
    log: Path,
    log_format: LogFormat,
    topics: str | None,
    poses: Path | None,
    options: dict[str, object],
    units: tuple[str, str, str, str],
) -> LogKind:
    """How to read LOG: a bag (``--topics``), a Player or CARMEN log, or text rows
    (``--format``, or how LOG opens: ``## Player version``, ``# CARMEN Logfile`` or a CARMEN
    message). ``options`` are the format-specific options given (``None`` if not). Options
    that do not go with the format are a usage error (exit 2)."""
    kind: LogKind
    if topics is not None:
        if log_format != "auto":
            _usage(f"--format {log_format} is for log files; with --topics LOG is a ROS bag")
        if poses is not None:
            _usage("--poses is for text logs; a bag's poses come from --pose-topic")
        kind = "bag"
    elif (bag := bag_kind(log)) is not None:
        _usage(f"{log} is {bag}: give --topics, one sensor_msgs/Range topic per transducer")
    elif log_format == "auto":
        kind = "player" if is_player_log(log) else "carmen" if is_carmen_log(log) else "text"
    else:
        kind = log_format
    if kind in _LOGGED_RING:
        tool = _LOGGED_RING[kind]
        if poses is not None:
            _usage(f"--poses is for text logs; a {tool} log holds its own odometry")
        if units != ("m", "m", "rad", "s"):
            _usage(
                f"a {tool} log is in metres, radians and seconds: drop --range-unit, "
                "--position-unit, --heading-unit and --time-unit"
            )
    owners = {"--sonar-index": "player", "--position-index": "player", "--clock": "carmen"}
    for name, value in options.items():
        if value is not None and owners[name] != kind:
            _usage(
                f"{name} is for {_LOGGED_RING[owners[name]]} logs; LOG is read as {kind} "
                "(see --format)"
            )
    return kind


def _logged_ring(
    tool: str,
    logged: RingLog,
    given: SonarGeometry | None,
    max_range: float | None,
    beam_width_deg: float | None,
    sigma: float | None,
) -> SonarGeometry:
    """The ring of a Player or CARMEN (``tool``) log's rings: the one given, else the one the
    log describes."""
    geometry = given
    if geometry is None:
        if logged.ring is None:
            raise InputError(
                f"the {tool} log has no usable sonar geometry: give the ring as --ring or "
                "--angles-deg"
            )
        geometry = _geometry(None, None, max_range, beam_width_deg, sigma, "m", logged.ring)
        _say(
            f"ring: the log's sonar geometry, {geometry.n} transducers, "
            f"{math.degrees(geometry.beam_width):.3g} deg beams, max range "
            f"{geometry.max_range:g} m"
        )
    n = logged.log.ranges.shape[1]
    if n != geometry.n:
        raise InputError(f"the log's rings hold {n} ranges, the ring has {geometry.n} transducers")
    return geometry


def _read_bag(
    log: Path,
    topics: str,
    frames: str | None,
    pose_topic: str,
    tf_frames: str,
    geometry: SonarGeometry,
    strict: bool,
    pose_tolerance: float,
    max_pose_gap: float,
) -> SonarLog:
    names = _listed("--topics", topics)
    ring_frames = None if frames is None else _listed("--frames", frames)
    transducers = names if ring_frames is None else ring_frames
    option = "--topics" if ring_frames is None else "--frames"
    if len(transducers) != geometry.n and not (ring_frames is None and len(names) == 1):
        _usage(f"{option} names {len(transducers)} transducers for a ring of {geometry.n}")
    tf_pair = tuple(f.strip() for f in tf_frames.split(","))
    if len(tf_pair) != 2 or not all(tf_pair):
        _usage(f"--tf-frames needs 'parent,child', got {tf_frames!r}")
    from bayesmap.sonar.bags import read_sonar_bag  # rosbags loads only for bags

    return read_sonar_bag(
        log,
        names,
        pose_topic=pose_topic,
        tf_frames=(tf_pair[0], tf_pair[1]),
        strict=strict,
        time_tolerance=pose_tolerance,
        max_pose_gap=max_pose_gap,
        frames=ring_frames,
        positions=geometry.sensors(np.zeros(3))[0],  # for a ring sent as one point cloud
    )


def _listed(option: str, text: str) -> list[str]:
    """The comma-separated names of ``option``; a name given twice is a usage error."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        _usage(f"{option} names {repeated[0]} twice; each transducer has its own")
    return names


def _write_outputs(
    folder: RunFolder,
    log: Path,
    poses: Path | None,
    data: SonarLog,
    built: BuiltMap,
    pipeline: str,
    no_filter: bool,
) -> None:
    from bayesmap.grid.ros import write_ros_map  # the map writers load only when used
    from bayesmap.viz.sonar import map_png

    out = folder.path
    grid = built.mapper.grid
    probability = built.mapper.probability()
    observed = built.mapper.observed()
    unmeasured = int((built.run.stage == Stage.TOO_CLOSE).sum())
    if not observed.any():
        _say("warning: no reading changed the map: every cell is unknown")
    elif not (probability[observed] > 0.5).any():
        _say(
            "warning: the map has no occupied cell (all free or unknown): check --max-range "
            "and --range-unit"
        )
    yaml_path, pgm_path = write_ros_map(
        out / "map", probability, grid.resolution, grid.origin, unknown_mask=~observed
    )
    write_bytes(
        out / "map.png",
        map_png(
            np.where(observed, probability, 0.5),
            grid.extent,
            path=data.poses[:, :2],
            title=f"{log.name} ({pipeline}{', no filter' if no_filter else ''})",
        ),
    )
    stage = built.run.stage
    rejected = {
        s.name.lower(): int((stage == s).sum())
        for s in Stage
        if s not in (Stage.ACCEPTED, Stage.TOO_CLOSE)
    }
    dropped = sum(row.path == str(log) for row in data.skipped)
    summary = {
        "log": str(log),
        "poses": None if poses is None else str(poses),
        "pipeline": pipeline,
        "filter": built.filt is not None,
        "rows": data.rows,
        "rows_skipped": dropped,
        "pose_rows_skipped": len(data.skipped) - dropped,
        "dropped_fraction": dropped / max(data.rows, 1),
        "readings": int(data.ranges.size),
        "repeated_rings": int(built.run.repeat.sum()),
        "rejected": rejected,
        "below_min_range": unmeasured,
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
    pose_skips = len(data.skipped) - dropped
    skips = f"{dropped} skipped" + (f"; {pose_skips} pose rows skipped" if pose_skips else "")
    typer.echo(
        f"{data.rows} rows ({skips}), {data.ranges.size} readings, "
        f"{int(built.run.repeat.sum())} repeated rings merged, "
        + (f"{unmeasured} below the min range not mapped, " if unmeasured else "")
        + f"rejected {sum(rejected.values())} "
        f"({', '.join(f'{k} {v}' for k, v in rejected.items())}); "
        f"wrote {folder.target}: map.png, {yaml_path.name}, {pgm_path.name}, summary.json"
    )
