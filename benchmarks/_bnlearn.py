"""The bnlearn networks the BN benchmarks ask (the copies that ship with pgmpy)."""

from __future__ import annotations

from pathlib import Path

import pgmpy

MODELS = Path(pgmpy.__file__).parent / "utils" / "example_models"
"""Folder of the gzipped BIF files (``<name>.bif.gz``)."""

NETWORKS = [
    "asia",
    "alarm",
    "child",
    "insurance",
    "hailfinder",
    "win95pts",
    "pathfinder",
    "andes",
    "munin1",
    "pigs",
    "link",
    "munin",
]
"""The twelve networks of the inference tables, smallest to largest (munin: 1 041 variables)."""
