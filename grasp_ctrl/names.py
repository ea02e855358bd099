"""Safe identifiers: names that become directory or file names.

Object, finger and run names end up in paths under a run directory
(``RUN_DIR/trials/POLICY/OBJECT/...``); a name such as ``../../x`` must be
refused before any file is touched. Policy *specs* may be paths or
``oracle:scale=K``; :func:`path_component` turns any of them into one safe
directory name.
"""

from __future__ import annotations

import re

SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
SAFE_NAME_RULE = "a name of 1-64 letters, digits, '_' or '-', starting with a letter or digit"
_MAX_COMPONENT = 100


def is_safe_name(name: object) -> bool:
    return isinstance(name, str) and SAFE_NAME.match(name) is not None


def path_component(spec: str) -> str:
    """Any text (a policy spec, a path) -> one directory name that cannot leave its parent.

    Characters other than letters, digits, '-', '_' and '.' become '_'; a leading
    '.' too, so the result is never '.', '..' or a hidden name.
    """
    out = "".join(c if c.isascii() and (c.isalnum() or c in "-_.") else "_" for c in spec)[:_MAX_COMPONENT]
    if not out:
        return "_"
    return "_" + out[1:] if out[0] == "." else out
