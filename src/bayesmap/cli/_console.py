"""How every command prints: literally. User text is never read as Rich markup.

Messages are printed on one line (never wrapped at the terminal width), so that a log
keeps a whole message on the line a ``grep`` finds.

Network names, states, evidence and paths may hold brackets (``[/x]``, ``[m]``), which
Rich would take for markup: eat them, or fail on them. The consoles made here have markup
off, and styles come from :class:`rich.text.Text` spans, never from the text itself.
"""

from __future__ import annotations

from rich.console import Console
from rich.text import Text


def console(*, stderr: bool = False) -> Console:
    """A console that prints strings as they are (no markup, no highlighting)."""
    return Console(stderr=stderr, markup=False, highlight=False)


_STDERR = console(stderr=True)


def styled(*parts: str | tuple[str, str]) -> Text:
    """Literal text from plain strings and ``(text, style)`` pairs."""
    return Text.assemble(*parts)


def print_error(message: object, *, label: str = "error", out: Console | None = None) -> None:
    """Print ``label: message`` to stderr, the label in red, the message literally."""
    (out or _STDERR).print(styled((f"{label}:", "red"), " ", str(message)), soft_wrap=True)


def print_note(message: object, *, out: Console | None = None) -> None:
    """Print a message to stderr, literally."""
    (out or _STDERR).print(Text(str(message)), soft_wrap=True)
