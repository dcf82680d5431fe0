"""The ``bayesmap`` command: parse, call the library, report; no logic of its own.

Sub-commands live one module per group (``bn``, ``sonar``, …) and load on first use
(:data:`COMMANDS`): ``bayesmap bn query`` imports neither the sonar mapper nor the
experiments, and ``bayesmap --help`` imports none of them. Help pages are click's plain
text: Typer's Rich help pulls in a markdown parser and a syntax highlighter, which would
double the start-up of every ``--help``.
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Iterator, MutableMapping
from typing import TYPE_CHECKING, Annotated, Any

import typer
from typer.core import TyperGroup
from typer.exceptions import TyperException

from bayesmap import __version__
from bayesmap._io import terminate_as_exit
from bayesmap.cli._console import library_messages, print_error
from bayesmap.cli._values import plain_values
from bayesmap.errors import BayesmapError

if TYPE_CHECKING:
    from typer.core import TyperCommand

COMMANDS: dict[str, tuple[str, str]] = {
    "sweep": (
        "bayesmap.cli.sweep:sweep",
        "Run an experiment over worlds × seeds × conditions; write tables and report.html.",
    ),
    "report": (
        "bayesmap.cli.sweep:report",
        "Write one self-contained HTML page of a sweep's tables and figures.",
    ),
    "reproduce": (
        "bayesmap.cli.reproduce:reproduce",
        "Run the paper experiments at their default size; write figures, maps and metrics.",
    ),
    "bn": (
        "bayesmap.cli.bn:app",
        "Inspect, query, draw and convert network files (XMLBIF, BIF, XBN, NET, XDSL, UAI).",
    ),
    "blackboard": (
        "bayesmap.cli.blackboard:app",
        "Map four-legged tables with a whiskered robot (Fox & Prescott 2011 and past it).",
    ),
    "sonar": (
        "bayesmap.cli.sonar:app",
        "Build occupancy maps from sonar-ring logs, with specular-reading rejection.",
    ),
    "rover": (
        "bayesmap.cli.rover:app",
        "The micro-rover (Post et al. 2016): run it on a world file, generate worlds.",
    ),
}
"""Each sub-command of ``bayesmap``: ``module:attribute`` (a Typer group or a command
function), loaded when the command runs, and the line ``bayesmap --help`` shows for it
(a test holds it equal to the command's own help)."""


def load_command(name: str) -> TyperCommand | TyperGroup:
    """The click command behind ``bayesmap NAME``, imported from :data:`COMMANDS`."""
    module_name, _, attribute = COMMANDS[name][0].partition(":")
    target = getattr(importlib.import_module(module_name), attribute)
    if isinstance(target, typer.Typer):
        target.rich_markup_mode = None  # plain help throughout (see the module docstring)
        command: Any = typer.main.get_group(target)
    else:
        single = typer.Typer(rich_markup_mode=None, add_completion=False)
        single.command(name=name)(target)
        command = typer.main.get_command(single)
    command.name = name
    return plain_values(command)


class _Commands(MutableMapping[str, Any]):
    """A group's sub-commands by name, each imported on first access (:func:`load_command`)."""

    def __init__(self, loaded: MutableMapping[str, Any]) -> None:
        self._loaded = dict(loaded)

    def __getitem__(self, name: str) -> Any:
        if name not in self._loaded:
            if name not in COMMANDS:
                raise KeyError(name)
            self._loaded[name] = load_command(name)
        return self._loaded[name]

    def __setitem__(self, name: str, command: Any) -> None:
        self._loaded[name] = command

    def __delitem__(self, name: str) -> None:
        del self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        yield from COMMANDS
        yield from (name for name in self._loaded if name not in COMMANDS)

    def __len__(self) -> int:
        return len(set(COMMANDS) | set(self._loaded))


class _LazyGroup(TyperGroup):
    """The root group: sub-commands load when invoked; the help lists them unloaded."""

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        plain_values(self)
        self.commands = _Commands(self.commands)

    def list_commands(self, ctx: Any) -> list[str]:
        return list(self.commands)

    def format_commands(self, ctx: Any, formatter: Any) -> None:
        rows = [(name, help_line) for name, (_, help_line) in COMMANDS.items()]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


app = typer.Typer(
    name="bayesmap",
    cls=_LazyGroup,
    help="Bayesian mapping and decision-making with sparse, noisy, local sensors.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"bayesmap {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    context: typer.Context,
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = False,
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log progress details.")] = False,
) -> None:
    """Bayesian mapping and decision-making with sparse, noisy, local sensors."""
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    context.with_resource(library_messages())


def main() -> None:
    """Entry point of the ``bayesmap`` console script and of ``python -m bayesmap``.

    Every error is one line on stderr: a usage mistake (unknown option, missing argument,
    a value of the wrong type) exits with code 2, a failed command with code 1.
    """
    try:
        with terminate_as_exit():
            code = app(standalone_mode=False, prog_name="bayesmap")
    except typer.Abort:
        print_error("aborted")
        raise SystemExit(130) from None
    except TyperException as error:  # click's usage errors, as Typer ships them
        context = getattr(error, "ctx", None)
        where = context.command_path if context is not None else "bayesmap"
        format_message = getattr(error, "format_message", None)
        text = format_message() if format_message is not None else str(error)
        code = getattr(error, "exit_code", 2)
        if context is not None and text == context.get_help():  # a group called bare
            typer.echo(text, err=True)
            raise SystemExit(code) from None
        if text.strip():
            print_error(f"{' '.join(text.split())} (see '{where} --help')")
        raise SystemExit(code) from None
    except BayesmapError as error:
        print_error(" ".join(str(error).split()))
        raise SystemExit(1) from None
    raise SystemExit(code if isinstance(code, int) else 0)


__all__ = ["COMMANDS", "app", "load_command", "main"]
