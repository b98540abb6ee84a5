"""Names to optimizer plugins: built-ins, :func:`register`, entry points and ``"module:Class"``.

:func:`make` resolves a name in this order:

1. a name given to :func:`register` (the built-ins are registered this way);
2. a ``"module:Class"`` string (any callable returning an :class:`~optimizers.base.Optimizer`);
3. an entry point of the group ``tooldesign.optimizers`` of an installed package, loaded only
   when selected (as gymnasium's ``load_env_creator`` does).

Built-ins whose optional backend is missing are left out of :func:`available`, and
:func:`make` names the pip extra that installs them.
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import inspect
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ._imports import DependencyNotInstalled, install_hint, is_installed
from .base import Optimizer, PluginError

__all__ = ["ENTRY_POINT_GROUP", "available", "make", "register"]

ENTRY_POINT_GROUP = "tooldesign.optimizers"

Factory = Callable[..., Optimizer]

_SPEC = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")


@dataclass(frozen=True)
class _Entry:
    target: Factory | str  # a callable, or "module:attr" imported when made
    requires: tuple[str, ...] = ()  # top-level modules that must be importable


_REGISTRY: dict[str, _Entry] = {}


def register(name: str, cls_or_factory: Factory | str, *, requires: tuple[str, ...] = ()) -> None:
    """Make an optimizer available under ``name``.

    Args:
        name: The name for :func:`make`, without ``":"`` (that marks ``"module:Class"``).
        cls_or_factory: An :class:`~optimizers.base.Optimizer` subclass, a callable taking its
            keyword arguments (``bounds``, ``batch_size``, ``seed``, ...) and returning one, or
            a ``"module:attr"`` string naming such a callable, imported only when made.
        requires: Top-level modules the plugin needs; while one is missing the name is left out
            of :func:`available`.

    Raises:
        TypeError: A name that is not a str, or a target that is neither callable nor a
            ``"module:attr"`` string.
        ValueError: An empty name, a name with ``":"``, or a name already registered.
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {name!r}")
    if not name.strip() or name != name.strip() or ":" in name:
        raise ValueError(
            f"name must be non-empty, without surrounding spaces and without ':', got {name!r}"
        )
    if name in _REGISTRY:
        raise ValueError(f"an optimizer named {name!r} is already registered")
    if isinstance(cls_or_factory, str):
        if not _SPEC.match(cls_or_factory):
            raise ValueError(f"a target string must be 'module:attr', got {cls_or_factory!r}")
    elif not callable(cls_or_factory):
        raise TypeError(
            "cls_or_factory must be an Optimizer subclass, a factory or a 'module:attr' string, "
            f"got {cls_or_factory!r}"
        )
    if not isinstance(requires, tuple) or not all(isinstance(m, str) for m in requires):
        raise TypeError(f"requires must be a tuple of module names, got {requires!r}")
    _REGISTRY[name] = _Entry(cls_or_factory, requires)


def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    """Installed plugins by name; nothing is imported."""
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)}


def available() -> list[str]:
    """Names :func:`make` accepts: registered ones whose backends are installed, and entry points.

    Returns:
        Sorted names. ``"module:Class"`` strings are accepted too but not listed.
    """
    names = {n for n, e in _REGISTRY.items() if all(is_installed(m) for m in e.requires)}
    return sorted(names | _entry_points().keys())


def _import_target(spec: str, origin: str) -> Any:
    module_name, _, attr = spec.partition(":")
    try:
        target: Any = importlib.import_module(module_name)
    except ImportError as error:
        if isinstance(error, DependencyNotInstalled):
            raise
        raise ImportError(f"cannot import module {module_name!r} of {origin}: {error}") from error
    except Exception as error:  # the plugin's module itself fails: a bug of the plugin
        raise PluginError(
            f"importing module {module_name!r} of {origin} raised {type(error).__name__}: {error}"
        ) from error
    for part in attr.split("."):
        try:
            target = getattr(target, part)
        except AttributeError:
            raise ImportError(f"module {module_name!r} has no {attr!r} ({origin})") from None
    return target


def _resolve(name: str) -> Any:
    if name in _REGISTRY:
        entry = _REGISTRY[name]
        for module in entry.requires:
            if not is_installed(module):
                raise DependencyNotInstalled(
                    f"the optimizer {name!r} needs the optional package {module!r}: install it "
                    f"with `{install_hint(module)}`"
                )
        if isinstance(entry.target, str):
            return _import_target(entry.target, f"optimizer {name!r}")
        return entry.target
    if ":" in name:
        if not _SPEC.match(name):
            raise ValueError(f"a plugin string must be 'module:Class', got {name!r}")
        return _import_target(name, f"plugin string {name!r}")
    entry_points = _entry_points()
    if name in entry_points:
        ep = entry_points[name]
        try:
            return ep.load()
        except ImportError as error:
            raise ImportError(
                f"cannot load optimizer {name!r} from entry point {ep.value!r} (group "
                f"{ENTRY_POINT_GROUP!r}): {error}"
            ) from error
        except Exception as error:  # the plugin's module itself fails: a bug of the plugin
            raise PluginError(
                f"loading optimizer plugin {name!r} from entry point {ep.value!r} raised "
                f"{type(error).__name__}: {error}"
            ) from error
    raise ValueError(
        f"unknown optimizer {name!r}; available: {', '.join(available())} (or a 'module:Class' "
        "string)"
    )


def _factory_name(factory: Any) -> str:
    """``MODULE.CLASS.__init__`` of a plugin class, ``MODULE.NAME`` of another factory."""
    target = factory.func if isinstance(factory, functools.partial) else factory
    module = getattr(target, "__module__", None)
    name = getattr(target, "__qualname__", None)
    if not (isinstance(module, str) and isinstance(name, str)):
        return repr(factory)
    return f"{module}.{name}.__init__" if isinstance(target, type) else f"{module}.{name}"


def make(name_or_spec: str, **kwargs: Any) -> Optimizer:
    """Build an optimizer by name.

    Args:
        name_or_spec: A name from :func:`available`, or ``"module:Class"``.
        **kwargs: Passed to the plugin: ``bounds`` ((d, 2) in physical units), ``batch_size``,
            ``seed`` and its own settings.

    Returns:
        The optimizer.

    Raises:
        TypeError: name_or_spec is not a str, names a class that is not an Optimizer subclass,
            or the plugin did not return an Optimizer.
        ValueError: Unknown name or malformed ``"module:Class"``.
        DependencyNotInstalled: The plugin's optional backend is missing (the message names the
            pip extra).
        ImportError: The plugin's module or entry point cannot be imported.
        OverflowError: A setting too large for the backend to convert.
        PluginError: The plugin's ``__init__`` (or factory) raised another exception, a bug
            of the plugin; the message names it (``optimizer plugin MODULE.CLASS.__init__
            raised ...``) and the original exception is the ``__cause__``.
    """
    if not isinstance(name_or_spec, str):
        raise TypeError(f"name_or_spec must be a str, got {name_or_spec!r}")
    if name_or_spec in _REGISTRY and name_or_spec in _entry_points():
        warnings.warn(
            f"the entry point {name_or_spec!r} is shadowed by the registered optimizer of that "
            "name",
            RuntimeWarning,
            stacklevel=2,
        )
    factory = _resolve(name_or_spec)
    if not callable(factory):
        raise TypeError(
            f"optimizer {name_or_spec!r} resolves to {factory!r}, which is not callable"
        )
    if isinstance(factory, type) and not issubclass(factory, Optimizer):
        # Called with the harness's keywords it would fail on the first one ("has no setting
        # 'bounds'"), which hides that the name points at something that is no optimizer.
        raise TypeError(
            f"optimizer {name_or_spec!r} is the class {factory.__module__}.{factory.__qualname__}"
            ", not an ask/tell optimizer: give a registered name or the 'module:Class' of an "
            "optimizers.Optimizer subclass (docs/optimizer-plugins.md)"
        )
    try:
        optimizer = factory(**kwargs)
    except TypeError as error:
        unknown = re.search(r"unexpected keyword argument '(\w+)'", str(error))
        if unknown is None or unknown.group(1) not in kwargs:
            raise
        raise TypeError(
            f"optimizer {name_or_spec!r} has no setting {unknown.group(1)!r}; its settings: "
            f"{', '.join(_settings_of(factory)) or 'none'}"
        ) from error
    except (ValueError, OverflowError, ImportError, PluginError):
        # Bad settings (OverflowError: a number too large for the backend) or a missing
        # backend: the plugin's own message says which, and the CLI calls it bad input.
        raise
    except Exception as error:
        raise PluginError(
            f"optimizer plugin {_factory_name(factory)} raised {type(error).__name__}: {error}"
        ) from error
    if not isinstance(optimizer, Optimizer):
        raise TypeError(
            f"optimizer {name_or_spec!r} returned a {type(optimizer).__name__}, not an "
            "optimizers.Optimizer"
        )
    return optimizer


def _settings_of(factory: Any) -> list[str]:
    """The keywords ``factory`` takes, the base class's included when it passes ``**kwargs`` on."""
    names: list[str] = []
    try:
        parameters = list(inspect.signature(factory).parameters.values())
    except (TypeError, ValueError):  # pragma: no cover - a builtin without a signature
        return names
    for parameter in parameters:
        if parameter.kind is parameter.VAR_KEYWORD:
            if isinstance(factory, type) and issubclass(factory, Optimizer):
                names += [n for n in _settings_of(Optimizer) if n not in names]
        elif parameter.kind is not parameter.VAR_POSITIONAL and parameter.name != "self":
            names.append(parameter.name)
    return names


register("cmaes", "optimizers.cmaes:CMAES", requires=("cma",))
register("bo", "optimizers.bo:BayesianOptimization", requires=("skopt",))
register("pso", "optimizers.pso:ParticleSwarm", requires=("pyswarms",))
register("random", "optimizers.random_search:RandomSearch")
register("optuna-tpe", "optimizers.optuna_adapter:OptunaTPE", requires=("optuna",))
register("optuna-cmaes", "optimizers.optuna_adapter:OptunaCMAES", requires=("optuna", "cmaes"))
register("nevergrad", "optimizers.nevergrad_adapter:NevergradOptimizer", requires=("nevergrad",))
