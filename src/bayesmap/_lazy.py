"""Package exports that load on first use (PEP 562), so importing a package stays cheap.

``bayesmap.viz`` must not import matplotlib until a figure is drawn, and the CLI imports the
simulator and the sonar code only inside the commands that use them; a package's
``__init__`` therefore names its exports here instead of importing them.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable, Mapping
from types import ModuleType
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


def lazy_module(name: str) -> ModuleType:
    """Module ``name``, executed on its first attribute access (:class:`importlib.util.LazyLoader`).

    For a third-party module that only some calls need (``opt_einsum`` in ``bayesmap.bn``:
    about a sixth of ``import bayesmap.bn``'s own time, issue 15 item 5). After the first
    access the module is the ordinary one, so hot paths pay nothing. An already imported
    module is returned as it is.

    Examples
    --------
    >>> colorsys = lazy_module("colorsys")
    >>> colorsys.rgb_to_hsv(1.0, 0.0, 0.0)
    (0.0, 1.0, 1.0)
    """
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ModuleNotFoundError(f"no module named {name!r}", name=name)
    loader = importlib.util.LazyLoader(spec.loader)
    spec.loader = loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    loader.exec_module(module)
    return module
