"""The fused table mapper over a robot's tour, and the scores of its map (shared by the
paper experiment's ``reproduce blackboard`` and by world-file runs)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from bayesmap._typing import ProgressHook
from bayesmap.blackboard.fused import FusedMap, FusedMapper, FusedParams
from bayesmap.blackboard.sweep_model import ObjectType
from bayesmap.errors import ConfigError
from bayesmap.experiments._common import no_progress
from bayesmap.experiments.table_metrics import (
    MatchTolerance,
    fused_scores,
    match_tables,
    symmetry_period,
)
from bayesmap.sim.tables_world import TablesWorld
from bayesmap.sim.whiskers import WhiskerParams, observe
from bayesmap.viz.tables import MappedObjects

__all__ = ["fused_metrics", "fused_params", "map_scores", "run_fused"]


def fused_params(
    sensor: WhiskerParams, overrides: dict[str, int | float] | None = None
) -> FusedParams:
    """Fused-mapper constants for a sensor: its noise, never below the model's floors.

    The model's σ_r and σ_φ are the sensor's, at least 2 cm and 0.1 rad (a noiseless
    sensor still meets a model that is not exact); births jitter by a tenth of σ_r (at
    least 2 cm); in the noisy condition leg spacings are matched to 12 cm instead of 6 and
    a leg candidate needs four contacts' bearings crossing (1.5 contacts' worth otherwise:
    two noisy bearings cross somewhere wherever they point); the model's reach is the
    whiskers' length.
    """
    base: dict[str, Any] = {
        "sigma_r": max(0.02, sensor.sigma_r),
        "sigma_phi": max(0.1, sensor.sigma_theta),
        "birth_sigma_xy": max(0.02, sensor.sigma_r / 10.0),
        "spacing_tol": 0.06 if sensor.sigma_r < 0.1 else 0.12,
        "min_votes": 1.5 if sensor.sigma_r < 0.1 else 4.0,
        "reach": sensor.whisker_length,
    }
    base.update(overrides or {})
    try:
        return FusedParams(**base)
    except TypeError as error:
        raise ConfigError(f"unknown FusedParams field in the overrides: {error}") from error


def _touched_support(
    table: np.ndarray, leg: np.ndarray, seen: dict[int, set[int]]
) -> tuple[np.ndarray, np.ndarray]:
    """Tables touched at a pose and, per table, the distinct legs of it touched so far."""
    for t, g in zip(table, leg, strict=True):
        if t >= 0:
            seen.setdefault(int(t), set()).add(int(g))
    hit = np.unique(table[table >= 0])
    return hit, np.array([len(seen[int(t)]) for t in hit], dtype=np.int64)


def run_fused(
    world: TablesWorld,
    poses: np.ndarray,
    catalogue: tuple[ObjectType, ...],
    sensor: WhiskerParams,
    params: FusedParams,
    sensor_rng: np.random.Generator,
    chain_rng: np.random.Generator,
    *,
    label: str,
    progress: ProgressHook = no_progress,
) -> dict[str, Any]:
    """The fused mapper over a tour: the running map per pose, timings, the final map."""
    arena = (world.bounds[2], world.bounds[3])
    mapper = FusedMapper(catalogue, arena, params)
    maps, touched, support, contacts, step_s = [], [], [], [], []
    seen: dict[int, set[int]] = {}
    start, cpu_start = time.perf_counter(), time.process_time()
    for index, pose in enumerate(poses):
        reading = observe(world, pose, sensor, rng=sensor_rng)
        tic = time.perf_counter()
        result = mapper.step(pose, reading.sweeps, rng=chain_rng)
        step_s.append(time.perf_counter() - tic)
        maps.append(result.tables)
        hit, legs = _touched_support(reading.table, reading.leg, seen)
        touched.append(hit)
        support.append(legs)
        contacts.append(int((reading.table >= 0).sum()))
        progress(label, index + 1, len(poses) + 1)
    fused: FusedMap = mapper.finish(rng=chain_rng)
    progress(label, len(poses) + 1, len(poses) + 1)
    return {
        "maps": maps,
        "touched": touched,
        "support": support,
        "contacts": np.asarray(contacts),
        "step_ms": 1e3 * np.asarray(step_s),
        "wall_s": time.perf_counter() - start,
        "cpu_s": time.process_time() - cpu_start,
        "sensor": sensor,
        "fused": fused,
        "store_rows": len(mapper.store_),
    }


def fused_metrics(run: dict[str, Any], world: TablesWorld, tol: MatchTolerance) -> dict[str, Any]:
    """The ``fused_*`` metrics of a fused run's final map (:func:`map_scores`), the size of
    its evidence store, and ``tables_touched``: the true tables some whisker touched at
    some pose (a table no whisker touched left no contact, so no mapper could place it: the
    tour never came within a whisker's length of it).
    """
    return {
        **map_scores(run["fused"], world, tol),
        "fused_evidence_rows": run["store_rows"],
        "tables_touched": len(set().union(*(set(t.tolist()) for t in run["touched"]))),
    }


def map_scores(fused: FusedMap, world: TablesWorld, tol: MatchTolerance) -> dict[str, Any]:
    """The ``fused_*`` scores of a fused map against the world's tables
    (:func:`~bayesmap.experiments.table_metrics.fused_scores`), its log posterior, and per
    mapped object its existence probability and whether it matches a true table
    (``fused_existence``, ``fused_object_true``: the data of a calibration check)."""
    matched, _ = match_tables(
        fused.tables, world.tables, tol, symmetry_period(world.table_sizes[:, :2])
    )
    true = np.zeros(len(fused.tables), dtype=bool)
    true[matched] = True
    sizes = np.array(
        [
            [fused.catalogue[int(k)].length, fused.catalogue[int(k)].width]
            for k in fused.tables[:, 3]
        ]
    ).reshape(-1, 2)
    return {
        **fused_scores(
            fused.tables, sizes, world.tables, world.table_sizes[:, :2], world.bounds, tol
        ),
        "fused_log_posterior": fused.log_posterior,
        "fused_existence": [float(p) for p in fused.existence],
        "fused_doubtful_existence": [float(p) for p in fused.doubtful_existence],
        "fused_object_true": true.tolist(),
    }


def figure_objects(objects: list[dict[str, Any]]) -> MappedObjects:
    """Object records (as in ``map.json`` and :meth:`FusedMap.objects`) as the fused map's
    figure draws them."""
    return MappedObjects(
        np.array([[o["x"], o["y"], o["theta"]] for o in objects]).reshape(-1, 3),
        np.array([[o["length"], o["width"], o["leg"]] for o in objects]).reshape(-1, 3),
        np.array([o["existence_probability"] for o in objects]),
        [str(o["type"]) for o in objects],
    )
