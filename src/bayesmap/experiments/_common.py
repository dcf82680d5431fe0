"""What every experiment shares: the progress hook, the result record and the run folder."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from bayesmap._io import RunFolder, run_folder
from bayesmap.errors import ConfigError


class ExperimentConfig(BaseModel):
    """Base of every experiment's ``Config``: a bad setting is a :class:`ConfigError`.

    pydantic's own ``ValidationError`` lies outside the project's error hierarchy; here it
    becomes one line naming each bad field and why.

    Examples
    --------
    >>> class Config(ExperimentConfig):
    ...     poses: int = 400
    >>> Config(poses="many")
    Traceback (most recent call last):
    ...
    bayesmap.errors.ConfigError: Config: poses: Input should be a valid integer, ...
    """

    def __init__(self, **data: Any) -> None:
        try:
            super().__init__(**data)
        except ValidationError as error:
            raise ConfigError(f"{type(self).__name__}: {validation_problems(error)}") from None


def validation_problems(error: ValidationError) -> str:
    """pydantic's errors on one line: ``field: why; field.sub: why`` (``config`` for the
    whole model), without pydantic's ``Value error,`` prefixes."""
    return "; ".join(
        f"{'.'.join(str(part) for part in e['loc']) or 'config'}: "
        + e["msg"].removeprefix("Value error, ")
        for e in error.errors()
    )


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

    def moved(self, folder: RunFolder) -> ExperimentResult:
        """This result with its paths moved from ``folder.path`` to ``folder.target``."""
        return replace(
            self,
            out_dir=folder.final(self.out_dir),
            figures=tuple(folder.final(p) for p in self.figures),
            metrics=tuple(folder.final(p) for p in self.metrics),
        )


def run_in_folder(
    name: str,
    config: BaseModel,
    out_dir: str | Path,
    body: Callable[[Path], ExperimentResult],
    *,
    command: str | None = None,
) -> ExperimentResult:
    """Run ``body(folder)`` in a fresh folder that becomes ``out_dir`` once it completes.

    The folder gets a ``manifest.json`` (version, command, the configuration, its seed,
    start and end time, every file's size and SHA-256) and replaces a previous run's
    ``out_dir`` as a whole; a failed or interrupted run leaves ``out_dir`` as it was (see
    :func:`bayesmap._io.run_folder`). ``command`` is recorded as what produced the run.
    """
    seed = getattr(config, "seed", None)
    with run_folder(
        out_dir,
        command=command or f"bayesmap.experiments.{name}.run",
        configuration={"experiment": name, **config.model_dump(mode="json")},
        seed=seed if isinstance(seed, int) else None,
    ) as folder:
        result = body(folder.path)
    return result.moved(folder)
