"""The package's layering: no two subpackages of grasp_ctrl import each other, directly or
through others, counting imports inside functions (docs/design.md, section 2)."""

from __future__ import annotations

import ast
import functools
from collections import defaultdict
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "grasp_ctrl"


def _unit(dotted: str) -> str | None:
    """grasp_ctrl.X.Y -> X (a subpackage or a top-level module)."""
    parts = dotted.split(".")
    if parts[0] != "grasp_ctrl" or len(parts) < 2:
        return None
    return parts[1]


@functools.cache  # the package's sources do not change during a test session
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


def _module_of(dotted: str) -> str | None:
    """The package's module that ``dotted`` names (a package is its __init__), or None."""
    if not dotted.startswith("grasp_ctrl"):
        return None
    path = PACKAGE.parent.joinpath(*dotted.split("."))
    if path.with_suffix(".py").is_file():
        return dotted
    if (path / "__init__.py").is_file():
        return f"{dotted}.__init__"
    return None


def _runtime_imports(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement, inside functions too, except under ``if TYPE_CHECKING:``."""
    found: list[ast.Import | ast.ImportFrom] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import | ast.ImportFrom):
            found.append(node)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


@functools.cache
def module_graph() -> dict[str, dict[str, list[str]]]:
    """module -> imported module -> the lines that import it (a package's __init__ is a module)."""
    graph: dict[str, dict[str, list[str]]] = defaultdict(lambda: defaultdict(list))
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        me = ".".join(rel.parts)
        package = rel.parts[:-1] if rel.name != "__init__" else rel.parts[:-1]
        for node in _runtime_imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                base = node.module or ""
                if node.level:
                    up = package[: len(package) - (node.level - 1)]
                    base = ".".join(up + ((base,) if base else ()))
                targets = [f"{base}.{a.name}" if _module_of(f"{base}.{a.name}") else base for a in node.names]
            for target in targets:
                module = _module_of(target)
                if module and module != me:
                    graph[me][module].append(f"{rel}.py:{node.lineno}")
    return graph


def test_no_import_cycle_between_modules():
    """No circle of imports between modules, counting imports inside functions (a lazy import
    hides a circle from the interpreter, not from the reader)."""
    graph = module_graph()
    found = cycles(graph)
    detail = [f"{a} -> {b}: {graph[a][b][:2]}" for c in found for a in c for b in c if b in graph.get(a, {})]
    assert not found, "\n".join(detail)


def test_the_module_graph_reads_relative_and_package_imports():
    graph = module_graph()
    assert "grasp_ctrl.controller.machine" in graph["grasp_ctrl.controller.grip_load"]
    assert any(m.startswith("grasp_ctrl.numeric.") for m in graph["grasp_ctrl.controller.machine"])


def test_each_world_and_the_sensor_model_stand_alone():
    """The mock world, the MuJoCo world and the BioTac model import none of each other's modules
    except the sensor model (both worlds render frames with it); the shared pieces live in
    sim/world_parts.py, sim/world_api.py and sim/world_backends.py."""
    graph = module_graph()
    packages = {"mock": "grasp_ctrl.sim.mock.", "mujoco": "grasp_ctrl.sim.mujoco.", "biotac": "grasp_ctrl.sim.biotac."}
    allowed = {("mock", "biotac"), ("mujoco", "biotac")}
    for me, prefix in packages.items():
        for module, imported in graph.items():
            if not module.startswith(prefix):
                continue
            for other, other_prefix in packages.items():
                if other == me or (me, other) in allowed:
                    continue
                bad = [t for t in imported if t.startswith(other_prefix)]
                assert not bad, f"{module} imports {bad} ({imported[bad[0]][:1]})"


DESIGN = PACKAGE.parent / "docs" / "design.md"


def documented_layers() -> list[set[str]]:
    """docs/design.md's layer table, in its order: the subpackages (and root modules) each row
    names in its second column (``trials/episode/`` counts as ``trials``)."""
    import re

    lines = DESIGN.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| layer |"))
    layers: list[set[str]] = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        column = line.split("|")[2]
        layers.append({name.split("/")[0] for name in re.findall(r"`([a-z_]+)/?[^`]*`", column)})
    return layers


def layer_breaks(graph: dict[str, dict[str, list[str]]], layers: list[set[str]]) -> list[str]:
    """Each import of a subpackage from a later layer (the table lists the lowest first)."""
    rank = {unit: i for i, layer in enumerate(layers) for unit in layer}
    return [
        f"{a} (layer {rank[a]}) imports {b} (layer {rank[b]}): {graph[a][b][:2]}"
        for a in sorted(graph)
        for b in sorted(graph[a])
        if a in rank and b in rank and rank[b] > rank[a]
    ]


def test_imports_follow_the_documented_layers():
    layers = documented_layers()
    units = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    units |= {p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"}
    placed = set().union(*layers)
    assert units <= placed, f"not in docs/design.md's layer table: {sorted(units - placed)}"
    breaks = layer_breaks(import_graph(), layers)
    assert not breaks, "\n".join(breaks)


def test_the_layer_check_finds_an_upward_import():
    layers = [{"config"}, {"tactile"}, {"cli"}]
    assert layer_breaks({"config": {"tactile": ["grasp_ctrl/config/hand.py:1"]}}, layers) == [
        "config (layer 0) imports tactile (layer 1): ['grasp_ctrl/config/hand.py:1']"
    ]
    assert layer_breaks({"cli": {"config": ["x"]}, "tactile": {"tactile": ["y"]}}, layers) == []
