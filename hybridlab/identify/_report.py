"""Shared helpers of the result objects: text tables, JSON and lazy plotting."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from hybridlab._files import replace_file, replace_text

__all__ = ["format_table", "axes", "save_figure", "write_json"]


def _cell(value: object) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def format_table(header: Iterable[str], rows: Iterable[Iterable[object]]) -> str:
    """A plain-text table with aligned columns.

    Examples
    --------
    >>> print(format_table(["name", "value"], [["c", 17.41], ["d", 257.0]]))
    name  value
    ----  -----
    c     17.41
    d     257
    """
    text = [[_cell(h) for h in header], *([_cell(c) for c in r] for r in rows)]
    widths = [max(len(r[i]) for r in text) for i in range(len(text[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
             for r in text]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def axes(ax: Any = None, nrows: int = 1) -> Any:
    """``ax`` itself, or new axes on a fresh figure.

    matplotlib is imported only here, on demand, and through ``matplotlib.figure.Figure``
    rather than pyplot, so no global figure registry or backend is touched.

    Examples
    --------
    The ``plot`` methods draw into the caller's axes when given some (any object here);
    ``axes()`` and ``axes(nrows=2)`` make one or two axes on a new ``Figure``:

    >>> ax = object()
    >>> axes(ax) is ax
    True
    """
    if ax is not None:
        return ax
    try:
        from matplotlib.figure import Figure
    except ImportError as exc:  # optional dependency
        raise ImportError("plotting needs matplotlib: pip install 'hybridlab[plot]'") from exc
    fig = Figure(figsize=(6.4, 3.2 * nrows + 0.8))
    return fig.subplots(nrows, 1, squeeze=nrows == 1)


def save_figure(ax: Any, path: str | Path) -> None:
    """Save the figure that holds ``ax`` (an axes or an array of axes).

    The file's suffix gives the format (``png`` without one); the file is replaced
    atomically.

    Examples
    --------
    With a stand-in for a matplotlib figure (the two methods used):

    >>> import pathlib, tempfile
    >>> class Figure:
    ...     def tight_layout(self):
    ...         pass
    ...     def savefig(self, fh, dpi, format):
    ...         fh.write(f"<{format} at {dpi} dpi>".encode())
    >>> class Axes:
    ...     figure = Figure()
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "friction.svg"
    >>> save_figure(Axes(), path)
    >>> path.read_text()
    '<svg at 120 dpi>'
    """
    first = ax.flat[0] if hasattr(ax, "flat") else ax
    fig = first.figure
    fig.tight_layout()
    suffix = Path(path).suffix.lstrip(".").lower() or "png"
    replace_file(path, lambda fh: fig.savefig(fh, dpi=120, format=suffix), binary=True)


def write_json(path: str | Path, payload: Mapping[str, Any]) -> None:
    """Write ``payload`` as indented JSON (non-finite floats become ``null``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "fit.json"
    >>> write_json(path, {"parameters": {"c": 17.41}, "se": float("nan"), "n": (8, 0)})
    >>> print(path.read_text())
    {
     "parameters": {
      "c": 17.41
     },
     "se": null,
     "n": [
      8,
      0
     ]
    }
    """

    def clean(value: Any) -> Any:
        if isinstance(value, float):
            return value if math.isfinite(value) else None
        if isinstance(value, Mapping):
            return {str(k): clean(v) for k, v in value.items()}
        if isinstance(value, list | tuple):
            return [clean(v) for v in value]
        return value

    replace_text(path, json.dumps(clean(dict(payload)), indent=1) + "\n")
