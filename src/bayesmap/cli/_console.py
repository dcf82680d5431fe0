"""How every command prints: literally. User text is never read as Rich markup.

Messages are printed on one line (never wrapped at the terminal width), so that a log
keeps a whole message on the line a ``grep`` finds.

Network names, states, evidence and paths may hold brackets (``[/x]``, ``[m]``), which
Rich would take for markup: eat them, or fail on them. The consoles made here have markup
off, and styles come from :class:`rich.text.Text` spans, never from the text itself.

Rich itself loads on the first message, so a command that prints nothing through it
(``--help``, ``--version``, a ``--json`` answer) starts without it.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from functools import cache
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from rich.console import Console
    from rich.text import Text

    from bayesmap._typing import ProgressHook


USAGE = 2
"""Exit code of a usage mistake, as click's own: a malformed, repeated or conflicting option."""


def console(*, stderr: bool = False) -> Console:
    """A console that prints strings as they are (no markup, no highlighting, no emoji)."""
    from rich.console import Console

    return Console(stderr=stderr, markup=False, highlight=False, emoji=False)


@cache
def _stderr() -> Console:
    return console(stderr=True)


def styled(*parts: str | tuple[str, str]) -> Text:
    """Literal text from plain strings and ``(text, style)`` pairs."""
    from rich.text import Text

    return Text.assemble(*parts)


def print_error(message: object, *, label: str = "error", out: Console | None = None) -> None:
    """Print ``label: message`` to stderr, the label in red, the message literally."""
    (out or _stderr()).print(styled((f"{label}:", "red"), " ", str(message)), soft_wrap=True)


def print_note(message: object, *, out: Console | None = None) -> None:
    """Print a message to stderr, literally."""
    from rich.text import Text

    (out or _stderr()).print(Text(str(message)), soft_wrap=True)


class _LiteralHandler(logging.Handler):
    """Print the library's log records as ``level: message`` lines on stderr, literally."""

    def emit(self, record: logging.LogRecord) -> None:
        print_note(f"{record.levelname.lower()}: {record.getMessage()}")


@contextmanager
def library_messages() -> Iterator[None]:
    """While a command runs, print what the library logs and warns as one literal line each.

    The ``bayesmap`` logger's records (skipped rows, a suspicious unit) print as
    ``warning: message`` (``info: message`` with ``--verbose``), and warnings the library
    raises (a table renormalised) as ``warning: message``, without Python's file, line and
    source line. Other libraries' logs and warnings keep their usual form.
    """
    handler = _LiteralHandler()
    library = logging.getLogger("bayesmap")
    library.addHandler(handler)
    propagate = library.propagate
    library.propagate = False
    with warnings.catch_warnings():
        shown = warnings.showwarning

        def show(
            message: Warning | str,
            category: type[Warning],
            filename: str,
            lineno: int,
            file: TextIO | None = None,
            line: str | None = None,
        ) -> None:
            if category.__module__.startswith("bayesmap."):
                print_note(f"warning: {message}")
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        try:
            yield
        finally:
            library.removeHandler(handler)
            library.propagate = propagate


@contextmanager
def progress_bar(
    out: Console,
    *,
    first: str = "starting",
    percent: bool = False,
    elapsed: bool = False,
    remaining: bool = False,
    transient: bool = True,
) -> Iterator[ProgressHook]:
    """A progress bar on ``out`` while the block runs, and the hook that moves it.

    The bar shows the stage the hook last named (literally; ``first`` until then), the bar,
    how far it is (``done/total``, or a percentage with ``percent``, for bytes), and the
    time spent and left when asked. The hook takes ``(description, completed, total)``,
    as every experiment and library loop reports (:data:`bayesmap._typing.ProgressHook`);
    a negative ``total`` means not known yet. A ``transient`` bar is gone when the block
    ends, so that an error or the result is printed without a bar above it. On a console
    that is not a terminal (output to a file or a pipe) there is no bar, and nothing is
    printed for it.
    """
    if not out.is_terminal:
        yield lambda description, completed, total: None
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        ProgressColumn,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns: list[ProgressColumn] = [
        TextColumn("{task.description}", markup=False),
        BarColumn(),
        TaskProgressColumn() if percent else MofNCompleteColumn(),
    ]
    if elapsed:
        columns.append(TimeElapsedColumn())
    if remaining:
        columns.append(TimeRemainingColumn())
    with Progress(*columns, console=out, transient=transient) as bar:
        task = bar.add_task(first, total=None)

        def hook(description: str, completed: int, total: int) -> None:
            bar.update(
                task,
                description=description,
                completed=completed,
                total=total if total >= 0 else None,
            )

        yield hook


def headline_text(headline: Mapping[str, object]) -> str:
    """A run's headline numbers on one line: ``key value, ...``.

    Floats get three decimals, an undefined one (NaN, e.g. a precision over no objects)
    reads ``undefined``; other values print as they are. Used by every ``run`` command.
    """

    def value_text(value: object) -> str:
        if isinstance(value, float):
            return f"{value:.3f}" if math.isfinite(value) else "undefined"
        return str(value)

    return ", ".join(f"{key} {value_text(value)}" for key, value in headline.items())
