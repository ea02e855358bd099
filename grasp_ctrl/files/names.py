"""Policy specs as directory names.

Object, finger and policy names are identifiers, checked where they are read by the one rule of
:mod:`grasp_ctrl.config.identifiers` (a name such as ``../../x`` is refused before any file is
touched). Policy *specs* may also be paths or ``oracle:scale=K``; :func:`path_component` turns any
of them into one safe directory name.
"""

from __future__ import annotations

_MAX_COMPONENT = 100


def path_component(spec: str) -> str:
    """Any text (a policy spec, a path) -> one directory name that cannot leave its parent.

    Characters other than letters, digits, '-', '_' and '.' become '_'; a leading
    '.' too, so the result is never '.', '..' or a hidden name.
    """
    out = "".join(c if c.isascii() and (c.isalnum() or c in "-_.") else "_" for c in spec)[:_MAX_COMPONENT]
    if not out:
        return "_"
    return "_" + out[1:] if out[0] == "." else out
