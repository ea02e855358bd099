"""The one rule for names: object, policy and finger names (and servo models a hand file defines).

Names become directory and file names (``RUN_DIR/trials/POLICY/OBJECT/...``, ``policies/NAME.json``)
and keys that other files refer to, so a name is an *identifier*: 1 to 64 ASCII letters, digits,
``_``, ``-`` or ``.``, not starting with ``.``. Such a name is one safe path component: no ``/``,
no NUL, no whitespace or newline, never ``.``, ``..`` or a hidden file. Anything else is refused with
one line naming the file and key (:func:`check_identifier`, a ConfigError) or the command-line
argument (:func:`check_identifier_arg`, a UsageError).
"""

from __future__ import annotations

import re
from typing import Any, TypeGuard

from grasp_ctrl.errors import ConfigError, PolicyError, UsageError

MAX_IDENTIFIER = 64
IDENTIFIER = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,63}")  # matched with fullmatch, never match
IDENTIFIER_RULE = f"an identifier: 1-{MAX_IDENTIFIER} ASCII letters, digits, '_', '-' or '.', not starting with '.'"
_SHOWN = 40  # characters of a refused value quoted in the message


def is_identifier(value: object) -> TypeGuard[str]:
    return isinstance(value, str) and IDENTIFIER.fullmatch(value) is not None


def shown(value: Any) -> str:
    """``repr(value)`` cut to one short line (repr escapes newlines and other control characters)."""
    text = repr(value)
    return (
        text
        if len(text) <= _SHOWN
        else f"{text[:_SHOWN]}... ({len(value) if isinstance(value, str) else len(text)} characters)"
    )


def check_identifier(value: object, where: object, key: str, why: str = "") -> str:
    """``value`` if it is an identifier, else ConfigError(where, key, the rule, ``why`` and the value)."""
    if not is_identifier(value):
        raise ConfigError(str(where), key, _expected(value, why))
    return value


def check_policy_identifier(value: object, where: object, key: str) -> str:
    """``check_identifier`` for a policy file: the same line as a PolicyError (what a policy that
    cannot be loaded raises, and the command line reports)."""
    if not is_identifier(value):
        raise PolicyError(f"{where}: {key}: {_expected(value)}")
    return value


def _expected(value: object, why: str = "") -> str:
    return f"{IDENTIFIER_RULE}{f'; {why}' if why else ''} (got {shown(value)})"


def check_identifier_arg(value: object, what: str) -> str:
    """``value`` if it is an identifier, else a one-line UsageError naming ``what`` (a flag)."""
    if not is_identifier(value):
        raise UsageError(f"{what} {shown(value)}: must be {IDENTIFIER_RULE}")
    return value
