"""Flowpipes projected on two variables, with simulated traces overlaid (matplotlib)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlab.reachability.sets import Zonotope

if TYPE_CHECKING:
    from hybridlab.reachability.result import ReachResult

__all__ = ["zonotope_polygon", "plot_reach"]


def zonotope_polygon(Z: Zonotope) -> np.ndarray:
    """Vertices (counter-clockwise, shape ``(k, 2)``) of a 2-D zonotope.

    Examples
    --------
    >>> zonotope_polygon(Zonotope([0.0, 0.0], [[1.0, 0.0], [0.0, 1.0]])).tolist()
    [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]
    """
    if Z.dim != 2:
        raise ValueError(f"zonotope_polygon needs a 2-D zonotope (got dimension {Z.dim})")
    G = Z.generators[:, np.any(Z.generators != 0, axis=0)].copy()
    if G.shape[1] == 0:
        return Z.center[None, :].copy()
    flip = (G[1] < 0) | ((G[1] == 0) & (G[0] < 0))
    G[:, flip] *= -1
    G = G[:, np.argsort(np.arctan2(G[1], G[0]))]
    start = Z.center - G.sum(axis=1)   # the lowest point
    steps = np.hstack([2 * G, -2 * G])
    pts = start + np.cumsum(steps, axis=1).T
    return np.vstack([pts[-1:], pts[:-1]])


def _index(result: ReachResult, name: str) -> int | None:
    if name == "t":
        return None
    if name not in result.state_names:
        raise ValueError(f"unknown variable {name!r}; expected 't' or one of: "
                         f"{', '.join(result.state_names)}")
    return result.state_names.index(name)


def plot_reach(result: ReachResult, x: str, y: str, ax: Any = None,
               traces: Sequence[Any] | None = None, color: str = "tab:blue",
               alpha: float = 0.35, trace_color: str = "k") -> Any:
    """Draw ``result``'s sets projected on ``(x, y)``; ``"t"`` may be either axis.

    Parameters
    ----------
    result : ReachResult
    x, y : str
        State names, or ``"t"`` for time (then each set is drawn as its time
        interval times its bounds).
    ax : matplotlib Axes, optional
        Created when omitted.
    traces : sequence of SimulationResult, optional
        Simulations drawn on top (dense, 400 points per trace).

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")  # no window
    >>> import hybridlab
    >>> result = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
    ...                          t_end=1.0, step=0.1)
    >>> ax = plot_reach(result, "t", "T")  # one rectangle per set: its time and T bounds
    >>> ax.get_xlabel(), ax.get_ylabel(), len(ax.collections[0].get_paths())
    ('t', 'T', 16)
    >>> import matplotlib.pyplot as plt
    >>> plt.close(ax.figure)
    """
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    ix, iy = _index(result, x), _index(result, y)
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    polys = []
    for s in result.sets:
        b = s.bounds()
        if ix is None and iy is None:
            continue
        if ix is None or iy is None:
            t0, t1 = s.t
            lo, hi = b[iy if ix is None else ix]
            rect = [(t0, lo), (t1, lo), (t1, hi), (t0, hi)]
            polys.append(np.array(rect if ix is None else [(p[1], p[0]) for p in rect]))
        else:
            polys.append(zonotope_polygon(s.set.project([ix, iy])))
    ax.add_collection(PolyCollection(polys, facecolors=color, edgecolors=color, alpha=alpha,
                                     linewidths=0.3))
    for sim in traces or ():
        tt = np.linspace(sim.segments[0].t_start, sim.final.t, 400)
        Y = sim(tt)
        ax.plot(tt if ix is None else Y[ix], tt if iy is None else Y[iy], color=trace_color,
                lw=0.8)
    ax.autoscale_view()
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    return ax
