"""The results of the solves made before a trial (preshape fits, grip targets, grasp statics),
kept on disk so that a command does not import scipy.optimize and solve them again every run.

A result is stored under the SHA-256 of its function's name and arguments, in a folder named
after this package's source, scipy's version and numpy's: any code or library change starts a
new folder, so a stored result is always the one the code would compute now, to the bit. Where
the folder is ``$XDG_CACHE_HOME/grasp_ctrl/solves`` (``~/.cache`` without it), beside the compiled
kernels' (numeric/jit.py); ``GRASP_CTRL_SOLVE_CACHE`` names another folder, or ``off``. A folder
that cannot be written, an unreadable or damaged entry, or an argument the key cannot spell
(an object other than numbers, text, arrays, sequences, mappings and dataclasses of them) only
means the function runs as it would without the cache.

Entries are pickles, as numba's own cache: the folder is trusted like the code beside it.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.util
import inspect
import os
import pickle
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path, PurePath
from typing import Any, TypeVar

import numpy as np

ENV = "GRASP_CTRL_SOLVE_CACHE"
F = TypeVar("F", bound=Callable[..., Any])


class _Unkeyable(Exception):
    """An argument the key cannot spell."""


def _encode(value: Any, out: list[bytes]) -> None:
    """``value``'s exact bytes (float bits, array dtype and shape) appended to ``out``."""
    if value is None or type(value) in (bool, int, str):
        out.append(f"{type(value).__name__}:{value!r};".encode())
    elif isinstance(value, float):  # float and numpy's float64
        out.append(f"f:{float(value).hex()};".encode())
    elif isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise _Unkeyable("object array")
        out.append(f"a:{value.dtype.str}:{value.shape};".encode())
        out.append(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, np.generic):
        _encode(np.asarray(value), out)
    elif isinstance(value, (tuple, list)):
        out.append(f"{type(value).__name__}:{len(value)}[".encode())
        for item in value:
            _encode(item, out)
        out.append(b"]")
    elif isinstance(value, Mapping):
        out.append(f"map:{len(value)}{{".encode())
        for key in sorted(value, key=repr):
            _encode(key, out)
            _encode(value[key], out)
        out.append(b"}")
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        out.append(f"dc:{type(value).__module__}.{type(value).__qualname__}(".encode())
        for field in dataclasses.fields(value):
            out.append(f"{field.name}=".encode())
            _encode(getattr(value, field.name), out)
        out.append(b")")
    elif isinstance(value, PurePath):
        out.append(f"path:{value};".encode())
    else:
        raise _Unkeyable(type(value).__name__)


def key_of(name: str, args: Mapping[str, Any]) -> str | None:
    """The SHA-256 key of a call of ``name`` with ``args`` (None: an argument it cannot spell)."""
    parts: list[bytes] = [name.encode(), b"\0"]
    try:
        _encode(dict(args), parts)
    except _Unkeyable:
        return None
    return hashlib.sha256(b"".join(parts)).hexdigest()


@functools.lru_cache(maxsize=1)
def _code_version() -> str:
    """This package's source, scipy's and numpy's versions, as one short digest."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parents[1]
    for source in sorted(package.rglob("*.py")):
        digest.update(source.relative_to(package).as_posix().encode())
        digest.update(source.read_bytes())
    spec = importlib.util.find_spec("scipy")  # its version without importing it
    if spec is not None and spec.origin:
        version_file = Path(spec.origin).parent / "version.py"
        digest.update(version_file.read_bytes() if version_file.is_file() else b"?")
    digest.update(np.__version__.encode())
    return digest.hexdigest()[:16]


def cache_folder() -> Path | None:
    """Where results are kept now (None: off)."""
    chosen = os.environ.get(ENV, "")
    if chosen.lower() == "off":
        return None
    base = (
        Path(chosen)
        if chosen
        else Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "grasp_ctrl" / "solves"
    )
    return base / _code_version()


def _load(path: Path) -> tuple[bool, Any]:
    try:
        with open(path, "rb") as f:
            return True, pickle.load(f)
    except Exception:  # missing, unreadable or damaged: solved again and stored anew
        return False, None


def _store(path: Path, value: Any) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, path)  # whole or absent: another process reads either
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except OSError:
        pass  # a folder that cannot be written: the result is used, not kept


def stored(*, ignore: tuple[str, ...] = ()) -> Callable[[F], F]:
    """Keep ``fn``'s results on disk, keyed by its arguments but those named in ``ignore``
    (arguments that only make the call cheaper, such as a kinematics object built from the hand
    already in the key). ``fn`` must be a pure function of the other arguments and this
    package's code. An exception is raised again each time, never stored."""

    def wrap(fn: F) -> F:
        signature = inspect.signature(fn)
        name = f"{fn.__module__}.{fn.__qualname__}"

        @functools.wraps(fn)
        def cached(*args: Any, **kwargs: Any) -> Any:
            folder = cache_folder()
            if folder is None:
                return fn(*args, **kwargs)
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            key = key_of(name, {k: v for k, v in bound.arguments.items() if k not in ignore})
            if key is None:
                return fn(*args, **kwargs)
            path = folder / fn.__name__ / f"{key}.pickle"
            found, value = _load(path)
            if found:
                return value
            value = fn(*args, **kwargs)
            _store(path, value)
            return value

        cached.uncached = fn  # type: ignore[attr-defined]
        return cached  # type: ignore[return-value]

    return wrap
