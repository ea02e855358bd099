"""A controller's state machine as a Mermaid state diagram, and as a picture.

Built from the controller class's own table of states and transitions (``STATES`` and
``TRANSITIONS``: the paper's in ``machine.py``, grip_load's in ``grip_load.py``, any
registered controller's), so it cannot drift from the controller, with each guard's
condition in words (the controller's ``guard_words``) and the failure reason of every edge
into ``fault``. A guard without words there is described by its docstring's first line. The picture (SVG/PNG, the ``plot``
extra) draws the same graph with matplotlib: no Mermaid renderer is needed.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path

from grasp_ctrl.controller.machine import TERMINAL, GraspController
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import controller_class, settings_for

# Faults raised outside the guards, from any active state (GraspController.tick, the
# sensing pipeline, control_tick, the runner; docs/safety.md).
RUNTIME_FAULTS = (
    "sensor_stale",
    "sensor_invalid",
    "estimate_invalid",
    "goal_invalid",
    "hardware_error",
    "overforce",
    "aborted",
)


def _words(cls: type[GraspController], guard: str, known: dict[str, str]) -> str:
    """``guard``'s condition: ``known``'s words, else its docstring's first line."""
    if guard in known:
        return known[guard]
    doc = getattr(cls, guard).__doc__ or guard
    return doc.strip().splitlines()[0].rstrip(".")


@dataclass(frozen=True)
class Edge:
    src: str
    dst: str
    guard: str
    condition: str
    reason: str | None


def _controller(settings: PaperSettings | None) -> tuple[PaperSettings, type[GraspController]]:
    s = settings or settings_for("paper")
    return s, controller_class(s.controller)


def edges(settings: PaperSettings | None = None) -> list[Edge]:
    """The edges of ``settings.controller``'s state machine (the paper's by default)."""
    s, cls = _controller(settings)
    words = cls.guard_words(s)
    return [Edge(src, dst, guard, _words(cls, guard, words), reason) for src, dst, guard, reason in cls.TRANSITIONS]


def _label(e: Edge) -> str:
    text = f"{e.guard} ({e.condition})"
    return f"{text} → {e.reason}" if e.reason else text


def mermaid(settings: PaperSettings | None = None) -> str:
    """Mermaid ``stateDiagram-v2`` text: the success path first, then the fault edges."""
    s, cls = _controller(settings)
    all_edges = edges(s)
    active = [state for state in cls.STATES if state not in TERMINAL]
    lines = ["stateDiagram-v2", f"  [*] --> {cls.STATES[0]}"]
    lines += [f"  {e.src} --> {e.dst}: {_label(e)}" for e in all_edges if e.dst != "fault"]
    lines += [f"  {e.src} --> {e.dst}: {_label(e)}" for e in all_edges if e.dst == "fault"]
    guarded = {e.src for e in all_edges if e.dst == "fault"}
    for state in active:
        if state not in guarded:
            lines.append(f"  {state} --> fault: runtime fault → {', '.join(RUNTIME_FAULTS)}")
    lines += [f"  {t} --> [*]" for t in TERMINAL]
    lines += [
        "  note right of fault",
        f"    from every active state also: {', '.join(RUNTIME_FAULTS)}",
        "    then the hand's safety.on_fault action (open, hold or torque_off)",
        "  end note",
    ]
    return "\n".join(lines)


def _layout(states: list[str]) -> dict[str, tuple[float, float]]:
    """Grid positions (column, row) of the states in the picture: the success path down the
    left in the table's order, done below it, fault on the right halfway down."""
    path = [state for state in states if state not in TERMINAL]
    out: dict[str, tuple[float, float]] = {state: (0.0, float(row)) for row, state in enumerate(path)}
    out["done"] = (0.0, len(path) + 0.2)
    out["fault"] = (2.2, (len(path) - 1) / 2.0)
    return out


def draw(path: Path, settings: PaperSettings | None = None) -> Path:
    """The state machine as SVG or PNG (by the file's suffix); needs matplotlib."""
    from grasp_ctrl.display.plotting import pyplot

    plt = pyplot()
    s, cls = _controller(settings)
    all_edges = edges(s)
    layout = _layout(cls.STATES)
    rows = layout["done"][1]
    fig, ax = plt.subplots(figsize=(11.0, 1.15 * (rows + 0.8)), dpi=110)
    ax.set_xlim(-0.5, 3.3)
    ax.set_ylim(rows + 0.8, -0.8)
    ax.axis("off")
    box = {"boxstyle": "round,pad=0.4", "fc": "#eef3fb", "ec": "#4a6fa5"}
    for state, (x, y) in layout.items():
        style = (
            dict(box, fc="#f9d6d5", ec="#b03a2e")
            if state == "fault"
            else (dict(box, fc="#d5f5e3", ec="#1e8449") if state == "done" else box)
        )
        ax.text(x, y, state, ha="center", va="center", fontsize=11, bbox=style, zorder=3)
    for e in all_edges:
        (x0, y0), (x1, y1) = layout[e.src], layout[e.dst]
        fault = e.dst == "fault"
        colour = "#b03a2e" if fault else "#333333"
        ax.annotate(
            "",
            (x1, y1),
            (x0, y0),
            zorder=2,
            arrowprops={
                "arrowstyle": "-|>",
                "color": colour,
                "lw": 1.0,
                "shrinkA": 14,
                "shrinkB": 14,
                "connectionstyle": "arc3,rad=0.05" if fault else "arc3",
            },
        )
        if fault:
            # On the edge, a third of the way along (the two edges out of lower share a line).
            k = 0.55 if e.guard == "lower_exhausted" else 0.33
            tx, ty = x0 + k * (x1 - x0), y0 + k * (y1 - y0)
            ax.text(
                tx,
                ty,
                f"{e.guard} → {e.reason}",
                fontsize=7.5,
                color=colour,
                ha="center",
                va="center",
                bbox={"fc": "white", "ec": "none", "alpha": 0.85, "pad": 0.5},
                zorder=4,
            )
        else:
            ax.text(
                x0 + 0.12, (y0 + y1) / 2, f"{e.guard}\n{e.condition}", fontsize=7.5, ha="left", va="center", zorder=4
            )
    fx, fy = layout["fault"]
    ax.text(
        fx,
        fy + 0.55,
        "from every active state also:\n"
        + textwrap.fill(", ".join(RUNTIME_FAULTS), 44)
        + "\nthen safety.on_fault (open | hold | torque_off)",
        fontsize=8,
        ha="center",
        va="top",
        color="#b03a2e",
    )
    ax.set_title(f"grasp_ctrl lift-and-place controller: {s.controller}", fontsize=12)
    fig.tight_layout()
    from grasp_ctrl.files.safe_write import save_figure

    try:
        save_figure(fig, path)  # a symlink there is replaced, a stream gets the bytes
    finally:
        plt.close(fig)
    return path
