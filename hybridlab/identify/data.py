"""Measured data sets and their CSV formats.

Three record types, each a frozen object validated on construction:

* :class:`FrictionData` -- steady-state runs, columns ``velocity`` (m/s) and ``force`` (N);
* :class:`FrequencyData` -- a frequency response of position over force, columns
  ``frequency_hz``, ``magnitude_db`` and optionally ``phase_deg``;
* :class:`SensorEvents` -- sensor edges, columns ``sensor``, ``t`` (s) and ``edge``
  (``rising`` or ``falling``).

Extra columns are ignored; a missing column, a non-numeric or non-finite value names the
column and the row.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from hybridlab._files import read_bounded, replace_file
from hybridlab._text import printable
from hybridlab.identify.errors import DataError

__all__ = [
    "EDGES",
    "FrictionData",
    "FrequencyData",
    "SensorEvents",
    "read_friction_csv",
    "read_frequency_csv",
    "read_events_csv",
    "write_csv",
]

#: The accepted values of the ``edge`` column.
EDGES = ("rising", "falling")


def _column(values: Sequence[float] | np.ndarray, name: str, source: str = "") -> np.ndarray:
    """``values`` as a finite 1-D float array, or a :class:`DataError` naming ``name``."""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(f"must be numeric ({exc})", column=name, source=source) from None
    if arr.ndim != 1:
        raise DataError(f"must be 1-dimensional (got shape {arr.shape})", column=name,
                        source=source)
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise DataError(f"contains NaN or infinite values (first at row {bad[0] + 1})",
                        column=name, source=source)
    return arr


def _same_length(columns: dict[str, np.ndarray], source: str) -> None:
    lengths = {name: len(v) for name, v in columns.items()}
    if len(set(lengths.values())) > 1:
        raise DataError(f"columns have different lengths {lengths}", source=source)


@dataclass(frozen=True)
class FrictionData:
    """Steady-state friction runs: the force needed to move at a constant velocity.

    Parameters
    ----------
    velocity : array_like
        Steady velocities (m/s); both signs are needed.
    force : array_like
        The driving force at each velocity (N).
    source : str, optional
        Where the data came from (used in error messages).

    Examples
    --------
    >>> data = FrictionData([-0.2, -0.1, 0.1, 0.2], [-60.0, -43.0, 43.0, 69.0])
    >>> int(data.forward.sum()), int(data.backward.sum())
    (2, 2)
    """

    velocity: np.ndarray
    force: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        v = _column(self.velocity, "velocity", self.source)
        f = _column(self.force, "force", self.source)
        _same_length({"velocity": v, "force": f}, self.source)
        object.__setattr__(self, "velocity", v)
        object.__setattr__(self, "force", f)

    @property
    def forward(self) -> np.ndarray:
        """Boolean mask of the runs with positive velocity."""
        return self.velocity > 0

    @property
    def backward(self) -> np.ndarray:
        """Boolean mask of the runs with negative velocity."""
        return self.velocity < 0


@dataclass(frozen=True)
class FrequencyData:
    """A measured frequency response of position over force.

    Parameters
    ----------
    frequency_hz : array_like
        Strictly increasing positive frequencies (Hz).
    magnitude_db : array_like
        Gain ``20 log10 |X/F|`` with X in m and F in N (dB).
    phase_deg : array_like, optional
        Phase (degrees); used for plots and the phase check of the mass region.
    source : str, optional
        Where the data came from.

    Examples
    --------
    >>> FrequencyData([1.0, 10.0], [-20.0, -60.0]).omega.round(3)
    array([ 6.283, 62.832])
    """

    frequency_hz: np.ndarray
    magnitude_db: np.ndarray
    phase_deg: np.ndarray | None = None
    source: str = ""

    def __post_init__(self) -> None:
        f = _column(self.frequency_hz, "frequency_hz", self.source)
        m = _column(self.magnitude_db, "magnitude_db", self.source)
        cols = {"frequency_hz": f, "magnitude_db": m}
        if self.phase_deg is not None:
            cols["phase_deg"] = _column(self.phase_deg, "phase_deg", self.source)
        _same_length(cols, self.source)
        if np.any(f <= 0):
            raise DataError("must be positive", column="frequency_hz", source=self.source)
        if np.any(np.diff(f) <= 0):
            raise DataError("must be strictly increasing", column="frequency_hz",
                            source=self.source)
        object.__setattr__(self, "frequency_hz", f)
        object.__setattr__(self, "magnitude_db", m)
        object.__setattr__(self, "phase_deg", cols.get("phase_deg"))

    @property
    def omega(self) -> np.ndarray:
        """Angular frequencies (rad/s)."""
        return 2 * np.pi * self.frequency_hz


@dataclass(frozen=True)
class SensorEvents:
    """Edges of discrete sensors, sorted by time.

    Parameters
    ----------
    sensor : sequence of str
        Sensor identifier of each edge (any text, e.g. ``"1"``).
    t : array_like
        Edge times (s).
    edge : sequence of str
        ``"rising"`` (the sensor switches on) or ``"falling"`` (off).
    source : str, optional
        Where the data came from.

    Examples
    --------
    >>> ev = SensorEvents(["2", "1"], [0.30, 0.29], ["rising", "rising"])
    >>> ev.sensor, ev.t.tolist()
    (('1', '2'), [0.29, 0.3])
    """

    sensor: tuple[str, ...]
    t: np.ndarray
    edge: tuple[str, ...]
    source: str = ""

    def __post_init__(self) -> None:
        t = _column(self.t, "t", self.source)
        sensor = tuple(str(s).strip() for s in self.sensor)
        edge = tuple(str(e).strip().lower() for e in self.edge)
        if len(sensor) != len(t) or len(edge) != len(t):
            raise DataError(f"columns have different lengths (sensor {len(sensor)}, t {len(t)}, "
                            f"edge {len(edge)})", source=self.source)
        for i, e in enumerate(edge):
            if e not in EDGES:
                raise DataError(f"must be 'rising' or 'falling' (got {e!r} at row {i + 1})",
                                column="edge", source=self.source)
        for i, s in enumerate(sensor):
            if not s:
                raise DataError(f"is empty at row {i + 1}", column="sensor", source=self.source)
        order = np.argsort(t, kind="stable")
        object.__setattr__(self, "t", t[order])
        object.__setattr__(self, "sensor", tuple(sensor[i] for i in order))
        object.__setattr__(self, "edge", tuple(edge[i] for i in order))

    def __len__(self) -> int:
        return len(self.t)


def _read_rows(path: str | Path, required: Sequence[str],
               optional: Sequence[str] = ()) -> tuple[dict[str, list[str]], str]:
    source = str(path)
    try:
        text = read_bounded(path).decode("utf-8")
    except OSError as exc:
        raise DataError(f"cannot read the file ({exc.strerror})", source=source) from None
    except UnicodeDecodeError:
        raise DataError("is not UTF-8 text", source=source) from None
    if "\x00" in text:
        raise DataError("is not text (it holds NUL bytes)", source=source)
    lines = [ln for ln in text.removeprefix("\ufeff").splitlines(keepends=True)
             if ln.strip() and not ln.lstrip().startswith("#")]
    reader = csv.DictReader(lines)
    header = [h.strip() for h in (reader.fieldnames or [])]
    twice = sorted({h for h in header if header.count(h) > 1})
    if twice:
        raise DataError(f"has the column {twice[0]!r} twice", column=twice[0], source=source)
    missing = [c for c in required if c not in header]
    if missing:
        raise DataError(f"missing column(s) {', '.join(missing)}; the file has "
                        f"{', '.join(map(printable, header)) or 'no header'}",
                        column=missing[0], source=source)
    wanted = [*required, *(c for c in optional if c in header)]
    out: dict[str, list[str]] = {c: [] for c in wanted}
    for row in reader:
        row = {(k or "").strip(): v for k, v in row.items()}
        for c in wanted:
            out[c].append((row.get(c) or "").strip())
    return out, source


def _floats(cells: list[str], name: str, source: str) -> np.ndarray:
    values = []
    for i, cell in enumerate(cells):
        try:
            values.append(float(cell))
        except ValueError:
            raise DataError(f"is not a number at data row {i + 1} (got {cell!r})", column=name,
                            source=source) from None
    return _column(values, name, source)


def read_friction_csv(path: str | Path) -> FrictionData:
    """Read :class:`FrictionData` from a CSV file with columns ``velocity`` and ``force``.

    Lines starting with ``#`` are comments; other columns are ignored.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "friction.csv"
    >>> _ = path.write_text("# steady-state runs\\n"
    ...                     "velocity,force,run\\n-0.2,-68.8,1\\n-0.1,-43.1,2\\n0.1,43.1,3\\n")
    >>> data = read_friction_csv(path)
    >>> data.velocity.tolist(), data.force.tolist(), int(data.forward.sum())
    ([-0.2, -0.1, 0.1], [-68.8, -43.1, 43.1], 1)
    >>> _ = path.write_text("velocity,force\\n0.1,abc\\n")
    >>> read_friction_csv(path)
    Traceback (most recent call last):
    ...
    hybridlab.identify.errors.DataError: ...friction.csv: column 'force': is not a number at
    data row 1 (got 'abc')
    """
    rows, source = _read_rows(path, ("velocity", "force"))
    return FrictionData(_floats(rows["velocity"], "velocity", source),
                        _floats(rows["force"], "force", source), source=source)


def read_frequency_csv(path: str | Path) -> FrequencyData:
    """Read :class:`FrequencyData` from a CSV file.

    Columns ``frequency_hz`` and ``magnitude_db`` are required, ``phase_deg`` is optional.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "bode.csv"
    >>> _ = path.write_text("frequency_hz,magnitude_db,phase_deg\\n"
    ...                     "10,-60,-178\\n100,-100,-179\\n")
    >>> data = read_frequency_csv(path)
    >>> data.magnitude_db.tolist(), data.phase_deg.tolist(), data.omega.round(1).tolist()
    ([-60.0, -100.0], [-178.0, -179.0], [62.8, 628.3])
    """
    rows, source = _read_rows(path, ("frequency_hz", "magnitude_db"), ("phase_deg",))
    phase = _floats(rows["phase_deg"], "phase_deg", source) if "phase_deg" in rows else None
    return FrequencyData(_floats(rows["frequency_hz"], "frequency_hz", source),
                         _floats(rows["magnitude_db"], "magnitude_db", source), phase,
                         source=source)


def read_events_csv(path: str | Path) -> SensorEvents:
    """Read :class:`SensorEvents` from a CSV file with columns ``sensor``, ``t``, ``edge``.

    Examples
    --------
    Edges are sorted by time; the ``edge`` column is case-insensitive:

    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "edges.csv"
    >>> _ = path.write_text("sensor,t,edge\\n2,0.31,Rising\\n1,0.29,rising\\n1,0.35,falling\\n")
    >>> events = read_events_csv(path)
    >>> events.sensor, events.t.tolist(), events.edge
    (('1', '2', '1'), [0.29, 0.31, 0.35], ('rising', 'rising', 'falling'))
    """
    rows, source = _read_rows(path, ("sensor", "t", "edge"))
    return SensorEvents(tuple(rows["sensor"]), _floats(rows["t"], "t", source),
                        tuple(rows["edge"]), source=source)


def write_csv(path: str | Path, columns: dict[str, Sequence[object]]) -> None:
    """Write equal-length ``columns`` to a CSV file (the inverse of the readers).

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "runs.csv")
    >>> write_csv(path, {"velocity": [-0.1, 0.1], "force": [-40.0, 40.0]})
    >>> read_friction_csv(path).force.tolist()
    [-40.0, 40.0]
    """
    names = list(columns)
    n = {len(v) for v in columns.values()}
    if len(n) > 1:
        raise ValueError(f"columns must have equal lengths (got {n})")
    def write(fh: IO[str]) -> None:
        writer = csv.writer(fh)
        writer.writerow(names)
        for row in zip(*(columns[c] for c in names), strict=True):
            writer.writerow([repr(float(x)) if isinstance(x, float | np.floating) else x
                             for x in row])

    replace_file(path, write)
