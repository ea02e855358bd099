"""Discover and run benchmark figures."""

from __future__ import annotations

import importlib
import pkgutil
import platform
from typing import Callable

import grasp_ctrl.bench as bench_pkg
from grasp_ctrl.bench.figure import Figure
from grasp_ctrl.errors import UsageError


def all_figures() -> dict[str, Callable[[bool], Figure]]:
    figures: dict[str, Callable[[bool], Figure]] = {}
    for info in pkgutil.iter_modules(bench_pkg.__path__):
        if info.name.startswith("fig_"):
            mod = importlib.import_module(f"{bench_pkg.__name__}.{info.name}")
            figures.update(mod.FIGURES)
    return dict(sorted(figures.items()))


def machine_description() -> str:
    import os

    from grasp_ctrl import jit

    return (f"{platform.node()} {platform.machine()} {os.cpu_count()} cpu {platform.python_implementation()} "
            f"{platform.python_version()}, mock-world kernels: {jit.backend()}")


def run_figures(only: list[str] | None, quick: bool) -> dict[str, Figure]:
    figures = all_figures()
    names = list(figures) if not only else only
    unknown = [n for n in names if n not in figures]
    if unknown:
        raise UsageError(f"--only: unknown figure {unknown[0]!r} (known: {', '.join(figures)})")
    return {n: figures[n](quick) for n in names}
