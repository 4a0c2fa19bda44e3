"""A result drawn over time (matplotlib, the ``plot`` extra): what
:meth:`SimulationResult.plot` draws.

matplotlib is imported only when a plot is made, and through ``matplotlib.figure.Figure``
rather than pyplot: no window opens, no backend is chosen and no global figure registry is
touched, so it works under any backend (Agg included) and in threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlab._text import printable

if TYPE_CHECKING:
    from hybridlab.simulation.result import SimulationResult

#: the points of the uniform grid laid over the run, besides the stored points
_GRID_POINTS = 1000


def _states(result: SimulationResult, states: str | Sequence[str] | None) -> list[str]:
    chosen = list(result.state_names) if states is None else (
        [states] if isinstance(states, str) else list(states))
    unknown = [s for s in chosen if s not in result.state_names]
    if unknown:
        raise ValueError(f"unknown state {unknown[0]!r}; the result has: "
                         f"{', '.join(result.state_names)}")
    return chosen


def _curves(result: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    """Times and states to draw: each segment's stored points and the grid points inside
    it from its dense output, with a NaN column between segments so a jump is a gap."""
    segments = result.segments
    starts, ends = segments.t_start, segments.t_end
    grid = np.linspace(starts[0], ends[-1], _GRID_POINTS)
    # stored points keep their segment; a grid point goes to the segment holding it
    # (the later one at a jump instant)
    which = np.concatenate([np.repeat(np.arange(len(segments)), segments.n_points),
                            result.segment_index(grid)])
    t = np.concatenate([segments.t, grid])
    order = np.lexsort((t, which))
    which, t = which[order], t[order]
    y = segments.dense(which, t)
    gaps = np.flatnonzero(np.diff(which)) + 1
    return (np.insert(t, gaps, np.nan),
            np.insert(y, gaps, np.nan, axis=1))


def _shade_modes(result: SimulationResult, ax: Any) -> None:
    """One translucent band per mode over the time it is active (only when several modes
    occur); one collection per mode, labelled with the mode's name."""
    from matplotlib.collections import PolyCollection

    segments = result.segments
    modes = segments.mode
    names = list(dict.fromkeys(modes))
    if len(names) < 2:
        return
    starts, ends = segments.t_start, segments.t_end
    colors = [f"C{k % 10}" for k in range(len(names))]
    for name, color in zip(names, colors, strict=True):
        rows = np.array([m == name for m in modes])
        bands = [np.array([(a, 0.0), (b, 0.0), (b, 1.0), (a, 1.0)])
                 for a, b in zip(starts[rows], ends[rows], strict=True)]
        ax.add_collection(PolyCollection(bands, facecolors=color, edgecolors="none",
                                         alpha=0.12, transform=ax.get_xaxis_transform(),
                                         label=f"mode {printable(name)}", zorder=0))


def plot(result: SimulationResult, states: str | Sequence[str] | None = None,
         ax: Any = None) -> Any:
    """What :meth:`SimulationResult.plot` draws and returns (its example is there)."""
    chosen = _states(result, states)
    if not len(result.segments):
        raise ValueError("the result has no flow segment to plot")
    given = ax is not None
    if ax is None:
        try:
            from matplotlib.figure import Figure
        except ImportError as exc:  # optional dependency
            raise ImportError("plotting needs matplotlib: pip install 'hybridlab[plot]'"
                              ) from exc
        ax = Figure(figsize=(7.0, 3.6), layout="constrained").subplots()
    t, y = _curves(result)
    for name in chosen:
        ax.plot(t, y[result.state_names.index(name)], label=name, lw=1.2)
    _shade_modes(result, ax)
    events = result.events
    if len(events):
        ax.vlines(events.t, 0.0, 1.0, transform=ax.get_xaxis_transform(), colors="0.4",
                  linestyles=":", linewidths=0.8, label=f"events ({len(events)})")
    ax.set_xlabel("t")
    if len(chosen) == 1:
        ax.set_ylabel(chosen[0])
    t0, t1 = float(result.segments.t_start[0]), float(result.final.t)
    if t1 > t0:
        ax.set_xlim(t0, t1)
    ax.legend(loc="best", fontsize="small")
    return ax if given else ax.figure
