"""Map a logged whisker tour: ``bayesmap blackboard map LOG --world ROOM.json --out DIR``.

The log's poses and sweeps (:mod:`bayesmap.blackboard.logs`) go through the fused mapper
(:class:`~bayesmap.blackboard.fused.FusedMapper`, docs/blackboard.md) as a simulated tour's
do. The room file gives what the mapper is told and never learns from the log: the walled
arena and the catalogue of object types. Tables it lists are the truth the map is scored
against and drawn over; a room of real tables whose places are unknown lists none (and
names its types in ``catalogue``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from bayesmap._io import run_folder, write_bytes, write_json
from bayesmap._typing import ProgressHook
from bayesmap.blackboard.fused import FusedMap, FusedMapper
from bayesmap.blackboard.logs import angle_unit_hint, read_sweep_log
from bayesmap.errors import InputError
from bayesmap.experiments._common import no_progress
from bayesmap.experiments.blackboard_world import catalogue_of, map_figure, match_tolerance
from bayesmap.experiments.fused_run import fused_params, map_scores
from bayesmap.sim import whisker_worlds
from bayesmap.sim.whiskers import WhiskerParams

__all__ = ["map_log"]


def map_log(
    log: Path,
    world: Path,
    out: Path,
    *,
    sigma_range: float = 0.02,
    sigma_normal: float = 0.05,
    seed: int = 0,
    length_unit: str = "m",
    angle_unit: str = "rad",
    progress: ProgressHook = no_progress,
    command: str = "bayesmap.experiments.blackboard_log.map_log",
) -> dict[str, Any]:
    """Map ``log`` in the room of ``world``; write ``map.json``, ``map.png`` and
    ``metrics.json`` under ``out`` and return the metrics (``warnings``: hints about the
    log, such as angles that look like degrees read as radians).

    ``sigma_range`` [m] and ``sigma_normal`` [rad] are the sensor's noise on a contact's
    range and normal (the defaults are the simulator's ``normal`` condition); ``seed``
    seeds the sampler. ``progress`` is called per pose mapped. ``out`` is a run folder
    (:func:`bayesmap._io.run_folder`): written whole with its manifest, or not at all;
    ``command`` is recorded as what produced it.
    """
    for name, value in (("sigma_range", sigma_range), ("sigma_normal", sigma_normal)):
        if not (np.isfinite(value) and value >= 0):
            raise InputError(f"{name} must be a number >= 0, got {value}")
    settings = {
        "log": str(log),
        "world": str(world),
        "sigma_range": sigma_range,
        "sigma_normal": sigma_normal,
        "length_unit": length_unit,
        "angle_unit": angle_unit,
    }
    with run_folder(out, command=command, configuration=settings, seed=seed) as folder:
        room = whisker_worlds.load_world(world)
        catalogue = catalogue_of(room)  # a room without tables must list it (load_world)
        data = read_sweep_log(log, length_unit=length_unit, angle_unit=angle_unit)
        width, height = room.arena
        outside = (
            (data.poses[:, 0] < 0)
            | (data.poses[:, 0] > width)
            | (data.poses[:, 1] < 0)
            | (data.poses[:, 1] > height)
        )
        if outside.any():
            k = int(np.flatnonzero(outside)[0])
            raise InputError(
                f"{log}: pose {k + 1} at ({data.poses[k, 0]:g}, {data.poses[k, 1]:g}) m lies "
                f"outside the {width:g} m x {height:g} m arena of {world}: are the units or the "
                "frame right?"
            )
        sensor = WhiskerParams(
            sigma_r=sigma_range, sigma_theta=sigma_normal, whisker_length=data.whisker_length
        )
        mapper = FusedMapper(catalogue, room.arena, fused_params(sensor))
        rng = np.random.default_rng(seed)
        for k, (pose, sweeps) in enumerate(zip(data.poses, data.sweeps, strict=True), start=1):
            mapper.step(pose, sweeps, rng=rng)
            progress("mapping", k, len(data.poses) + 1)
        fused: FusedMap = mapper.finish(rng=rng)
        progress("mapping", len(data.poses) + 1, len(data.poses) + 1)
        truth = room.world(name=Path(world).stem)
        objects, doubtful = fused.objects(), fused.objects(doubtful=True)
        metrics: dict[str, Any] = {
            "log": str(log),
            "world": str(world),
            "poses": len(data.poses),
            "sweeps": int(sum(len(s) for s in data.sweeps)),
            "contacts": int(sum(int(np.isfinite(s[:, 3]).sum()) for s in data.sweeps)),
            "sigma_range": sigma_range,
            "sigma_normal": sigma_normal,
            "seed": seed,
            "catalogue": [t._asdict() for t in catalogue],
            "objects": len(objects),
            "doubtful": len(doubtful),
            "warnings": [hint for hint in (angle_unit_hint(data, angle_unit),) if hint],
        }
        if len(truth.tables):
            metrics.update(map_scores(fused, truth, match_tolerance(truth)))
        write_json(folder.path / "metrics.json", metrics)
        write_json(
            folder.path / "map.json",
            {"objects": objects, "doubtful": doubtful, "arena": room.arena},
        )
        title = f"{Path(log).name}: fused map ({len(objects)} objects, {len(data.poses)} poses)"
        write_bytes(folder.path / "map.png", map_figure(truth, objects, title, doubtful))
        return metrics
