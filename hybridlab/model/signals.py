"""Input signals: tables over time and explicit functions of time, lowered to sympy.

A table becomes an expression in ``t`` built only from ``max`` and ``sign``, the
functions the simulator treats as switching surfaces in a flow. Each breakpoint
``t_i`` is then the surface ``t - t_i = 0``, crossed transversally (its rate is 1),
and located as an event like any other: no step integrates across it blindly.

- ``"linear"``: ``u(t) = u_0 + sum_i c_i * max(0, t - t_i)``, ``c_i`` the change of
  slope at ``t_i``; before the first row and after the last the end values hold.
- ``"previous"`` (zero-order hold): ``u(t) = u_0 + sum_i d_i * (1 + sign(t - t_i)) / 2``,
  ``d_i`` the jump at ``t_i``; the value of the last row at or before ``t`` (before the
  first row, the first value).

Only breakpoints where the value or the slope changes become surfaces.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import sympy as sp

from hybridlab._files import read_bounded
from hybridlab.errors import ModelError

__all__ = ["MAX_ROWS", "MAX_CSV_BYTES", "INTERPOLATIONS", "lower_table", "check_table",
           "read_csv_table", "inline_files"]

#: The most rows a table may have: each breakpoint is a switching function evaluated at
#: every step (``docs/model-format.md`` gives the measured cost).
MAX_ROWS = 100
#: The largest CSV file of a table read.
MAX_CSV_BYTES = 64 * 1024
#: The interpolations a table may ask for.
INTERPOLATIONS = ("linear", "previous")


def check_table(rows: Sequence[Sequence[float]]) -> str | None:
    """What is wrong with a table's rows ``(t, value)``, or ``None``: the one rule for
    tables written inline and read from files.

    Examples
    --------
    >>> check_table([(0.0, 1.0), (1.0, 2.0)]) is None
    True
    >>> check_table([(0.0, 1.0), (0.0, 2.0)])
    'times must increase strictly (row 1: t = 0.0 after t = 0.0)'
    >>> check_table([(0.0, float("nan"))])
    'values must be finite numbers (row 0: 0.0, nan)'
    """
    if not rows:
        return "a table needs at least one row"
    if len(rows) > MAX_ROWS:
        return f"a table has at most {MAX_ROWS} rows (got {len(rows)})"
    for i, row in enumerate(rows):
        if not all(math.isfinite(v) for v in row):
            return f"values must be finite numbers (row {i}: {', '.join(map(repr, row))})"
        if i and row[0] <= rows[i - 1][0]:
            return (f"times must increase strictly (row {i}: t = {row[0]!r} after "
                    f"t = {rows[i - 1][0]!r})")
    return None


def lower_table(rows: Sequence[Sequence[float]], interpolation: str,
                time: sp.Symbol) -> sp.Expr:
    """The table ``rows`` (checked by :func:`check_table`) as an expression in ``time``.

    Examples
    --------
    >>> t = sp.Symbol("t", real=True)
    >>> ramp = lower_table([(1.0, 0.0), (3.0, 4.0)], "linear", t)
    >>> [float(ramp.subs(t, v)) for v in (0.0, 2.0, 5.0)]
    [0.0, 2.0, 4.0]
    >>> steps = lower_table([(0.0, 1.0), (2.0, 3.0)], "previous", t)
    >>> [float(steps.subs(t, v)) for v in (1.0, 2.5)]
    [1.0, 3.0]

    A breakpoint where neither the value nor the slope changes is no surface:

    >>> len(lower_table([(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)], "linear", t).atoms(sp.Max))
    2
    """
    expr: sp.Expr = sp.Float(rows[0][1])
    if interpolation == "previous":
        for (_, before), (t_i, after) in zip(rows, rows[1:], strict=False):
            if after != before:
                expr += sp.Float(after - before) * (1 + sp.sign(time - sp.Float(t_i))) / 2
        return expr
    slopes = [(v1 - v0) / (t1 - t0) for (t0, v0), (t1, v1) in zip(rows, rows[1:], strict=False)]
    for i, (t_i, _) in enumerate(rows):
        change = (slopes[i] if i < len(slopes) else 0.0) - (slopes[i - 1] if i else 0.0)
        if change != 0.0:
            expr += sp.Float(change) * sp.Max(0, time - sp.Float(t_i))
    return expr


def read_csv_table(path: Path, key: str) -> list[tuple[float, float]]:
    """The rows ``t,value`` of a CSV file (a first row of column names is skipped).

    Raises
    ------
    ModelError
        Naming ``key`` and the file (with its line) when the file cannot be read, is too
        large, holds a row that is not two numbers, or its rows break
        :func:`check_table`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> csv = pathlib.Path(tempfile.mkdtemp()) / "wind.csv"
    >>> _ = csv.write_text("t,value\\n0,0.0\\n1,2.5\\n")
    >>> read_csv_table(csv, "signals.wind.file")
    [(0.0, 0.0), (1.0, 2.5)]
    >>> _ = csv.write_text("t,value\\n0,calm\\n")
    >>> read_csv_table(csv, "signals.wind.file")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hybridlab.errors.ModelError: signals.wind.file: not a number (token '.../wind.csv line 2: calm')
    """
    try:
        text = read_bounded(path, MAX_CSV_BYTES).decode("utf-8")
    except OSError as exc:
        raise ModelError(f"cannot read the table: {exc.strerror}", key=key,
                         token=str(path)) from None
    except UnicodeDecodeError:
        raise ModelError("the table is not UTF-8 text", key=key, token=str(path)) from None
    rows: list[tuple[float, float]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        cells = [c.strip() for c in line.split(",")]
        if not line.strip():
            continue
        if len(cells) != 2:
            raise ModelError("each line is t,value", key=key,
                             token=f"{path} line {number}: {line[:40]}")
        try:
            rows.append((float(cells[0]), float(cells[1])))
        except ValueError:
            if not rows and number == 1:
                continue  # the column names
            bad = next(c for c in cells if not _is_float(c))
            raise ModelError("not a number", key=key,
                             token=f"{path} line {number}: {bad[:40]}") from None
    problem = check_table(rows)
    if problem is not None:
        raise ModelError(problem, key=key, token=str(path))
    return rows


def inline_files(data: Mapping[str, Any], folder: Path) -> dict[str, Any]:
    """``data`` (a model file as read) with each signal's ``file`` replaced by its rows
    as a ``table``, the file taken relative to ``folder`` (the model file's).

    So a model holds its data: it writes out and reads back without the CSV file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "wind.csv").write_text("0,0.0\\n1,2.5\\n")
    >>> inline_files({"signals": {"wind": {"file": "wind.csv"}}}, folder)["signals"]
    {'wind': {'table': [(0.0, 0.0), (1.0, 2.5)]}}
    """
    signals = data.get("signals")
    if not isinstance(signals, Mapping):
        return dict(data)
    out: dict[str, Any] = {}
    for name, signal in signals.items():
        if isinstance(signal, Mapping) and isinstance(signal.get("file"), str) and \
                "table" not in signal:
            signal = {k: v for k, v in signal.items() if k != "file"}
            signal["table"] = read_csv_table(folder / signals[name]["file"],
                                             f"signals.{name}.file")
        out[name] = signal
    return {**data, "signals": out}


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
