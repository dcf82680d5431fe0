"""``bayesmap bn codegen``: compile a network's question pattern to portable C99."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from bayesmap.cli._console import print_error, print_note
from bayesmap.errors import BayesmapError


def _names(items: list[str] | None) -> list[str]:
    """Variable names from repeated and/or comma-separated options."""
    return [name.strip() for item in items or [] for name in item.split(",") if name.strip()]


def codegen(
    file: Annotated[
        Path, typer.Argument(help="Network file (.xml/.xmlbif/.bifxml, .bif, .xbn, .net).")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Directory for PREFIX.h and PREFIX.c.")],
    target: Annotated[
        list[str], typer.Option("--target", "-t", help="Variable to answer; repeat for more.")
    ],
    evidence: Annotated[
        list[str] | None,
        typer.Option(
            "--evidence", "-e", help="Variables that may be observed, VAR,VAR,... (or repeat)."
        ),
    ] = None,
    soft: Annotated[
        list[str] | None,
        typer.Option("--soft", help="Variables that take soft evidence, VAR,VAR,... (or repeat)."),
    ] = None,
    arith: Annotated[
        str, typer.Option("--arith", help="float, double, q16.16 or q8.24.")
    ] = "q16.16",
    name: Annotated[
        str | None, typer.Option("--name", help="File and C-name prefix (default: the file's).")
    ] = None,
) -> None:
    """Write C99 code answering P(TARGET | evidence, soft evidence) for one network."""
    from bayesmap import bn  # the engine loads only when this command runs
    from bayesmap.bn.codegen import generate
    from bayesmap.bn.codegen.emit import identifier

    try:
        net = bn.read(file)
        prefix = name if name is not None else identifier(file.name.split(".")[0]).lower()
        code = generate(
            net, _names(target), _names(evidence), arith, soft=_names(soft), name=prefix
        )
        header, source = code.write(out)
    except BayesmapError as error:
        print_error(" ".join(str(error).split()))
        raise typer.Exit(1) from error
    print_note(
        f"wrote {header} and {source}: {code.functions} pattern functions, {code.arith.name}"
    )
