"""Option values of the plain types converted without pydantic, so that commands start fast.

Typer (from 0.2x) converts every parameter value through a pydantic ``TypeAdapter``; the
first one imports pydantic, which costs about as much start-up as the whole Bayesian-network
engine. The commands declare plain types: ``str``, ``bool``, ``int`` and ``float`` (with
``min``/``max`` bounds), ``pathlib.Path``, and lists of them; :func:`plain_values` gives those
parameters a converter of a line each, with the messages Typer prints, and leaves every
other parameter (enums, literals, clamped numbers, files, tuples) to Typer. With a Typer
that has no such machinery it changes nothing.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, get_args, get_origin

import typer

if TYPE_CHECKING:
    from collections.abc import Callable

    from typer.core import TyperCommand, TyperGroup

try:  # Typer's runtime coercion (0.2x); absent in older Typers, which need none of this
    from typer._coercion import RuntimeParam
    from typer._param_types import coerce_cli_path
except ImportError:  # pragma: no cover - depends on the installed Typer
    COERCION = False
else:
    COERCION = True

_TRUE = {"1", "true", "t", "yes", "y", "on"}
_FALSE = {"0", "false", "f", "no", "n", "off", ""}


def _boolean(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in _TRUE or text in _FALSE:
        return text in _TRUE
    raise ValueError("Input should be a valid boolean")


def _number(kind: type[int] | type[float], low: float | None, high: float | None) -> Any:
    noun = "integer" if kind is int else "number"

    def convert(value: Any) -> int | float:
        try:
            number = kind(value)
        except (TypeError, ValueError):
            raise ValueError(f"Input should be a valid {noun}") from None
        if low is not None and number < low:
            raise ValueError(f"Input should be greater than or equal to {low}")
        if high is not None and number > high:
            raise ValueError(f"Input should be less than or equal to {high}")
        return number

    return convert


def _converter(annotation: Any, info: Any) -> Callable[[Any, Any, Any], Any] | None:
    """``convert(value, param, ctx)`` for a plain ``annotation``, or None to keep Typer's."""
    if getattr(info, "parser", None) is not None:
        return None
    if annotation is str:
        return lambda value, param, ctx: value if isinstance(value, str) else str(value)
    if annotation is bool:
        return lambda value, param, ctx: _boolean(value)
    if annotation in (int, float) and not getattr(info, "clamp", False):
        number = _number(annotation, info.min, info.max)
        return lambda value, param, ctx: number(value)
    if annotation is Path and getattr(info, "path_type", None) is None:

        def path(value: Any, param: Any, ctx: Any) -> Path:
            checked = coerce_cli_path(value, info, path_type=None, param=param, ctx=ctx)
            return Path(os.fsdecode(checked))

        return path
    return None


def _make_plain_param() -> type | None:
    if not COERCION:  # pragma: no cover - depends on the installed Typer
        return None

    @dataclass(frozen=True)
    class PlainParam(RuntimeParam):
        """A parameter converted by :func:`_converter`, one item at a time for a list."""

        convert: Callable[[Any, Any, Any], Any]
        many: bool

        def _coerce_value(self, value: Any, param: Any, ctx: Any) -> Any:
            try:
                if self.many:
                    items = value if isinstance(value, (list, tuple)) else [value]
                    return [self.convert(item, param, ctx) for item in items]
                return self.convert(value, param, ctx)
            except ValueError as error:
                raise typer.BadParameter(str(error), ctx=ctx, param=param) from None

    return PlainParam


_PLAIN_PARAM = _make_plain_param()


def plain_values(command: TyperCommand | TyperGroup) -> TyperCommand | TyperGroup:
    """``command`` (and its sub-commands) with plain-typed parameters converted here.

    The hook rests on Typer's private parameter objects; a Typer whose objects are shaped
    otherwise keeps its own conversion for every parameter not yet converted.
    """
    if _PLAIN_PARAM is None:  # pragma: no cover - depends on the installed Typer
        return command
    try:
        return _plain_values(command)
    except (AttributeError, TypeError):  # pragma: no cover - depends on the installed Typer
        return command


def _plain_values(command: TyperCommand | TyperGroup) -> TyperCommand | TyperGroup:
    assert _PLAIN_PARAM is not None
    context = typer.Context(command, **getattr(command, "context_settings", {}))
    help_option = command.get_help_option(context)  # made once and kept by the command
    for param in [*command.params, *([help_option] if help_option is not None else [])]:
        descriptor = getattr(param, "type_descriptor", None)
        if descriptor is None or getattr(param, "_runtime_param", "absent") is not None:
            continue
        annotation, info = descriptor.annotation, descriptor.parameter_info
        many = get_origin(annotation) is list
        if many:
            (annotation,) = get_args(annotation)
        convert = _converter(annotation, info)
        if convert is not None:
            param._runtime_param = _PLAIN_PARAM(  # type: ignore[attr-defined]
                parameter_info=info, annotation=descriptor.annotation, convert=convert, many=many
            )
    for sub in getattr(command, "commands", {}).values():
        _plain_values(sub)
    return command
