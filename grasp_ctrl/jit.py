"""Optional compilation of the mock world's inner loops with numba.

The mock world must step hundreds of times faster than real time, which plain
Python cannot do for its per-fingertip contact physics. The kernels are written
as plain loops over numpy arrays: with the ``sim`` extra (numba) installed they
are compiled on first use (cached on disk); without it, or with
``GRASP_CTRL_NO_JIT=1``, the same code runs as ordinary Python, several times
slower and with the same results.
"""

from __future__ import annotations

import os
from typing import Any, Callable, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

JIT_DISABLED = os.environ.get("GRASP_CTRL_NO_JIT", "") not in ("", "0")

try:
    if JIT_DISABLED:
        raise ImportError
    import numba as _numba
except ImportError:
    _numba = None

#: True when the kernels are compiled.
JIT = _numba is not None


def njit(fn: F) -> F:
    """Compile ``fn`` in nopython mode when numba is available (cached on disk)."""
    if _numba is None:
        return fn
    return _numba.njit(cache=True, nogil=True)(fn)  # type: ignore[no-any-return]


def backend() -> str:
    """A line for bench output and logs: how the kernels run."""
    if _numba is None:
        why = "GRASP_CTRL_NO_JIT set" if JIT_DISABLED else "numba not installed (pip install -e '.[sim]')"
        return f"plain Python ({why})"
    return f"numba {_numba.__version__}"
