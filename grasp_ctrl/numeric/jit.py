"""Optional compilation of the mock world's inner loops (and the control tick's) with numba.

The mock world must step hundreds of times faster than real time, which plain
Python cannot do for its per-fingertip contact physics. The kernels are written
as plain loops over numpy arrays: with the ``sim`` extra (numba) installed they
are compiled on first use (about 10 s, then cached on disk); without it, or
with ``GRASP_CTRL_NO_JIT=1``, the same code runs as ordinary Python, about ten
times slower and with the same results.

The control tick uses a few small kernels too (tare and contact gate, pad IK,
force rotation, goal limits, finiteness checks), each replacing several numpy
calls on 4- or 16-element arrays whose call overhead is most of their cost.
Those callers check ``JIT`` and use their numpy code without numba (same
results, bit for bit, tests/loop/test_tick_kernels.py).

numba's cache notices edits to a kernel's own file but not to the kernels it
calls from other files, so the cache lives in a folder named after a hash of
every kernel source (``~/.cache/grasp_ctrl/numba/...``, or ``NUMBA_CACHE_DIR``
when set): any edit compiles afresh.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar, overload

F = TypeVar("F", bound=Callable[..., Any])

JIT_DISABLED = os.environ.get("GRASP_CTRL_NO_JIT", "") not in ("", "0")

_numba: ModuleType | None  # numba, when installed and not disabled
try:
    if JIT_DISABLED:
        raise ImportError
    import numba as _numba
except ImportError:
    from grasp_ctrl.errors import reraise_interrupt

    reraise_interrupt()  # a Ctrl-C or SIGTERM inside numba's import is not a missing numba
    _numba = None

#: True when the kernels are compiled.
JIT = _numba is not None

#: Modules that define compiled kernels (relative to the package).
KERNEL_SOURCES = (
    "numeric/jit.py",
    "sim/mock/world_step.py",
    "sim/mock/shapes.py",
    "sim/mock/grip.py",
    "sim/biotac/model.py",
    "kinematics/fingertip.py",
    "kinematics/multilinear.py",
    "kinematics/pad_ik_kernels.py",
    "kinematics/chain_packing.py",
    "kinematics/stiffness_squeeze.py",
    "kinematics/sensor_frame_kernels.py",
    "numeric/limits.py",
    "tactile/tare.py",
    "numeric/finite.py",
    "sim/mock/backends.py",
    "sim/world_backends.py",
    "sim/world_parts.py",
    "loop/loop_kernels.py",
    "sim/mock/world.py",
    "sim/mujoco/tick_kernel.py",
    "estimators/linear.py",
    "estimators/mlp.py",
)


def _cache_dir(numba_version: str) -> Path:
    package = Path(__file__).resolve().parents[1]  # grasp_ctrl/
    digest = hashlib.sha256()
    for rel in KERNEL_SOURCES:
        digest.update((package / rel).read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "grasp_ctrl" / "numba" / f"{numba_version}-{digest.hexdigest()[:16]}"


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


if _numba is not None and not os.environ.get("NUMBA_CACHE_DIR"):
    # Where that folder cannot be written numba keeps its own default locations.
    _where = _cache_dir(_numba.__version__)
    if _writable(_where):
        _numba.config.CACHE_DIR = str(_where)


@overload
def njit(fn: F) -> F: ...


@overload
def njit(*, numpy_division: bool = False) -> Callable[[F], F]: ...


def njit(fn: F | None = None, *, numpy_division: bool = False) -> Any:
    """Compile ``fn`` in nopython mode when numba is available (cached on disk).

    ``numpy_division``: a float division by zero gives inf or nan as in numpy instead of
    raising ZeroDivisionError; without that check per division the compiler can turn a
    loop with a division into SIMD code (``@njit(numpy_division=True)``)."""
    if fn is None:
        return lambda f: _compile(f, numpy_division)
    return _compile(fn, numpy_division)


def _compile(fn: F, numpy_division: bool) -> F:
    if _numba is None:
        return fn
    return _numba.njit(cache=True, nogil=True, error_model="numpy" if numpy_division else "python")(fn)


def backend() -> str:
    """A line for bench output and logs: how the kernels run."""
    if _numba is None:
        why = "GRASP_CTRL_NO_JIT set" if JIT_DISABLED else "numba not installed (pip install numba)"
        return f"plain Python ({why})"
    return f"numba {_numba.__version__}"
