"""Guard hits joined into clusters: which hits go together, and the set that covers them.

A run of consecutive flowpipe sets that may fire a transition is cut down to the guard
and the source invariant and joined before the reset. Two choices shape the result:

* **Groups** (:func:`groups`): ``"box"`` joins the whole run, ``"none"`` keeps every
  piece, ``"auto"`` starts a new group where joining would make the hull much wider than
  its pieces.
* **Hull** (:func:`oriented_hull`): the interval hull of a group is the box of its
  pieces in the state axes. Where a run sweeps diagonally through the state space
  (a state that moves while a clock reaches a time-triggered guard), that box is far
  larger than the run; the box in the run's *principal axes* (the singular vectors of
  the pieces' centres and generators) follows it. Each piece's bounds in those axes
  are exact (LPs over the zonotope within the guard), the axes' inverse is enclosed
  in ball arithmetic, and of the two boxes the one of smaller volume is kept.

  ``"sweep"`` keeps the run a zonotope instead (:func:`sweep_hull`): the flowpipe's own
  generators, one generator along the chord of the centres (the sweep in time), and a
  box of what is left. Every correlation the flowpipe carried survives the jump, such
  as a tracking controller's error between a state and its reference, which a box of
  a run a centimetre long turns into a centimetre.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hybridlab.reachability.balls import inverse_enclosure
from hybridlab.reachability.rounding import U, gamma, product_error, up
from hybridlab.reachability.sets import Box, SetError, Zonotope

__all__ = ["COMPACT", "GROUP_GROWTH", "groups", "hull", "oriented_hull", "sweep_hull"]

GROUP_GROWTH = 2.0
"""``"auto"`` clustering: a run of guard hits is split where joining the next piece would
make the group's interval hull wider than this many times its widest piece in some
coordinate."""


COMPACT = 2.0
"""A run whose interval hull is within this many times the summed volume of its pieces'
boxes keeps the interval hull (the principal axes could not gain more)."""


def groups(pieces: list[tuple[np.ndarray, float, float]], clustering: str
           ) -> list[list[int]]:
    """Indices of the cut pieces ``(box, t0, t1)`` of one cluster, in the groups joined.

    ``"box"``: one group; ``"none"``: one per piece; ``"auto"``: consecutive pieces, a new
    group whenever the hull would grow past :data:`GROUP_GROWTH` times the widest piece in
    some coordinate (a short run that stays compact is one group; a long sweep across the
    guard becomes several, each tight).

    Examples
    --------
    >>> box = lambda lo, hi: (np.array([[lo, hi]]), 0.0, 1.0)
    >>> groups([box(0, 1), box(0.5, 1.5), box(5, 6)], "auto")
    [[0, 1], [2]]
    """
    if not pieces:
        return []
    if clustering in ("box", "sweep"):
        return [list(range(len(pieces)))]
    if clustering == "none":
        return [[k] for k in range(len(pieces))]
    out = [[0]]
    lo, hi = pieces[0][0][:, 0].copy(), pieces[0][0][:, 1].copy()
    widest = hi - lo
    for k, piece in enumerate(pieces[1:], start=1):
        box = piece[0]
        new_lo, new_hi = np.minimum(lo, box[:, 0]), np.maximum(hi, box[:, 1])
        new_widest = np.maximum(widest, box[:, 1] - box[:, 0])
        scale = 1e-12 * (1.0 + np.abs(new_lo) + np.abs(new_hi))
        if np.all(new_hi - new_lo <= GROUP_GROWTH * new_widest + scale):
            out[-1].append(k)
            lo, hi, widest = new_lo, new_hi, new_widest
        else:
            out.append([k])
            lo, hi = box[:, 0].copy(), box[:, 1].copy()
            widest = hi - lo
    return out


def hull(boxes: Sequence[np.ndarray]) -> np.ndarray:
    """The interval hull ``(n, 2)`` of boxes ``(n, 2)``.

    Examples
    --------
    >>> hull([np.array([[0.0, 1.0], [2.0, 3.0]]), np.array([[0.5, 2.0], [1.0, 2.5]])]).tolist()
    [[0.0, 2.0], [1.0, 3.0]]
    """
    stack = np.stack(boxes)
    return np.column_stack([stack[:, :, 0].min(axis=0), stack[:, :, 1].max(axis=0)])


def _log_volume(box: np.ndarray) -> float:
    """``log`` of the box's volume (``-inf`` for a flat box)."""
    with np.errstate(divide="ignore"):
        return float(np.sum(np.log(box[:, 1] - box[:, 0])))


def oriented_hull(sets: Sequence[Zonotope], A: np.ndarray, b: np.ndarray,
                  axis_box: np.ndarray, piece_boxes: Sequence[np.ndarray] | None = None
                  ) -> Zonotope | None:
    """A zonotope containing every ``Z ∩ {A x <= b}`` of ``sets``: the box in the sets'
    principal axes, or ``axis_box`` (their interval hull in the state axes) where that is
    smaller. ``None`` when every intersection is empty.

    ``piece_boxes``, the pieces' own boxes in the state axes, let a run that stays
    compact (its hull within :data:`COMPACT` times the sum of their volumes) keep the
    axis box without the LPs of the principal axes.

    Examples
    --------
    A run of squares moving along the diagonal: its box in the state axes is ten times
    larger than the run, the box along the diagonal is not.

    >>> run = [Zonotope([k, k], np.eye(2) * 0.1) for k in np.linspace(0.0, 1.0, 11)]
    >>> axis = hull([Z.bounds() for Z in run])
    >>> Z = oriented_hull(run, np.zeros((0, 2)), np.zeros(0), axis)
    >>> float(np.prod(axis[:, 1] - axis[:, 0])).__round__(2)     # the axis box's area
    1.44
    >>> G = Z.generators[:, :2]               # the oriented box (and a rounding box)
    >>> float(4 * abs(np.linalg.det(G))).__round__(2)           # its area: 0.28 x 1.70
    0.48
    >>> bool(all(Z.contains_points(np.vstack([Q.center + Q.generators.sum(axis=1),
    ...                                        Q.center - Q.generators.sum(axis=1)])).all()
    ...           for Q in run))
    True
    """
    n = axis_box.shape[0]
    whole = Box(axis_box[:, 0], axis_box[:, 1]).to_zonotope()
    if len(sets) < 2 or n < 2:
        return whole
    C = np.column_stack([Z.center for Z in sets])
    D = np.hstack([C - C.mean(axis=1, keepdims=True), sets[len(sets) // 2].generators])
    width = axis_box[:, 1] - axis_box[:, 0]
    free = np.flatnonzero(width > 0)  # flat coordinates stay axes
    if free.size < 2 or not np.all(np.isfinite(D)):
        return whole
    if piece_boxes is not None:
        pieces = np.log(sum(np.exp(_log_volume(box[free])) for box in piece_boxes) + 1e-300)
        if _log_volume(axis_box[free]) <= np.log(COMPACT) + pieces:
            return whole
    # principal axes of the run in coordinates scaled to the hull's widths (so the units
    # of the states do not decide them), mapped back
    U = np.eye(n)
    scaled = D[free] / width[free, None]
    U[np.ix_(free, free)] = width[free, None] * np.linalg.svd(scaled)[0]
    inverse = inverse_enclosure(U)
    if inverse is None:
        return whole
    inv_mid, inv_rad = inverse
    boxes = []
    for Z in sets:
        Y = Z.linear_map(inv_mid, radius=inv_rad)  # y = U^{-1} x
        if A.shape[0]:
            # A x <= b with x = U y: (A U) y <= b, the product's rounding added to b
            y_max = up(np.abs(Y.center) + Y.radius())
            slack = up(product_error(np.abs(A), np.abs(U)) @ y_max)
            try:
                box = Y.bounds_within(A @ U, b + slack)
            except SetError:  # the LP failed in these axes: keep the state axes
                return whole
        else:
            box = Y.bounds()
        if box is not None:
            boxes.append(box)
    if not boxes:
        return None
    y_box = hull(boxes)
    # volumes compared on the free coordinates (the frame keeps the flat ones); the
    # frame's determinant converts the box in y to the state space
    det = abs(float(np.linalg.det(U[np.ix_(free, free)])))
    if not (det > 0 and np.isfinite(det)):
        return whole
    y_free, x_free = y_box[free], axis_box[free]
    if not _log_volume(y_free) + np.log(det) < _log_volume(x_free):
        return whole
    return Box(y_box[:, 0], y_box[:, 1]).to_zonotope().linear_map(U)


def sweep_hull(sets: Sequence[Zonotope]) -> Zonotope | None:
    """A zonotope containing every zonotope of a run ``sets`` of one flowpipe, which share
    their generators' layout: ``c + mu d + G y + diag(r) e`` (``|mu|, |y|, |e| <= 1``).

    ``d`` is half the chord from the first centre to the last (the run's sweep), ``G`` the
    middle set's generators, and ``r`` bounds, per coordinate, each set's deviation from
    that frame: its centre's distance from the chord's line, plus ``|G_i - G|`` summed
    over the generators (and the rounding of both). ``None`` when the layouts differ.

    Examples
    --------
    A square carried along the diagonal while it turns slightly: the hull is the square's
    frame plus the sweep, not the box of the run.

    >>> turn = lambda a: np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    >>> run = [Zonotope([k, k], 0.1 * turn(0.01 * k)) for k in np.linspace(0.0, 1.0, 11)]
    >>> Z = sweep_hull(run)
    >>> Z.generators.shape, bool(np.allclose(Z.generators[:, 0], [0.5, 0.5]))
    ((2, 5), True)
    >>> bool(all(Z.contains_points(Q.center + Q.generators @ np.array(v)).all()
    ...           for Q in run for v in [[1, 1], [1, -1], [-1, 1], [-1, -1]]))
    True
    """
    if not sets:
        return None
    shape = sets[0].generators.shape
    if any(Z.generators.shape != shape for Z in sets):
        return None
    C = np.column_stack([Z.center for Z in sets])
    mid = sets[len(sets) // 2].generators
    base = 0.5 * (C[:, 0] + C[:, -1])
    d = 0.5 * (C[:, -1] - C[:, 0])
    dd = float(d @ d)
    lam = ((C - base[:, None]).T @ d) / dd if dd > 0 else np.zeros(len(sets))
    lo, hi = float(lam.min()), float(lam.max())
    centre = base + 0.5 * (lo + hi) * d
    half = 0.5 * (hi - lo)
    r = np.zeros(C.shape[0])
    for k, Z in enumerate(sets):
        # any mu with |mu| <= half serves (off is computed from it): clipped against rounding
        mu = min(max(lam[k] - 0.5 * (lo + hi), -half), half)
        off = C[:, k] - centre - mu * d  # the centre's distance from the chord's line
        # the rounding of off: a few operations on terms of these magnitudes
        err = gamma(6) * (np.abs(C[:, k]) + np.abs(centre) + np.abs(mu * d))
        spread = np.sum(np.abs(Z.generators - mid), axis=1)
        r = np.maximum(r, up(np.abs(off) + err + spread, shape[1] + 8))
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(centre))):
        return None
    # the chord generator half * d: its rounding joins the box
    chord = half * d
    r = up(r + U * np.abs(chord) + 2 * U * (np.abs(centre) + np.abs(mid) @ np.ones(shape[1])), 4)
    return Zonotope(centre, np.hstack([chord[:, None], mid, np.diag(r)])).compact()
