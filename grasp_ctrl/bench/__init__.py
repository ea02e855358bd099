"""Benchmarks (``python launch.py bench``, docs/design.md 5.6).

Each ``grasp_ctrl/bench/fig_<topic>.py`` module exposes ``FIGURES``: a dict
from a stable figure name to a function ``measure(quick: bool) -> Figure``.
They are discovered automatically, so a new figure touches no shared file.
"""
