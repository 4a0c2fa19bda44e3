"""The tidy table a sweep returns."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from hybridlab._files import replace_file

__all__ = ["Pivot", "SweepResult"]


@dataclass(frozen=True)
class Pivot:
    """One column of a sweep laid out over two swept inputs.

    Attributes
    ----------
    index, columns : numpy.ndarray
        The distinct values of the two inputs (sorted), rows and columns of ``values``.
    values : numpy.ndarray
        Shape ``(len(index), len(columns))``; NaN where no run had that pair.

    Examples
    --------
    >>> table = SweepResult(("run", "a", "b", "y"),
    ...                     ((0, 1.0, 10.0, 5), (1, 2.0, 10.0, 6), (2, 2.0, 20.0, 7)))
    >>> pivot = table.pivot("a", "b", "y")
    >>> pivot.index.tolist(), pivot.columns.tolist()
    ([1.0, 2.0], [10.0, 20.0])
    >>> pivot.values.tolist()
    [[5.0, nan], [6.0, 7.0]]
    """

    index: np.ndarray
    columns: np.ndarray
    values: np.ndarray


@dataclass(frozen=True)
class SweepResult:
    """One row per run: the swept inputs, how the run ended, what was recorded.

    Columns, in order: ``run`` (the run's index), the swept inputs, ``status``
    (a :class:`hybridlab.Status` name, or ``ERROR`` when the run raised),
    ``t_final``, ``jumps`` (transitions fired), one ``count:...`` column per
    recorded count, one column per observable, and ``error`` (empty unless the
    run raised or an observable could not be evaluated). Missing values are
    ``None`` (NaN in numeric arrays, empty in CSV).

    Attributes
    ----------
    columns : tuple of str
    rows : tuple of tuple
        The table, one tuple per run in run order.
    inputs : tuple of str
        The swept input columns.
    results : tuple of SimulationResult or None, or None
        Full results (``None`` for a run that raised) when the sweep was made
        with ``keep="results"``; otherwise ``None``.
    elapsed : float
        Wall-clock seconds of the whole sweep.
    executor : str
        Where the runs ran (``serial``, ``threads(2)``, ``processes(2)``, ...).
    interrupted : bool
        Ctrl-C arrived during the sweep: the finished runs are in the table, the
        others have status ``INTERRUPTED``.

    Examples
    --------
    >>> import hybridlab
    >>> table = hybridlab.sweep("models/bouncing_ball.toml", grid={"e": [0.5, 0.8]},
    ...                         t_end=3.0, observe={"h_end": "h"}, events=["bounce"],
    ...                         executor="serial")
    >>> table.columns
    ('run', 'e', 'status', 't_final', 'jumps', 'count:bounce', 'h_end', 'error')
    >>> table["count:bounce"].tolist(), table.ok    # impacts at 1.43 s, then 2.86 s for e = 0.5
    ([2, 1], True)
    """

    columns: tuple[str, ...]
    rows: tuple[tuple[Any, ...], ...]
    inputs: tuple[str, ...] = ()
    results: tuple[Any, ...] | None = field(default=None, repr=False)
    elapsed: float = 0.0
    executor: str = "serial"
    interrupted: bool = False

    def __len__(self) -> int:
        return len(self.rows)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.column(name)

    def column(self, name: str) -> np.ndarray:
        """A column as an array: integers, floats (NaN for missing) or strings.

        Raises
        ------
        KeyError
            Naming the unknown column and listing the known ones.
        """
        if name not in self.columns:
            raise KeyError(f"no column {name!r}; the columns are: {', '.join(self.columns)}")
        k = self.columns.index(name)
        values = [row[k] for row in self.rows]
        present = [v for v in values if v is not None]
        if present and all(isinstance(v, str) for v in present):
            return np.array(["" if v is None else v for v in values], dtype=str)
        if (present and len(present) == len(values)
                and all(isinstance(v, int | np.integer) and not isinstance(v, bool)
                        for v in present)):
            return np.array(values, dtype=np.int64)
        return np.array([math.nan if v is None else float(v) for v in values], dtype=float)

    @property
    def status(self) -> np.ndarray:
        """The ``status`` column."""
        return self.column("status")

    @property
    def ok(self) -> bool:
        """True when every run completed (status ``COMPLETED``)."""
        return all(s == "COMPLETED" for s in self.column("status"))

    @property
    def failed(self) -> tuple[int, ...]:
        """Indices of the runs that did not complete (any other status, or ``ERROR``)."""
        return tuple(int(i) for i in np.flatnonzero(self.column("status") != "COMPLETED"))

    def as_dict(self) -> dict[str, list[Any]]:
        """``{column: list of values}``, JSON-ready."""
        return {name: [row[k] for row in self.rows] for k, name in enumerate(self.columns)}

    def to_numpy(self, columns: Sequence[str] | None = None) -> np.ndarray:
        """Numeric columns as a float array of shape ``(runs, columns)`` (NaN for missing).

        By default every numeric column (``status`` and ``error`` are text).
        """
        if columns is None:
            columns = [c for c in self.columns if self.column(c).dtype.kind in "if"]
        arrays = []
        for name in columns:
            values = self.column(name)
            if values.dtype.kind not in "if":
                raise ValueError(f"column {name!r} is not numeric")
            arrays.append(values.astype(float))
        return np.column_stack(arrays) if arrays else np.empty((len(self.rows), 0))

    def to_csv(self, path: str | Path) -> None:
        """Write the table as CSV with a header row (floats in full precision)."""
        def cell(value: Any) -> str:
            if value is None:
                return ""
            if isinstance(value, float):
                return repr(value)
            return str(value)

        def write(fh: IO[str]) -> None:
            writer = csv.writer(fh)
            writer.writerow(self.columns)
            for row in self.rows:
                writer.writerow([cell(v) for v in row])

        replace_file(path, write)

    def pivot(self, index: str, columns: str, values: str) -> Pivot:
        """Lay the column ``values`` out over two swept inputs.

        Examples
        --------
        >>> table = SweepResult(("run", "a", "b", "y"), ((0, 1.0, 10.0, 5), (1, 2.0, 10.0, 6)))
        >>> table.pivot("a", "b", "y").values.tolist()
        [[5.0], [6.0]]
        """
        rows, cols, vals = self.column(index), self.column(columns), self.column(values)
        r_keys, c_keys = np.unique(rows), np.unique(cols)
        out = np.full((r_keys.size, c_keys.size), math.nan)
        out[np.searchsorted(r_keys, rows), np.searchsorted(c_keys, cols)] = vals
        return Pivot(r_keys, c_keys, out)

    def __repr__(self) -> str:
        return (f"SweepResult({len(self.rows)} runs, {len(self.failed)} not completed, "
                f"columns={list(self.columns)}, elapsed={self.elapsed:.3g} s, "
                f"executor={self.executor!r})")
