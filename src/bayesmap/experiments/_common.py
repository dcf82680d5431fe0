"""What every experiment shares: the progress hook and the result record."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ProgressHook = Callable[[str, int, int], None]
"""``hook(description, completed, total)``: called as an experiment advances.

``description`` names the current stage (e.g. ``"obstacles-flat"``), ``completed`` and
``total`` count its units of work (poses, steps, runs). Experiments never print; the CLI
turns these calls into a progress bar.
"""


def no_progress(description: str, completed: int, total: int) -> None:
    """The default :data:`ProgressHook`: does nothing."""


@dataclass(frozen=True)
class ExperimentResult:
    """Where an experiment wrote its outputs, and its headline numbers.

    Attributes
    ----------
    name
        The experiment's name (``"rover"``, ``"sonar"``, ``"blackboard"``).
    out_dir
        The folder holding everything it wrote.
    figures
        Paths of the figures (PNG, GIF) it wrote.
    metrics
        Paths of its metrics files (JSON) and summaries (Markdown).
    headline
        A few ``name: value`` numbers for the closing summary of ``reproduce``.
    """

    name: str
    out_dir: Path
    figures: tuple[Path, ...] = ()
    metrics: tuple[Path, ...] = ()
    headline: dict[str, float | int | str] = field(default_factory=dict)
