"""Public names of a package imported on first use (PEP 562), for a fast ``import``.

``tooldesign_env``, ``benchmarks.design`` and ``benchmarks.reports`` list where each public name
lives; their module ``__getattr__`` calls :func:`lazy_attribute`. A name that is not listed but
is a submodule is imported too, so ``import tooldesign_env; tooldesign_env.env.SERIES_KEYS``
works as it would with eager imports.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Mapping
from typing import Any

__all__ = ["lazy_attribute"]


def lazy_attribute(package: str, table: Mapping[str, str], name: str) -> Any:
    """The attribute ``name`` of ``package``, importing the module ``table`` says holds it.

    The value is stored in the package's namespace, so the next lookup is an ordinary one.

    Raises:
        AttributeError: ``name`` is neither listed nor a submodule of ``package``.
    """
    module = table.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
    elif not name.startswith("__") and importlib.util.find_spec(f"{package}.{name}") is not None:
        value = importlib.import_module(f"{package}.{name}")
    else:
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    setattr(sys.modules[package], name, value)
    return value
