"""Lazy imports of optional backends, with an error that names the pip extra to install.

`import optimizers` needs only numpy and cma; scikit-optimize, pyswarms, optuna and nevergrad are
imported by the plugin that uses them, when it is constructed (as optuna's ``_imports.py`` and
gymnasium's ``error.DependencyNotInstalled`` do).
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

__all__ = ["DependencyNotInstalled", "import_optional", "install_hint", "is_installed"]

# Import name -> (pip distribution, extra of tooldesign that installs it).
_PACKAGES: dict[str, tuple[str, str]] = {
    "skopt": ("scikit-optimize", "bo"),
    "pyswarms": ("pyswarms", "pso"),
    "optuna": ("optuna", "optuna"),
    "cmaes": ("cmaes", "optuna"),
    "nevergrad": ("nevergrad", "nevergrad"),
}


class DependencyNotInstalled(ImportError):
    """An optional backend of an optimizer plugin is not installed."""


def install_hint(module: str) -> str:
    """The pip command that installs an optional backend.

    Args:
        module: Import name of the backend, e.g. ``"skopt"``.

    Returns:
        E.g. ``"pip install tooldesign[bo]"``, or ``"pip install <module>"`` for a module this
        package does not know.
    """
    if module in _PACKAGES:
        return f"pip install tooldesign[{_PACKAGES[module][1]}]"
    return f"pip install {module}"


def import_optional(module: str, *, purpose: str) -> ModuleType:
    """Import an optional backend or raise :class:`DependencyNotInstalled`.

    Args:
        module: Import name, e.g. ``"skopt"`` or ``"pyswarms.backend"``.
        purpose: Who needs it, for the message, e.g. ``"the 'bo' optimizer"``.

    Returns:
        The imported module.

    Raises:
        DependencyNotInstalled: The module (or a module it imports) is missing.
    """
    top = module.split(".")[0]
    try:
        importlib.import_module(top)  # a submodule already imported would hide a missing top
        return importlib.import_module(module)
    except ImportError as error:
        distribution = _PACKAGES.get(top, (top, ""))[0]
        raise DependencyNotInstalled(
            f"{purpose} needs the optional package {distribution!r}, which could not be imported "
            f"({error}); install it with `{install_hint(top)}`"
        ) from error


def is_installed(module: str) -> bool:
    """Whether a module can be imported, found without importing it.

    Args:
        module: Top-level import name, e.g. ``"skopt"``.

    Returns:
        True if the module is importable.
    """
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        # find_spec raises ValueError for a module set to None in sys.modules (blocked).
        return False
