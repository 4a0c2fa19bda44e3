"""Names from model files made safe to print on one line."""

from __future__ import annotations

import unicodedata

__all__ = ["printable"]

#: control, format, line and paragraph separators: what can forge or hide a line
_HIDDEN = frozenset(("Cc", "Cf", "Zl", "Zp"))


def printable(text: str) -> str:
    """``text`` with every control or invisible character written as an escape.

    A mode name holding a newline could otherwise forge a line of a summary that
    scripts parse (``status: COMPLETED``), or escape a TOML comment.

    Examples
    --------
    >>> printable("fall")
    'fall'
    >>> printable("a\\nstatus: COMPLETED")
    'a\\\\nstatus: COMPLETED'
    >>> printable("x\\u202ey")
    'x\\\\u202ey'
    """
    if all(unicodedata.category(c) not in _HIDDEN for c in text):
        return text
    return "".join(c.encode("unicode_escape").decode("ascii")
                   if unicodedata.category(c) in _HIDDEN else c for c in text)
