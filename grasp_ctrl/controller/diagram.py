"""The controller's state machine as Mermaid, from transitions' own graph support."""

from __future__ import annotations

from transitions.extensions import GraphMachine

from grasp_ctrl.controller.machine import build_machine


class _Model:
    """A stand-in model: the diagram needs the structure, not the guards' logic."""


def mermaid() -> str:
    model = _Model()
    machine = build_machine(
        model, machine_cls=GraphMachine, graph_engine="mermaid", show_conditions=True,
        title="grasp_ctrl lift-and-place controller",
    )
    return str(machine.get_graph().draw(None))
