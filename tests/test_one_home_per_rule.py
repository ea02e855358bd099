"""Rules that every backend shares are written once: gravity's value (numeric/gravity.py), the
arm's palm-height clamp and the joint-goal limiter (numeric/limits.py). A second copy elsewhere
in grasp_ctrl fails here, naming where."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "grasp_ctrl"


def _sources() -> list[tuple[str, ast.AST]]:
    return [(str(p.relative_to(PACKAGE)), ast.parse(p.read_text(), str(p))) for p in sorted(PACKAGE.rglob("*.py"))]


def _names_in(node: ast.AST) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} | {
        n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute)
    }


def _called(node: ast.Call) -> str:
    return node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")


def test_gravity_has_one_value():
    places = [
        f"{rel}:{node.lineno}"
        for rel, tree in _sources()
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, float) and node.value in (9.81, 9.80665)
    ]
    assert places == ["numeric/gravity.py:3"], places


def test_the_palm_height_is_clamped_in_one_place():
    """No clip, or min of a max, of a value against the arm's z range outside numeric/limits.py."""
    places = []
    for rel, tree in _sources():
        if rel == "numeric/limits.py":
            continue
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            name = _called(node)
            nested = name in ("min", "minimum") and any(
                isinstance(a, ast.Call) and _called(a) in ("max", "maximum") for a in node.args
            )
            if name in ("clip", "clamp") or nested:
                bounds = {n for a in node.args for n in _names_in(a)}
                if bounds & {"z_min", "z_max", "z_min_m", "z_max_m", "_z_min", "_z_max"}:
                    places.append(f"{rel}:{node.lineno}")
    assert places == [], places


def test_the_goal_step_limit_is_written_once():
    """``prev - max_step`` / ``prev + max_step`` bounds (the goal limiter's window) appear only
    in numeric/limits.py."""
    places = []
    for rel, tree in _sources():
        if rel == "numeric/limits.py":
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
                if any(
                    isinstance(side, (ast.Name, ast.Attribute)) and "max_step" in ast.unparse(side)
                    for side in (node.right,)
                ):
                    if (
                        isinstance(node.op, ast.Sub)
                        or "prev" in ast.unparse(node.left)
                        or "last" in ast.unparse(node.left)
                    ):
                        places.append(f"{rel}:{node.lineno}: {ast.unparse(node)}")
    assert places == [], places
