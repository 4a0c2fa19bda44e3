"""The SpaceEx configuration file (``.cfg``): ``key = value`` lines, ``#`` comments.

Values are numbers, bare words or double-quoted strings (which may span lines, as the
SpaceEx web interface writes long ``initially`` sets).
"""

from __future__ import annotations

import math
import re

from hybridlab.io._sxxml import SpaceExError

__all__ = ["parse_cfg", "cfg_number"]

_KEY = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")
MAX_CFG_BYTES = 1_000_000


def parse_cfg(text: str, source: str) -> dict[str, str]:
    """Parse ``.cfg`` text into a dict; a key given twice is an error.

    Examples
    --------
    >>> parse_cfg('system = "sys"  # the network\\ninitially = "x==1 & v==0"', "a.cfg")
    {'system': 'sys', 'initially': 'x==1 & v==0'}
    """
    if len(text) > MAX_CFG_BYTES:
        raise SpaceExError(f"file larger than {MAX_CFG_BYTES} bytes", source=source)
    out: dict[str, str] = {}
    pos, line = 0, 1
    while pos < len(text):
        ch = text[pos]
        if ch == "\n":
            line += 1
            pos += 1
            continue
        if ch.isspace():
            pos += 1
            continue
        if ch == "#":
            end = text.find("\n", pos)
            pos = len(text) if end < 0 else end
            continue
        key = _KEY.match(text, pos)
        if key is None:
            raise SpaceExError(f"line {line}: expected 'key = value'", token=text[pos:pos + 20],
                               source=source)
        pos = key.end()
        while pos < len(text) and text[pos] in " \t":
            pos += 1
        if pos >= len(text) or text[pos] != "=":
            raise SpaceExError(f"line {line}: expected '=' after the key",
                               key=key.group(), token=text[pos:pos + 20], source=source)
        pos += 1
        while pos < len(text) and text[pos] in " \t":
            pos += 1
        if pos < len(text) and text[pos] == '"':
            end = text.find('"', pos + 1)
            if end < 0:
                raise SpaceExError(f"line {line}: unterminated string", key=key.group(),
                                   token=text[pos:pos + 20], source=source)
            value = text[pos + 1:end]
            line += value.count("\n")
            pos = end + 1
        else:
            end = text.find("\n", pos)
            end = len(text) if end < 0 else end
            value = text[pos:end].split("#", 1)[0].strip()
            pos = end
        if key.group() in out:  # last-one-wins would silently drop the first meaning
            raise SpaceExError(f"line {line}: the key is given twice", key=key.group(),
                               token=key.group(), source=source)
        out[key.group()] = value
    return out


def cfg_number(settings: dict[str, str], key: str, source: str, *, integer: bool = False,
               positive: bool = True) -> float | int | None:
    """The number under ``key``, or ``None`` when absent.

    Examples
    --------
    >>> cfg_number({"time-horizon": "40"}, "time-horizon", "a.cfg")
    40.0
    """
    if key not in settings:
        return None
    text = settings[key].strip()
    try:
        value: float | int = int(text) if integer else float(text)
    except ValueError:
        kind = "an integer" if integer else "a number"
        raise SpaceExError(f"must be {kind}", key=key, token=text, source=source) from None
    if not math.isfinite(value) or (positive and value <= 0):
        raise SpaceExError("must be a positive finite number", key=key, token=text,
                           source=source)
    return value
