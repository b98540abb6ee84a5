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


#: PyBullet's packages: only the client wrapper imports them (docs/architecture.md).
_PYBULLET = {"pybullet", "pybullet_data", "pybullet_utils", "pybullet_envs"}


def _imported_roots(tree: ast.AST) -> set[str]:
    """The top-level names of every module a module imports, at any depth of its code."""
    roots: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
    return roots


def test_only_the_client_wrapper_imports_pybullet():
    """One module owns PyBullet (as panda-gym's pybullet.py does); the rest ask it.

    The robot model, the asset caches, the plan's references, the floor guard and the control
    loops reach PyBullet through :class:`tooldesign_env.bullet.BulletWorld` only.
    """
    importers = sorted(
        name
        for name, path in modules().items()
        if _imported_roots(ast.parse(path.read_text(encoding="utf-8"))) & _PYBULLET
    )
    assert importers == ["tooldesign_env.bullet"]


def test_the_pybullet_check_sees_every_way_in():
    for source in (
        "import pybullet",
        "from pybullet_utils.bullet_client import X",
        "import pybullet_data as d",
    ):
        assert _imported_roots(ast.parse(source)) & _PYBULLET
    assert not _imported_roots(ast.parse("from . import pybullet_like")) & _PYBULLET


#: A module of tooldesign_env/ longer than this says in its docstring why.
_LONG_MODULE = 600


def test_a_long_module_of_the_problem_says_why():
    for name, path in modules().items():
        if layer_of(name) != "tooldesign_env":
            continue
        text = path.read_text(encoding="utf-8")
        if text.count("\n") <= _LONG_MODULE:
            continue
        doc = ast.get_docstring(ast.parse(text)) or ""
        assert "Longer than 600 lines" in doc, (
            f"{name} has {text.count(chr(10))} lines: split it, or say in its docstring why "
            "it is longer than 600 lines"
        )


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


@pytest.mark.parametrize(
    ("old", "names", "new"),
    [
        (
            "tooldesign_env.bullet",
            ("panda_urdf_with_tool", "merged_hand_inertia", "robot_model_digest", "HAND_ROOT"),
            "tooldesign_env.robot_model",
        ),
        (
            "tooldesign_env.bullet",
            ("lean_collision_mesh", "lean_collision_meshes"),
            "tooldesign_env.lean_meshes",
        ),
        ("tooldesign_env.simulation", ("Trajectory",), "tooldesign_env.rollout"),
        ("tooldesign_env.simulation", ("contact_mobility",), "tooldesign_env.mobility"),
        ("tooldesign_env.simulation", ("floor_clearance_bound",), "tooldesign_env.floor_guard"),
        ("tooldesign_env.simulation", ("plan_cache_key",), "tooldesign_env.reference"),
        ("tooldesign_env.simulation", ("principal_inertia",), "tooldesign_env.robot_model"),
        ("tooldesign_env.objective", ("ContactEstimator",), "tooldesign_env.objective.contact"),
        ("tooldesign_env.objective", ("free_energy",), "tooldesign_env.objective.energy"),
    ],
)
def test_the_old_import_paths_of_moved_names_still_work(old, names, new):
    """The physics split and the objective package moved names (issue 30); users' imports hold."""
    import importlib

    for name in names:
        assert getattr(importlib.import_module(old), name) is getattr(
            importlib.import_module(new), name
        ), name
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        _ = importlib.import_module(old).not_a_name
