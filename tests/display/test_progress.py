"""One-line progress: shown on a terminal only, never with --quiet."""

from __future__ import annotations

import io

from grasp_ctrl.display.progress_bar import StatusLine, progress_bar, shown
from grasp_ctrl.trials.runs.progress import Progress


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _rec(k: int, ok: bool) -> dict:
    return {"policy": "p", "object": "lego", "trial": k, "success": ok, "reason": None if ok else "slipped"}


def test_series_progress_is_one_rewritten_line_on_a_terminal():
    term = Terminal()
    prog = Progress(3, stream=term)
    for k, ok in enumerate([True, False, True]):
        prog.trial_done(_rec(k, ok))
    prog.close()
    text = term.getvalue()
    assert "\n" not in text and "\r" in text  # one line, rewritten
    assert "3/3" in text and "p 2/3 ok" in text and "last: lego #2 ok" in text


def test_no_progress_off_a_terminal_or_when_quiet():
    pipe = io.StringIO()
    prog = Progress(2, stream=pipe)
    prog.trial_done(_rec(0, True))
    prog.close()
    assert pipe.getvalue() == ""
    term = Terminal()
    quiet = Progress(2, stream=term, enabled=False)
    quiet.trial_done(_rec(0, True))
    quiet.close()
    assert term.getvalue() == ""
    assert not shown(True, pipe) and shown(True, term) and not shown(False, term)
    with progress_bar(5, "x", True, pipe) as bar:
        bar.update(5)
    assert pipe.getvalue() == ""


def test_status_line_rewrites_in_place_and_notes_stay(capsys):
    term = Terminal()
    with StatusLine(True, term) as line:
        line.update("epoch 1/3")
        line.update("epoch 2/3")
        line.note("result: 1.0")
    assert "epoch 2/3" in term.getvalue() and "\r" in term.getvalue()
    assert capsys.readouterr().out == "result: 1.0\n"
