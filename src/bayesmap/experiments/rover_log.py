"""Map a logged rover drive: ``bayesmap rover map LOG --out DIR``.

The log's readings and poses (:mod:`bayesmap.rover.logs`) go through the same contact
detection, IR model and map update as a simulated run (:class:`bayesmap.rover.mapping.IRMapper`,
Post et al. 2016 eqs. 31–37), with the rangers' ADC fit of §5.1 read from a file or fitted
to calibration pairs. The map covers the driven area plus the rangers' reach.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from bayesmap._io import run_folder, write_bytes, write_json
from bayesmap._typing import ProgressHook
from bayesmap.errors import InputError
from bayesmap.experiments._common import no_progress
from bayesmap.grid import OccupancyGrid
from bayesmap.grid.ros import write_ros_map
from bayesmap.limits import cell_side_problem
from bayesmap.rover.logs import RoverLog, read_calibration, read_rover_log
from bayesmap.rover.mapping import IRMapper
from bayesmap.rover.params import RoverParams
from bayesmap.sensing.ir import RAW_FIT
from bayesmap.viz.rover import maps_pair_figure

__all__ = ["map_log"]


_PROGRESS_ROWS = 1000
"""Rows mapped between two calls of the progress hook."""


def map_log(
    log: Path,
    out: Path,
    *,
    calibration: Path | None = None,
    distance_unit: str = "m",
    position_unit: str = "m",
    heading_unit: str = "rad",
    resolution: float = 0.5,
    strict: bool = False,
    progress: ProgressHook = no_progress,
    command: str = "bayesmap.experiments.rover_log.map_log",
) -> dict[str, Any]:
    """Replay ``log`` into maps under ``out``; return the summary written to summary.json.

    ``out`` is a run folder (:func:`bayesmap._io.run_folder`): written whole with its
    manifest when the maps are done, or not at all; ``command`` is recorded as what
    produced it. ``progress`` is called while the log is read (bytes) and mapped (rows)."""
    problem = cell_side_problem(resolution)
    if problem is not None:
        raise InputError(f"--resolution {problem}")
    fit = (
        RAW_FIT
        if calibration is None
        else read_calibration(calibration, distance_unit=distance_unit)
    )
    settings = {
        "log": str(log),
        "calibration": None if calibration is None else str(calibration),
        "distance_unit": distance_unit,
        "position_unit": position_unit,
        "heading_unit": heading_unit,
        "resolution_m": resolution,
        "strict": strict,
    }
    with run_folder(out, command=command, configuration=settings, seed=None) as folder:
        params = RoverParams(ir_fit=fit)
        data = read_rover_log(
            log,
            len(params.sensor_angles),
            position_unit=position_unit,
            heading_unit=heading_unit,
            strict=strict,
            progress=progress,
        )
        reach = params.r_max + params.sensor_offset + 3.0 * params.sigma_xy
        low = np.floor((data.poses[:, :2].min(axis=0) - reach) / resolution) * resolution
        high = np.ceil((data.poses[:, :2].max(axis=0) + reach) / resolution) * resolution
        width, height = (float(v) for v in high - low)
        grid = OccupancyGrid(
            width, height, resolution, origin=(float(low[0]), float(low[1])), prior=params.prior
        )
        mapper = IRMapper(grid, params)
        for row, (raw, pose) in enumerate(zip(data.raw, data.poses, strict=True), start=1):
            mapper.update(raw, pose)
            if row % _PROGRESS_ROWS == 0 or row == len(data.poses):
                progress("mapping", row, len(data.poses))
        return _write_maps(folder.path, log, calibration, fit, params, grid, data)


def _write_maps(
    out: Path,
    log: Path,
    calibration: Path | None,
    fit: tuple[float, float, float],
    params: RoverParams,
    grid: OccupancyGrid,
    data: RoverLog,
) -> dict[str, Any]:
    """Write the map (npz, ROS YAML + PGM), its figure and summary.json into ``out``."""
    grid.save_npz(out / "map.npz")
    yaml_path, _ = write_ros_map(
        out / "map",
        grid.probability,
        grid.resolution,
        grid.origin,
        unknown_mask=grid.unobserved(),
        entropy=grid.entropy,
        certain_below=params.h_desired,
    )
    write_bytes(
        out / "path.png",
        maps_pair_figure(
            grid.probability, grid.entropy, grid.extent, title=log.name, path=data.poses[:, :2]
        ),
    )
    summary: dict[str, Any] = {
        "log": str(log),
        "rows": int(len(data.poses)),
        "rows_skipped": len(data.skipped),
        "skipped": [{"line": row.line, "reason": row.reason} for row in data.skipped],
        "calibration": {
            "a": fit[0],
            "b": fit[1],
            "c": fit[2],
            "source": str(calibration or "paper §5.1"),
        },
        "coverage": float(np.mean(grid.entropy < params.h_desired)),
        "map": {"yaml": yaml_path.name, "origin": list(grid.origin), "shape": list(grid.shape)},
    }
    write_json(out / "summary.json", summary)
    return summary
