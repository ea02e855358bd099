"""Discover and run benchmark figures."""

from __future__ import annotations

import importlib
import pkgutil
import platform
from collections.abc import Callable

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

    from grasp_ctrl.numeric import jit

    return (
        f"{platform.node()} {platform.machine()} {os.cpu_count()} cpu {platform.python_implementation()} "
        f"{platform.python_version()}, mock-world kernels: {jit.backend()}"
    )


def run_figures(only: list[str] | None, quick: bool, progress: bool = False) -> dict[str, Figure]:
    """The figures by name; ``progress``: a one-line bar on a terminal (the figure being measured)."""
    from grasp_ctrl.display.progress_bar import progress_bar

    figures = all_figures()
    names = list(figures) if not only else only
    unknown = [n for n in names if n not in figures]
    if unknown:
        raise UsageError(f"--only: unknown figure {unknown[0]!r} (known: {', '.join(figures)})")
    results = {}
    with progress_bar(len(names), "bench", progress, unit="figure", every_update=True) as bar:
        for n in names:
            bar.set_postfix_str(n)
            results[n] = figures[n](quick)
            bar.update(1)
    return results
