"""After an interrupt, the report of a multiprocessing finalizer that the signal left half-built
(no key: "Exception ignored in: <Finalize object, dead>" with a traceback) is dropped; any other
unraisable exception still reaches the hook that was there before."""

from __future__ import annotations

import sys
from multiprocessing.util import Finalize
from types import SimpleNamespace

import pytest

from grasp_ctrl import cli


def test_only_the_half_built_finalizers_report_is_dropped(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(u.object))
    cli._quiet_half_built_finalizers()
    half_built = Finalize.__new__(Finalize)  # as a signal inside Finalize.__init__ leaves it
    sys.unraisablehook(SimpleNamespace(exc_value=AttributeError("_key"), object=half_built))
    assert seen == []
    other = object()
    sys.unraisablehook(SimpleNamespace(exc_value=AttributeError("x"), object=other))
    sys.unraisablehook(SimpleNamespace(exc_value=ValueError("_key"), object=half_built))
    assert seen == [other, half_built]
