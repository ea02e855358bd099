"""matplotlib, imported only when a chart is drawn (the ``plot`` extra), without a display."""

from __future__ import annotations

from typing import Any

from grasp_ctrl.errors import UsageError


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend, or a one-line error naming the extra."""
    try:
        import matplotlib
    except ImportError:
        raise UsageError("charts need matplotlib: pip install -e '.[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
