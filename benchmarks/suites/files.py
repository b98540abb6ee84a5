"""Suite files: a suite as TOML or JSON, read by :func:`load_suite`, written by :func:`save_suite`.

A file may name a built-in suite as its ``base`` and change some of its fields, and may define its
own sizes (``[sizes.smoke]``, ``[sizes.full]``). ``docs/benchmarks.md`` documents the format.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from benchmarks.storage import atomic_write_text
from benchmarks.suites.builtin import SIZES, builtin_suite
from benchmarks.suites.config import SuiteConfig, suite_from_json


def _toml_module() -> Any:
    try:
        import tomllib  # Python >= 3.11
    except ImportError:  # pragma: no cover - Python 3.10
        try:
            import tomli as tomllib
        except ImportError as err:
            raise ImportError(
                "reading TOML suite files on Python 3.10 needs tomli: `pip install tomli` "
                "(or write the suite as JSON)"
            ) from err
    return tomllib


def _read_file(path: Path) -> dict[str, Any]:
    if path.is_dir():
        raise IsADirectoryError(f"suite file {path} is a folder; give a .toml or .json file")
    if not path.exists():
        raise FileNotFoundError(f"suite file {path} does not exist")
    if not path.is_file():
        raise ValueError(f"suite file {path} is not a regular file; give a .toml or .json file")
    if path.suffix not in (".toml", ".json"):
        raise ValueError(f"suite file {path} must end in .toml or .json")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"suite file {path} is not UTF-8 text: {err}") from None
    toml = _toml_module() if path.suffix == ".toml" else None
    try:
        data: Any = toml.loads(text) if toml is not None else json.loads(text)
    except ValueError as err:  # TOMLDecodeError and JSONDecodeError are ValueErrors
        raise ValueError(
            f"suite file {path} is not valid {path.suffix[1:].upper()}: {err}"
        ) from err
    except RecursionError:  # the parsers recurse once per level of nesting
        raise ValueError(
            f"suite file {path} nests lists or tables too deeply; a suite is at most 3 deep"
        ) from None
    if not isinstance(data, dict):
        raise ValueError(f"suite file {path} must hold a table (JSON object) of suite fields")
    return data


def load_suite(path: str | os.PathLike[str], *, size: str | None = None) -> SuiteConfig:
    """Read a suite from a TOML or JSON file.

    The file holds the fields of :class:`SuiteConfig` (``[[variants]]`` and ``[[optimizers]]``
    as arrays of tables) and optionally:

    - ``base = "NAME"``: start from the built-in suite NAME at ``size`` (``full`` if none) and
      override only the fields the file sets;
    - ``[sizes.smoke]``, ``[sizes.full]`` (any names): fields that override the others when
      that size is chosen. ``full`` needs no table: it is the file's fields as they are. A
      file without ``base`` or ``[sizes]`` refuses any other size, which could change nothing.

    Args:
        path: A ``.toml`` or ``.json`` file.
        size: The size to apply, or ``None`` for the file's fields as they are.

    Returns:
        The validated suite.

    Raises:
        FileNotFoundError: If the file does not exist.
        IsADirectoryError: If it is a folder.
        ValueError: If it is not a regular file, cannot be parsed, names an unknown field, base
            or size, or a value is invalid (the message names the file and the field).
        TypeError: If a value has the wrong type.
    """
    source = Path(path)
    data = _read_file(source)
    sizes = data.pop("sizes", {})
    if not isinstance(sizes, dict) or not all(isinstance(v, dict) for v in sizes.values()):
        raise ValueError(f"{source}: sizes must be tables, e.g. [sizes.smoke]")
    base = data.pop("base", None)
    fields: dict[str, Any] = {}
    if base is not None:
        if not isinstance(base, str):
            raise ValueError(f"{source}: base must be the name of a built-in suite")
        try:
            # A size of the file's own ([sizes.quick]) starts from the base's full size.
            known = size if size in SIZES else "full"
            fields = builtin_suite(base, known).to_json()
        except ValueError as err:
            raise ValueError(f"{source}: base: {err}") from None
    fields.update(data)
    allowed = {f.name for f in dataclasses.fields(SuiteConfig)}
    for name, table in sizes.items():
        unknown = sorted(str(key) for key in set(table) - allowed)
        if unknown:
            raise ValueError(
                f"{source}: [sizes.{name}]: unknown keys [{', '.join(unknown)}]; "
                f"allowed: {sorted(allowed)}"
            )
    if size is not None and size not in sizes and size != "full":
        # "full", the default, is the file's fields as they are (over its base's full size).
        if sizes:
            raise ValueError(
                f"{source}: unknown size {size!r}; the file defines "
                f"{', '.join(sorted(sizes))} (and 'full': the file as it is)"
            )
        if base is None:
            raise ValueError(
                f"{source} defines no sizes, so --size {size} would change nothing: leave it "
                "out, add a [sizes.NAME] table, or start from a built-in suite with base = NAME"
            )
        if size not in SIZES:
            raise ValueError(f"unknown size {size!r}; sizes: {', '.join(SIZES)}")
    if size is not None:
        fields.update(sizes.get(size, {}))
    return suite_from_json(fields, where=str(source))


def _toml_value(value: Any, where: str = "") -> str:
    if value is None:
        raise ValueError(
            f"cannot write {where or 'a value'} = null to TOML (TOML has no null); save the "
            "suite as .json instead"
        )
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)  # shortest exact text; TOML floats read back bit for bit
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v, where) for v in value) + "]"
    if isinstance(value, dict):
        items = ", ".join(
            f"{json.dumps(k)} = {_toml_value(v, f'{where}.{k}' if where else str(k))}"
            for k, v in value.items()
        )
        return "{" + items + "}"
    raise TypeError(f"cannot write {where or 'a value'} = {value!r} to TOML")


def _toml_text(data: Mapping[str, Any]) -> str:
    # TOML has no null: a None field is left out, which reads back as its default (None).
    lines = []
    tables = ("variants", "optimizers")
    for key, value in data.items():
        if key in tables or value is None:
            continue
        lines.append(f"{key} = {_toml_value(value, key)}")
    for key in tables:
        for index, item in enumerate(data.get(key, [])):
            lines += ["", f"[[{key}]]"]
            lines += [
                f"{k} = {_toml_value(v, f'{key}[{index}].{k}')}"
                for k, v in item.items()
                if v is not None
            ]
    return "\n".join(lines) + "\n"


def save_suite(config: SuiteConfig, path: str | os.PathLike[str]) -> Path:
    """Write a suite as a TOML or JSON file (by suffix) that :func:`load_suite` reads back.

    Args:
        config: The suite.
        path: A ``.toml`` or ``.json`` file; written atomically.

    Returns:
        The path written.

    Raises:
        ValueError: If the suffix is neither, or a TOML file would need a null (an optimizer
            setting ``x0 = None``): the message names the field and suggests ``.json``.
    """
    if not isinstance(config, SuiteConfig):
        raise TypeError(f"config must be a SuiteConfig, got {type(config).__name__}")
    target = Path(path)
    data = config.to_json()
    if target.suffix == ".json":
        text = json.dumps(data, indent=2, allow_nan=False) + "\n"
    elif target.suffix == ".toml":
        text = _toml_text(data)
    else:
        raise ValueError(f"suite file {target} must end in .toml or .json")
    return atomic_write_text(target, text)
