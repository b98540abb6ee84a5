"""The layout is the architecture: no import cycle, arrows one way, one place parses arguments."""

from __future__ import annotations

import ast
import subprocess
import sys

import pytest
from import_graph import LAYERS, ROOT, graph, layer_of, modules, package_graph


def _cycle(edges: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_no_module_import_cycle():
    assert _cycle(graph()) is None


def test_no_layer_cycle_and_every_arrow_points_down():
    edges = package_graph()
    assert _cycle(edges) is None
    for source, targets in edges.items():
        for target in targets:
            if source in LAYERS and target in LAYERS:
                assert LAYERS[target] < LAYERS[source], f"{source} imports {target}"


@pytest.mark.parametrize("package", ["optimizers", "tooldesign_env"])
def test_the_bottom_packages_import_nothing_above_them(package):
    for module, targets in graph().items():
        if layer_of(module) == package:
            assert {layer_of(t) for t in targets} <= {package}, module


@pytest.mark.slow
def test_optimizers_never_import_pybullet():
    """Nothing under optimizers/ loads PyBullet or the rest of the project, however indirectly."""
    names = sorted(n for n in modules() if n.split(".")[0] == "optimizers")
    code = "\n".join(
        [
            "import importlib, sys",
            f"for name in {names!r}:",
            "    importlib.import_module(name)",
            "print(sorted(m for m in sys.modules",
            "             if m.split('.')[0] in ('pybullet', 'tooldesign_env', 'benchmarks')))",
        ]
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", out.stdout


#: Modules that read a command line; only the command line's layer may use them.
_PARSERS = {"argparse", "optparse", "getopt", "click", "typer", "docopt", "fire"}


def _parses_arguments(tree: ast.AST) -> str | None:
    """What in a module reads the command line: a parser's import or ``sys.argv``, or None."""
    sys_names = {"sys"}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in _PARSERS:
                    return alias.name
                if alias.name == "sys":
                    sys_names.add(alias.asname or "sys")
        elif isinstance(node, ast.ImportFrom) and node.module:
            if node.module.split(".")[0] in _PARSERS:
                return node.module
            if node.module == "sys" and any(a.name == "argv" for a in node.names):
                return "sys.argv"
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and node.attr in {"argv", "orig_argv"}
            and isinstance(node.value, ast.Name)
            and node.value.id in sys_names
        ):
            return f"sys.{node.attr}"
    return None


def test_only_the_command_line_parses_arguments():
    for name, path in modules().items():
        found = _parses_arguments(ast.parse(path.read_text(encoding="utf-8")))
        assert found is None or layer_of(name) == "benchmarks.cli", f"{name} uses {found}"


@pytest.mark.parametrize(
    "source",
    [
        "import argparse",
        "from click import command",
        "import sys as _s\nargs = _s.argv[1:]",
        "from sys import argv",
        "import getopt",
    ],
)
def test_the_argument_check_sees_every_way_in(source):
    assert _parses_arguments(ast.parse(source)) is not None
    assert _parses_arguments(ast.parse("import sys\nsys.exit(0)")) is None


@pytest.mark.slow
def test_the_graph_sees_the_real_imports():
    # A guard of the guards: the graph must find the arrows we know are there.
    edges = package_graph()
    assert "benchmarks.storage" in edges["benchmarks.design"]
    assert "benchmarks.execution" in edges["benchmarks.suites"]
    assert "benchmarks.reports" in edges["benchmarks.cli"]
    # relative imports: optimizers/ uses nothing else
    assert "optimizers.base" in graph()["optimizers.cmaes"]
    # entry points belong to the command line's layer
    assert layer_of("benchmarks.rl.__main__") == "benchmarks.cli"


@pytest.mark.slow
@pytest.mark.parametrize("module", ["tooldesign_env.schema", "tooldesign_env.specs"])
def test_the_defaults_and_names_load_without_the_simulator(module):
    """The storage layer reads schema and specs; they must not pull in PyBullet or trimesh."""
    code = (
        f"import sys, {module}, tooldesign_env\n"
        "print(sorted(m for m in ('pybullet', 'trimesh', 'scipy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_the_package_names_resolve_on_first_use():
    import tooldesign_env

    for name in tooldesign_env.__all__:
        assert getattr(tooldesign_env, name) is not None, name
    assert set(tooldesign_env.__all__) <= set(dir(tooldesign_env))
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        _ = tooldesign_env.not_a_name


@pytest.mark.slow
@pytest.mark.parametrize(
    ("package", "attribute"),
    [
        ("tooldesign_env", "env.SERIES_KEYS"),
        ("tooldesign_env", "native.status"),
        ("benchmarks.reports", "comparison.make_report"),
        ("benchmarks.design", "config.RECORDED_SCENE_FIELDS"),
    ],
)
def test_a_lazy_package_still_reaches_its_submodules_as_attributes(package, attribute):
    """``import tooldesign_env; tooldesign_env.env.X``, as the docs write it, in a fresh process."""
    code = f"import {package} as p\nprint(p.{attribute} is not None)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
