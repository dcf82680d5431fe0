"""The one number grammar every reader accepts: plain ASCII decimals.

Python's ``float`` also reads ``1_0``, ``inf``, ``Infinity``, ``nan`` and digits of other
scripts (``"٣"``); a file that holds them was not written by a tool that means numbers, so
readers refuse them and name the field. YAML files are read with
:class:`PlainNumberLoader`, under which only such decimals are numbers.
"""

from __future__ import annotations

import re
from typing import Any

DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
"""A plain decimal number, whole (use with ``fullmatch``)."""

NOT_IN_DECIMALS = re.compile(r"[^0-9eE+\-.\s,]")
"""A character no decimal number (nor the spaces and commas between them) holds."""

DECIMAL_LINE = re.compile(rf"^(?:{DECIMAL.pattern})$")
"""A plain decimal number filling a whole scalar (for PyYAML's implicit resolvers)."""

_YAML_INT = "tag:yaml.org,2002:int"
_YAML_FLOAT = "tag:yaml.org,2002:float"


def is_decimal(text: str) -> bool:
    """Whether ``text`` is one plain ASCII decimal number.

    Examples
    --------
    >>> [is_decimal(t) for t in ("0.25", "-1e-3", "1_0", "inf", "٣")]
    [True, True, False, False, False]
    """
    return DECIMAL.fullmatch(text) is not None


def _plain_number_loader() -> type:
    """Build ``PlainNumberLoader`` (PyYAML loads only when a YAML file is read).

    Examples
    --------
    >>> import yaml
    >>> from bayesmap._numbers import PlainNumberLoader
    >>> yaml.load("{a: 1_0, b: 0.05, c: [2, -1e-3]}", Loader=PlainNumberLoader)
    {'a': '1_0', 'b': 0.05, 'c': [2, -0.001]}
    """
    import yaml

    class PlainNumberLoader(yaml.SafeLoader):  # type: ignore[misc]  # untyped PyYAML
        """PyYAML's safe loader with YAML numbers narrowed to plain decimals.

        YAML 1.1 also reads ``1_0`` as 10, ``0x10`` as 16, ``1:30`` as 90 and ``.inf`` and
        ``.nan`` as numbers; under this loader they stay strings, which the reader then refuses
        by name. Whole numbers without a leading zero are ints, other decimals floats.
        """

    PlainNumberLoader.yaml_implicit_resolvers = {
        first: [(tag, rx) for tag, rx in resolvers if tag not in (_YAML_INT, _YAML_FLOAT)]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }
    PlainNumberLoader.add_implicit_resolver(
        _YAML_INT, re.compile(r"^[+-]?(?:0|[1-9][0-9]*)$"), list("+-0123456789")
    )
    PlainNumberLoader.add_implicit_resolver(_YAML_FLOAT, DECIMAL_LINE, list("+-.0123456789"))
    return PlainNumberLoader


def __getattr__(name: str) -> Any:
    """``PlainNumberLoader``, built on first use (PEP 562)."""
    if name != "PlainNumberLoader":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    loader = globals()[name] = _plain_number_loader()
    return loader
