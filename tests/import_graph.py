"""The import graph of the project's packages, read from the source with ``ast`` (nothing run).

Used by ``tests/test_architecture.py`` (no cycle, the layers' arrows point one way, no argument
parsing outside the command line) and by ``python tests/import_graph.py --draw`` , which draws
``docs/images/architecture.png``: the layers of docs/architecture.md with their real arrows.
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("tooldesign_env", "optimizers", "benchmarks")

#: The layers, lowest first. A layer may import the layers below it, never one above.
LAYERS: dict[str, int] = {
    "tooldesign_env": 0,
    "optimizers": 0,
    "benchmarks.storage": 1,
    "benchmarks.execution": 1,
    "benchmarks.design": 2,
    "benchmarks.suites": 3,
    "benchmarks.rl": 4,
    "benchmarks.reports": 5,
    "benchmarks.protocol": 6,
    "benchmarks.cli": 7,
}


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    """Every module of the three packages, by dotted name, ``python -m`` entry points included.

    The developer scripts of ``perf/`` are outside the packages (not installed), so not here.
    """
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            out[module_name(path)] = path
    return out


def _absolute(node: ast.ImportFrom, module: str, path: Path) -> str | None:
    """The absolute name of what a ``from ... import`` reads, relative imports resolved."""
    if node.level == 0:
        return node.module
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    base = package[: len(package) - (node.level - 1)]
    if len(base) < 1:
        return None  # above the top-level package: Python refuses it too
    return ".".join([*base, node.module] if node.module else base)


def imports(path: Path, known: set[str]) -> set[str]:
    """The project modules a module imports (at any depth of its code).

    ``from package import submodule`` imports the submodule (Python runs the package's
    ``__init__`` first, but that is the package's dependency, not this module's).
    """
    found: set[str] = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    module = module_name(path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            source = _absolute(node, module, path)
            if source is None:
                continue
            submodules = {f"{source}.{a.name}" for a in node.names} & known
            found.update(submodules)
            if len(submodules) < len(node.names):
                found.add(source)
    return {name for name in found if name.split(".")[0] in PACKAGES}


def graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports (names that are modules)."""
    known = modules()
    names = set(known)
    return {name: (imports(path, names) & names) - {name} for name, path in known.items()}


def layer_of(module: str) -> str:
    """The layer (a key of :data:`LAYERS`) a module belongs to.

    A ``__main__`` module is an entry point: it hands ``sys.argv`` to the command line, so it
    sits in the command line's layer, whatever package it is in.
    """
    if module.endswith(".__main__"):
        return "benchmarks.cli"
    for key in sorted(LAYERS, key=len, reverse=True):
        if module == key or module.startswith(key + "."):
            return key
    return "benchmarks"  # the package's own __init__ / __main__


def package_graph() -> dict[str, set[str]]:
    edges: dict[str, set[str]] = defaultdict(set)
    for source, targets in graph().items():
        for target in targets:
            a, b = layer_of(source), layer_of(target)
            if a != b:
                edges[a].add(b)
    return edges


def draw(out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    edges = package_graph()
    rows: dict[int, list[str]] = defaultdict(list)
    for name, level in LAYERS.items():
        rows[level].append(name)
    pos = {}
    for level, names in rows.items():
        for k, name in enumerate(names):
            pos[name] = ((k + 1) / (len(names) + 1), level)
    notes = {
        "tooldesign_env": "the problem: geometry, PyBullet world,\ncontroller, objective, env",
        "optimizers": "ask/tell plugins\n(numbers only, no PyBullet)",
        "benchmarks.storage": "run folders: atomic files,\nmanifest, resume",
        "benchmarks.execution": "executors, evaluator,\nscheduler",
        "benchmarks.design": "Algorithm 1: design a tool",
        "benchmarks.suites": "declared suites, runner, retest",
        "benchmarks.rl": "RL baselines: agents,\nrl suite, saved policies",
        "benchmarks.reports": "tables, figures, pages\nfrom stored results only",
        "benchmarks.cli": "tooldesign: the only\nargument parsing",
    }
    fig, ax = plt.subplots(figsize=(10, 8))
    for source, targets in edges.items():
        for target in targets:
            if source not in pos or target not in pos:
                continue
            (x0, y0), (x1, y1) = pos[source], pos[target]
            ax.annotate(
                "",
                xy=(x1, y1 + 0.18),
                xytext=(x0, y0 - 0.18),
                arrowprops={"arrowstyle": "-|>", "color": "0.45", "lw": 0.8},
            )
    for name, (x, y) in pos.items():
        ax.text(
            x,
            y,
            f"{name}\n{notes.get(name, '')}",
            ha="center",
            va="center",
            fontsize=8.5,
            bbox={"boxstyle": "round", "facecolor": "#eef3fb", "edgecolor": "#4a6fa5"},
        )
    ax.set_xlim(0, 1)
    ax.set_ylim(-0.6, max(LAYERS.values()) + 0.6)
    ax.set_axis_off()
    ax.set_title("Layers of the project: every arrow is an import, and every arrow points down")
    fig.savefig(out, dpi=110, bbox_inches="tight", metadata={"Software": None})


if __name__ == "__main__":
    if "--draw" in sys.argv:
        draw(ROOT / "docs" / "images" / "architecture.png")
        print("wrote docs/images/architecture.png")
