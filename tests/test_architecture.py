"""The package's layering: no two subpackages of grasp_ctrl import each other, directly or
through others, counting imports inside functions (docs/design.md, section 2)."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "grasp_ctrl"


def _unit(dotted: str) -> str | None:
    """grasp_ctrl.X.Y -> X (a subpackage or a top-level module)."""
    parts = dotted.split(".")
    if parts[0] != "grasp_ctrl" or len(parts) < 2:
        return None
    return parts[1]


def import_graph() -> dict[str, dict[str, list[str]]]:
    """unit -> imported unit -> the places (file:line) that import it."""
    graph: dict[str, dict[str, list[str]]] = defaultdict(lambda: defaultdict(list))
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        me = rel.parts[1]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level:
                targets = [".".join(rel.parts[: -node.level] + ((node.module,) if node.module else ()))]
            else:
                continue
            for target in targets:
                unit = _unit(target)
                if unit and unit != me and ((PACKAGE / unit).is_dir() or (PACKAGE / f"{unit}.py").is_file()):
                    graph[me][unit].append(f"{rel}.py:{node.lineno}")
    return graph


def cycles(graph: dict[str, dict[str, list[str]]]) -> list[list[str]]:
    """The strongly connected components with more than one unit (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in list(graph.get(v, {})):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in list(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycle_between_subpackages():
    graph = import_graph()
    found = cycles(graph)
    detail = [f"{a} -> {b}: {graph[a][b][:3]}" for c in found for a in c for b in c if b in graph.get(a, {})]
    assert not found, "\n".join(detail)


def test_the_cycle_finder_finds_a_cycle():
    graph = {"a": {"b": ["x"]}, "b": {"c": ["y"]}, "c": {"a": ["z"]}, "d": {"a": ["w"]}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b": ["x"]}, "b": {}}) == []


def test_the_control_loop_sits_beneath_the_trials():
    graph = import_graph()
    for low in ("loop", "controller", "sim", "hardware", "estimators", "tactile", "kinematics"):
        assert "trials" not in graph.get(low, {}), f"{low} imports trials: {graph[low]['trials'][:3]}"
        assert "cli" not in graph.get(low, {}), f"{low} imports cli"
