"""The layout is the architecture: no import cycle, arrows one way, one place parses arguments."""

from __future__ import annotations

import ast

import pytest
from import_graph import LAYERS, graph, layer_of, modules, package_graph


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


def test_optimizers_never_import_pybullet():
    for name, path in modules().items():
        if name.startswith("optimizers"):
            assert "pybullet" not in path.read_text(encoding="utf-8"), name


def test_only_the_command_line_parses_arguments():
    for name, path in modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        uses = any(
            isinstance(n, (ast.Import, ast.ImportFrom))
            and any(a.name == "argparse" for a in n.names)
            or isinstance(n, ast.ImportFrom)
            and n.module == "argparse"
            for n in ast.walk(tree)
        )
        assert not uses or name.startswith("benchmarks.cli"), name


def test_the_graph_sees_the_real_imports():
    # A guard of the guards: the graph must find the arrows we know are there.
    edges = package_graph()
    assert "benchmarks.storage" in edges["benchmarks.design"]
    assert "benchmarks.execution" in edges["benchmarks.suites"]
    assert "benchmarks.reports" in edges["benchmarks.cli"]
