"""Package exports that load on first use (PEP 562), so importing a package stays cheap.

``bayesmap.viz`` must not import matplotlib until a figure is drawn, and the CLI imports the
simulator and the sonar code only inside the commands that use them; a package's
``__init__`` therefore names its exports here instead of importing them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package`` whose ``exports`` load on first use.

    ``exports`` maps each exported name to the submodule (relative to ``package``) that
    defines it; a name mapped to itself is that submodule.

    Examples
    --------
    >>> getattr_, dir_ = lazy_exports("bayesmap", {"geometry": "geometry"})
    >>> getattr_("geometry").__name__
    'bayesmap.geometry'
    """

    def __getattr__(name: str) -> Any:
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = importlib.import_module(f"{package}.{exports[name]}")
        return module if exports[name] == name else getattr(module, name)

    def __dir__() -> list[str]:
        return sorted(exports)

    return __getattr__, __dir__
