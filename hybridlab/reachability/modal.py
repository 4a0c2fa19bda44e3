"""A block-diagonal basis for stiff modes, and the enclosures of each fast block over a step.

A mode is *stiff* for a step ``r`` when some eigenvalue of its (homogeneous)
matrix ``A_h`` has ``|lambda| r`` large: a Taylor sum in ``A_h r`` then needs
a huge number of terms, and its entrywise remainder bound grows like
``e^{|A_h| r}`` (the cancellation of the alternating terms is lost). Instead,
the step is split by time scale:

1. A real Schur form of ``A_h`` with the *slow* eigenvalues (``|lambda| r <=
   FAST``) first, decoupled from the fast ones by a Sylvester equation
   (Bavely and Stewart, 1979), and the fast block diagonalised into real
   ``1 x 1`` and ``2 x 2`` blocks where its eigenvector basis is well
   conditioned (else it stays one block). This gives a float basis ``S``.
2. ``S^{-1}`` and ``B = S^{-1} A_h S`` are enclosed in ball arithmetic, so the
   basis need not be exact: ``B`` is its block-diagonal part ``B_D`` plus a
   remainder whose norm ``eps`` is bounded rigorously (rounding level).
3. Each fast block ``B_j`` gets an entrywise enclosure of the interpolation
   error ``F_j(t) = e^{B_j t} - I - (t/r)(e^{B_j r} - I)`` over ``t`` in
   ``[0, r]`` and of ``int_0^r |e^{B_j s}| ds`` (the gain of a bounded input):
   in closed form for a real eigenvalue (``e^{lambda t}`` is convex, so
   ``F_j`` lies in ``[F_j(t*), 0]`` with ``t*`` its stationary point; the
   step itself interpolates it with its own parameter, exactly) and for a
   complex pair that turns little in a step, and by subdividing the step into
   pieces with ``|B_j| h <= 1/4`` otherwise. Both
   are ``O(1)``, whatever ``|lambda| r``: a fast decaying mode is covered by
   the hull of its step ends plus a box of its own size.
4. The slow block keeps the Taylor correction (Althoff 2010), now with a small
   ``|B_s| r``.

Replacing ``B`` by ``B_D`` changes ``e^{B t}`` by at most
``M (e^{M eps t} - 1)`` in the infinity norm, with ``M`` a bound of
``|e^{B_D t}|`` over the step (Gronwall); that bound is added to every modal
coordinate, so the enclosure is rigorous for the exact ``A_h``.

Examples
--------
>>> import numpy as np
>>> Ah = np.array([[-2000.0, 0.0, 0.0], [1999.0, -1.0, 1.0], [0.0, 0.0, 0.0]])
>>> basis = block_basis(Ah, 0.1)
>>> [b.stop - b.start for b in basis.blocks], basis.n_slow
([2, 1], 2)

A badly scaled mode (large entries, slow eigenvalues) is balanced instead:

>>> scaled = block_basis(np.array([[0.0, 1e4, 0.0], [-1e-4, 0.0, 0.0], [0.0, 0.0, 0.0]]), 0.1)
>>> np.diag(scaled.S).tolist(), len(scaled.blocks)
([8192.0, 1.0, 1.0], 1)
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from flint import acb, arb, arb_mat

from hybridlab.reachability.balls import enclosure, inverse_enclosure, scalar_bounds, to_arb

__all__ = ["FAST", "Basis", "FastBlock", "block_basis", "fast_block", "eigenbasis"]

FAST = 0.25
"""An eigenvalue is fast for a step ``r`` when ``|lambda| r`` exceeds this."""

_MAX_REDUCTION_CONDITION = 1e4  # reductions box in eigenvector bases better than this
_MAX_PIECES = 4096        # subdivision of a step for a non-scalar fast block
_PIECE_NORM = 0.25        # |B_j| h per piece
_MAX_BALANCE = 16         # balancing scales stay within 2**-16 .. 2**16
_MAX_SPIN = 1.5           # a complex pair turning less than this per step is "monotone"


@dataclass(frozen=True, eq=False)
class Basis:
    """``A_h = S B S^{-1}`` with ``B`` block diagonal up to ``coupling``.

    Attributes
    ----------
    S : ndarray
        The basis (columns), float.
    inv_mid, inv_rad : ndarray
        ``S^{-1}`` lies entrywise in ``inv_mid +- inv_rad``.
    blocks : list of slice
        The diagonal blocks of ``B``; the first is the slow block.
    B : ndarray
        The block-diagonal part ``B_D`` (floats, exact as given).
    perturbation : ndarray
        Entrywise upper bound of ``|B - B_D|`` for the exact ``B``.
    eps : float
        Upper bound of ``|B - B_D|_inf`` for the exact ``B``.

    Examples
    --------
    A mode with one fast eigenvalue (-2000) and two slow ones (-1 and the homogeneous 0),
    for steps of 0.1:

    >>> Ah = np.array([[-2000.0, 0.0, 0.0], [1999.0, -1.0, 1.0], [0.0, 0.0, 0.0]])
    >>> basis = block_basis(Ah, 0.1)
    >>> basis.blocks, np.diag(basis.B).tolist()
    ([slice(0, 2, None), slice(2, 3, None)], [-1.0, 0.0, -2000.0])
    >>> x = np.array([1.0, 2.0, 1.0])
    >>> bool(np.allclose(basis.from_modal(basis.to_modal(x)), x)), bool(basis.eps < 1e-9)
    (True, True)
    """

    S: np.ndarray
    inv_mid: np.ndarray
    inv_rad: np.ndarray
    blocks: list[slice]
    B: np.ndarray
    perturbation: np.ndarray
    eps: float

    @property
    def n_slow(self) -> int:
        return self.blocks[0].stop

    @property
    def scaling(self) -> np.ndarray | None:
        """The diagonal of ``S`` when ``S`` is diagonal (a balancing), else ``None``."""
        d = np.diag(self.S)
        return d if np.count_nonzero(self.S) == np.count_nonzero(d) else None

    def to_modal(self, X: np.ndarray) -> np.ndarray:
        """``inv_mid @ X`` (a row scaling when ``S`` is diagonal)."""
        d = self.scaling
        if d is None:
            return self.inv_mid @ X
        inv = np.diag(self.inv_mid)
        return inv[:, None] * X if X.ndim == 2 else inv * X

    def from_modal(self, X: np.ndarray, cols: np.ndarray | slice | None = None) -> np.ndarray:
        """``S[:, cols] @ X`` (a row scaling when ``S`` is diagonal and ``cols`` is all)."""
        d = self.scaling
        if cols is None or (isinstance(cols, np.ndarray) and cols.all()):
            if d is not None:
                return d[:, None] * X if X.ndim == 2 else d * X
            return self.S @ X
        return self.S[:, cols] @ X


@dataclass(frozen=True, eq=False)
class FastBlock:
    """Enclosures of one fast block over ``[0, r]``.

    ``F(t)`` lies entrywise in ``F_mid +- F_rad``; ``gain`` bounds
    ``int_0^r |e^{B_j s}| ds`` entrywise; ``sup_norm`` bounds ``|e^{B_j t}|_inf``.
    ``monotone``: ``e^{B_j t} y`` is the segment from ``y`` to ``e^{B_j r} y``,
    interpolated with its own parameter, plus a disc of radius ``spin |y|_2``: a real
    ``1 x 1`` block (``spin = 0``), or a complex pair ``[[a, b], [-b, a]]`` that
    turns little in a step (``e^{at}`` is monotone; ``spin`` bounds how far the
    rotation takes the path from the chord, :func:`_chord_deviation`).

    Examples
    --------
    ``e^{-1000 t}`` over a step of 0.1: ``F`` lies in ``[-0.944, 0]`` and the input gain
    is ``int_0^0.1 e^{-1000 s} ds = 1e-3``:

    >>> blk = fast_block(np.array([[-1000.0]]), 0.1)
    >>> blk.monotone, blk.sup_norm, round(float(blk.F_mid[0, 0] - blk.F_rad[0, 0]), 4)
    (True, 1.0, -0.9439)
    >>> round(float(blk.gain[0, 0]), 12)
    0.001
    """

    F_mid: np.ndarray
    F_rad: np.ndarray
    gain: np.ndarray
    sup_norm: float
    monotone: bool = False
    spin: float = 0.0


def _is_slow(r: float):  # noqa: ANN202 - scipy's sort callback
    return lambda re, im: math.hypot(re, im) * r <= FAST


def block_basis(Ah: np.ndarray, r: float, stiff: bool = True) -> Basis | None:
    """The basis of ``A_h`` for steps ``r``, or ``None`` when the state coordinates do.

    A mode with fast eigenvalues gets the stiff basis; a mode without them but with
    a large ``|A_h| r`` (badly scaled: large entries, slow dynamics) gets a diagonal
    power-of-two balancing (Parlett and Reinsch), which changes no eigenvalue and
    rounds nothing. The slow block of a stiff basis is balanced too. With
    ``stiff=False`` only the balancing is tried. ``None`` also when the basis
    cannot be certified (``S`` numerically singular).

    Examples
    --------
    >>> Ah = np.array([[-2000.0, 0.0, 0.0], [1999.0, -1.0, 1.0], [0.0, 0.0, 0.0]])
    >>> basis = block_basis(Ah, 0.1)  # stiff: a slow block of 2, a fast one of 1
    >>> [b.stop - b.start for b in basis.blocks], basis.n_slow
    ([2, 1], 2)
    >>> block_basis(np.array([[-1.0, 0.0], [0.0, 0.0]]), 0.1) is None  # mild: state axes
    True
    """
    lam = np.linalg.eigvals(Ah)
    if not np.all(np.isfinite(lam)):
        return None
    n = Ah.shape[0]
    S: np.ndarray | None
    sizes: list[int]
    if not stiff or np.max(np.abs(lam)) * r <= FAST:
        if np.max(np.sum(np.abs(Ah), axis=1)) * r <= FAST:
            return None
        S, sizes, n_slow = np.eye(n), [], n
    else:
        found = _stiff_basis(Ah, r)
        if found is None:
            return None
        S, sizes, n_slow = found
    S = _balance_slow(Ah, S, n_slow)
    if S is None:
        return None
    return _certify(Ah, S, n_slow, sizes)


def _stiff_basis(Ah: np.ndarray, r: float) -> tuple[np.ndarray, list[int], int] | None:
    """``(S, fast block sizes, number of slow coordinates)``, float, uncertified."""
    from scipy import linalg  # on first use: mild modes never need it

    n = Ah.shape[0]
    T, Q, n_slow = linalg.schur(Ah, output="real", sort=_is_slow(r))
    if n_slow == n or n_slow == 0:
        return None
    T11, T12, T22 = T[:n_slow, :n_slow], T[:n_slow, n_slow:], T[n_slow:, n_slow:]
    X = linalg.solve_sylvester(T11, -T22, -T12)  # T11 X - X T22 = -T12
    decouple = np.eye(n)
    decouple[:n_slow, n_slow:] = X
    V, fast_sizes = _real_eigenbasis(T22)
    basis = np.eye(n)
    basis[n_slow:, n_slow:] = V
    S = Q @ decouple @ basis
    if not np.all(np.isfinite(S)):
        return None
    # unit columns scale well; the two columns of a complex pair share one scale, which
    # keeps its block in the form [[a, b], [-b, a]]
    scale = np.max(np.abs(S), axis=0)
    start = n_slow
    for size in fast_sizes:
        scale[start:start + size] = np.max(scale[start:start + size])
        start += size
    return S / scale, fast_sizes, n_slow


def _balance_slow(Ah: np.ndarray, S: np.ndarray, n_slow: int) -> np.ndarray | None:
    """``S`` with its slow columns scaled by powers of two that balance the slow block."""
    from scipy import linalg  # on first use: mild modes never need it

    try:
        B = np.linalg.solve(S, Ah @ S)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(B)):
        return None
    slow = B[:n_slow, :n_slow]
    _, (scale, _) = linalg.matrix_balance(slow, permute=False, separate=True)
    # a zero row (the homogeneous coordinate, a constant) cannot be balanced: the
    # iteration shrinks its column without bound, which would make S nearly singular
    scale = np.exp2(np.clip(np.log2(scale), -_MAX_BALANCE, _MAX_BALANCE))
    balanced = slow * (scale[None, :] / scale[:, None])
    if np.max(np.sum(np.abs(balanced), axis=1)) >= np.max(np.sum(np.abs(slow), axis=1)):
        return S
    S = S.copy()
    S[:, :n_slow] *= scale
    return S


def _certify(Ah: np.ndarray, S: np.ndarray, n_slow: int, fast_sizes: list[int]) -> Basis | None:
    """Enclose ``S^{-1}`` and ``S^{-1} A_h S`` in ball arithmetic."""
    try:
        S_ball = to_arb(S)
        inv_ball = S_ball.inv()
    except (ZeroDivisionError, ValueError):
        return None
    inv_mid, inv_rad = enclosure(inv_ball)
    if not np.all(np.isfinite(inv_rad)):
        return None
    B_mid, B_rad = enclosure(inv_ball * to_arb(Ah) * S_ball)
    blocks = [slice(0, n_slow)]
    start = n_slow
    for size in fast_sizes:
        blocks.append(slice(start, start + size))
        start += size
    B = np.zeros_like(B_mid)
    for b in blocks:
        B[b, b] = _rotation_form(B_mid[b, b])
    perturbation = np.nextafter(np.abs(B_mid - B) + B_rad, np.inf)
    eps = float(np.max(_up_sum(perturbation)))
    return Basis(S=S, inv_mid=inv_mid, inv_rad=inv_rad, blocks=blocks, B=B,
                 perturbation=perturbation, eps=eps)


def _rotation_form(Bj: np.ndarray) -> np.ndarray:
    """A ``2 x 2`` block of a complex pair as exactly ``[[a, b], [-b, a]]`` (the difference
    is rounding level and goes into the basis's ``eps``); other blocks unchanged."""
    if Bj.shape != (2, 2) or Bj[0, 1] * Bj[1, 0] >= 0:
        return Bj
    a = 0.5 * (Bj[0, 0] + Bj[1, 1])
    b = 0.5 * (Bj[0, 1] - Bj[1, 0])
    scale = max(abs(a), abs(b))
    if abs(Bj[0, 0] - Bj[1, 1]) > 1e-9 * scale or abs(Bj[0, 1] + Bj[1, 0]) > 1e-9 * scale:
        return Bj
    return np.array([[a, b], [-b, a]])


def eigenbasis(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(S, inv_mid, inv_rad)``: a real eigenvector basis of ``A`` (``2 x 2`` blocks for
    complex pairs, the columns of a pair sharing one scale) with ``S^{-1}`` enclosed, or
    ``None`` when ``A`` has no well-conditioned one (defective or nearly so).

    In these coordinates a stable ``e^{A r}`` shrinks every real mode's box, which is
    where reductions should box (:meth:`Zonotope.reduce`).

    Examples
    --------
    >>> S, inv_mid, inv_rad = eigenbasis(np.array([[-1.0, 100.0], [0.0, -2.0]]))
    >>> bool(np.allclose(inv_mid @ S, np.eye(2)) and inv_rad.max() < 1e-12)
    True
    """
    n = A.shape[0]
    if n == 0:
        return None
    V, sizes = _real_eigenbasis(A, max_condition=_MAX_REDUCTION_CONDITION)
    if sizes == [n] and n > 1:
        return None  # no good basis: _real_eigenbasis fell back to the identity
    scale = np.max(np.abs(V), axis=0)
    start = 0
    for size in sizes:
        scale[start:start + size] = np.max(scale[start:start + size])
        start += size
    S = V / scale
    inverse = inverse_enclosure(S)
    return None if inverse is None else (S, *inverse)


def _up_sum(M: np.ndarray) -> np.ndarray:
    return np.nextafter(np.sum(M, axis=1) * (1 + 2.0 ** -40), np.inf)


def _real_eigenbasis(T: np.ndarray, max_condition: float = 1e8
                     ) -> tuple[np.ndarray, list[int]]:
    """Real eigenvectors of ``T`` (``2 x 2`` blocks for complex pairs) and the block sizes.

    Falls back to the identity (one block) when the basis is ill-conditioned,
    as for repeated or nearly repeated fast eigenvalues.
    """
    m = T.shape[0]
    whole = (np.eye(m), [m])
    w, V = np.linalg.eig(T)
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(V))):
        return whole
    order = np.argsort(w.real, kind="stable")
    w, V = w[order], V[:, order]
    if np.all(w.imag == 0):
        Vr = V.real
        sizes = [1] * m
    else:
        pairs = _conjugate_order(w)
        if pairs is None:
            return whole
        w, V = w[pairs], V[:, pairs]
        Vr = V.real.copy()  # a pair (v, conj v) spans (-Im v, Re v), as scipy's cdf2rdf
        sizes = []
        i = 0
        while i < m:
            size = 2 if w[i].imag != 0 else 1
            if size == 2:
                Vr[:, i], Vr[:, i + 1] = -V[:, i].imag, V[:, i].real
            sizes.append(size)
            i += size
    if not np.all(np.isfinite(Vr)) or np.linalg.cond(Vr) > max_condition:
        return whole
    return Vr, sizes


def _conjugate_order(w: np.ndarray) -> np.ndarray | None:
    """An order with each complex eigenvalue (positive imaginary part) followed by its
    conjugate, as :func:`scipy.linalg.cdf2rdf` needs, or ``None`` if one has no partner."""
    used = np.zeros(w.size, dtype=bool)
    order: list[int] = []
    for i in range(w.size):
        if used[i]:
            continue
        used[i] = True
        if w[i].imag == 0:
            order.append(i)
            continue
        rest = np.flatnonzero(~used)
        if rest.size == 0:
            return None
        j = int(rest[np.argmin(np.abs(w[rest] - np.conj(w[i])))])
        if abs(w[j] - np.conj(w[i])) > 1e-8 * max(abs(w[i]), 1.0):
            return None
        used[j] = True
        order.extend([i, j] if w[i].imag > 0 else [j, i])
    return np.array(order)


def fast_block(Bj: np.ndarray, r: float) -> FastBlock:
    """Enclosures of ``F_j(t)``, of the input gain and of ``|e^{B_j t}|`` over ``[0, r]``.

    Examples
    --------
    >>> blk = fast_block(np.array([[-1000.0]]), 0.1)
    >>> lo = blk.F_mid[0, 0] - blk.F_rad[0, 0]
    >>> t = np.linspace(0, 0.1, 100001)
    >>> f = np.exp(-1000 * t) - 1 - t / 0.1 * (np.exp(-100) - 1)
    >>> bool(lo <= f.min() and blk.F_mid[0, 0] + blk.F_rad[0, 0] >= 0)
    True
    >>> bool(abs(blk.gain[0, 0] - 1e-3) < 1e-12)
    True
    """
    if Bj.shape == (1, 1):
        return _scalar_block(float(Bj[0, 0]), r)
    if Bj.shape == (2, 2) and Bj[0, 0] == Bj[1, 1] and Bj[0, 1] == -Bj[1, 0] \
            and abs(Bj[0, 1]) * r <= _MAX_SPIN:
        return _turning_block(float(Bj[0, 0]), float(Bj[0, 1]), r)
    return _subdivided_block(Bj, r)


def _scalar_block(lam: float, r: float) -> FastBlock:
    a_lam, a_r = arb(lam), arb(r)
    phi = (a_lam * a_r).exp()
    # e^{lam t} is convex: the chord lies above it, so F <= 0 with its minimum where
    # lam e^{lam t} equals the chord's slope
    t_star = (((phi - 1) / (a_lam * a_r)).log()) / a_lam
    f_star = (a_lam * t_star).exp() - 1 - (t_star / a_r) * (phi - 1)
    f_lo, _ = scalar_bounds(f_star)
    f_lo = min(f_lo, 0.0)
    _, gain = scalar_bounds((phi - 1) / a_lam)
    _, phi_hi = scalar_bounds(phi)
    mid = 0.5 * f_lo
    rad = math.nextafter(-0.5 * f_lo, math.inf)
    return FastBlock(F_mid=np.array([[mid]]), F_rad=np.array([[rad]]),
                     gain=np.array([[gain]]), sup_norm=max(1.0, phi_hi), monotone=True)


def _turning_block(a: float, b: float, r: float) -> FastBlock:
    """``[[a, b], [-b, a]]``: ``e^{Bt} = e^{at} R(bt)``. With ``theta`` chosen so that
    ``e^{at} = (1 - theta) + theta e^{ar}``, the path differs from the segment point
    ``(1 - theta) y + theta e^{Br} y`` by ``M(t) y`` with ``M(t) = e^{Bt} - (1 - theta) I
    - theta e^{Br}``, a matrix of the same rotation-scaling form, whose 2-norm is the modulus
    of the complex number ``m(t)`` of :func:`_chord_deviation`; the input gain is
    ``int_0^r e^{as} ds`` in every entry."""
    a_a, a_r = arb(a), arb(r)
    growth = (a_a * a_r).exp()
    _, growth_hi = scalar_bounds(growth)
    _, gain = scalar_bounds(((growth - 1) / a_a) if a != 0 else a_r)
    return FastBlock(F_mid=np.zeros((2, 2)), F_rad=np.zeros((2, 2)),
                     gain=np.full((2, 2), gain), sup_norm=math.nextafter(
                         2.0 * max(1.0, growth_hi), math.inf),
                     monotone=True, spin=_chord_deviation(a * r, b * r))


def _chord_deviation(alpha: float, beta: float, budget: int = _MAX_PIECES) -> float:
    """Upper bound of ``|m(s)|`` over ``s`` in ``[0, 1]``, where ``m(s) = e^{lam s} - 1 +
    theta(s) (1 - e^{lam})``, ``lam = alpha + i beta`` and ``theta(s) = (e^{alpha s} - 1) /
    (e^{alpha} - 1)`` (``s`` when ``alpha = 0``).

    ``m`` is how far ``e^{lam s}`` lies from the chord point with the parameter that
    matches the modulus; it is second order in ``beta`` for a slow decay and about
    ``|beta| / (e |alpha|)`` for a fast one. Each piece ``[c - h, c + h]`` is bounded by
    Taylor's theorem, ``|m(c)| + h |m'(c)| + h^2 / 2 max |m''|``, in ball arithmetic (the
    last term over the whole piece); the piece with the largest bound is halved until it
    is within 5 % of the largest value seen, or ``budget`` pieces were made.

    Examples
    --------
    >>> s = np.linspace(0.0, 1.0, 10001)
    >>> theta = np.expm1(-0.3 * s) / np.expm1(-0.3)
    >>> m = np.exp((-0.3 + 0.4j) * s) - 1 + theta * (1 - np.exp(-0.3 + 0.4j))
    >>> bound = _chord_deviation(-0.3, 0.4)
    >>> bool(np.abs(m).max() <= bound <= 1.06 * np.abs(m).max())
    True
    """
    lam = acb(alpha, beta)
    lam2 = lam * lam
    pull = 1 - lam.exp()
    denominator = arb(alpha).expm1()

    def terms(s: arb) -> tuple[acb, acb, acb]:
        e = (lam * s).exp()
        if alpha == 0:
            theta, d_theta, dd_theta = s, arb(1), arb(0)
        else:
            ea = (arb(alpha) * s).exp()
            theta, d_theta = (arb(alpha) * s).expm1() / denominator, alpha * ea / denominator
            dd_theta = alpha * alpha * ea / denominator
        return e - 1 + theta * pull, lam * e + d_theta * pull, lam2 * e + dd_theta * pull

    def piece(c: float, h: float) -> tuple[float, float]:
        value, slope, _ = terms(arb(c))
        _, _, curve = terms(arb(c, h))
        low, _ = scalar_bounds(abs(value))
        _, high = scalar_bounds(abs(value) + h * abs(slope) + 0.5 * h * h * abs(curve))
        return low, high

    heap: list[tuple[float, float, float]] = []  # (-bound, centre, half width)
    seen = 0.0
    for k in range(8):
        low, high = piece((k + 0.5) / 8, 1 / 16)
        seen = max(seen, low)
        heapq.heappush(heap, (-high, (k + 0.5) / 8, 1 / 16))
    for _ in range(budget):
        high, c, h = heap[0]
        if -high <= 1.05 * seen:
            break
        heapq.heappop(heap)
        for child in (c - 0.5 * h, c + 0.5 * h):
            low, high_child = piece(child, 0.5 * h)
            seen = max(seen, low)
            heapq.heappush(heap, (-high_child, child, 0.5 * h))
    return math.nextafter(-heap[0][0], math.inf)


def _subdivided_block(Bj: np.ndarray, r: float) -> FastBlock:
    m = Bj.shape[0]
    norm = float(np.max(np.sum(np.abs(Bj), axis=1)))
    pieces = int(min(_MAX_PIECES, max(1, math.ceil(norm * r / _PIECE_NORM))))
    B_ball = to_arb(Bj)
    h = arb(r) / pieces
    _, h_hi = scalar_bounds(h)
    piece = arb(0.5 * h_hi, 0.5 * h_hi)  # contains every s in [0, h]
    within = (B_ball * piece).exp()  # e^{B s} for every such s
    phi = (B_ball * arb(r)).exp()
    eye = arb_mat([[1 if i == j else 0 for j in range(m)] for i in range(m)])
    slope = (phi - eye) * (1 / arb(r))
    lo = np.full((m, m), np.inf)
    hi = np.full((m, m), -np.inf)
    gain = np.zeros((m, m))
    sup_norm = 0.0
    for k in range(pieces):
        span = h * k + piece  # every t in the piece
        # each start e^{B t_k} directly: a product of balls would wrap (grow) step by step
        E = (B_ball * (h * k)).exp() * within
        F = E - eye - slope * span
        F_mid, F_rad = enclosure(F)
        lo = np.minimum(lo, F_mid - F_rad)
        hi = np.maximum(hi, F_mid + F_rad)
        E_mid, E_rad = enclosure(E)
        E_abs = np.abs(E_mid) + E_rad
        sup_norm = max(sup_norm, float(np.max(np.sum(E_abs, axis=1))))
        gain += E_abs
    gain = np.nextafter(gain * h_hi * (1 + 2.0 ** -40), np.inf)
    mid = 0.5 * lo + 0.5 * hi
    rad = np.nextafter(np.maximum(hi - mid, mid - lo), np.inf)
    return FastBlock(F_mid=mid, F_rad=rad, gain=gain,
                     sup_norm=math.nextafter(sup_norm * (1 + 2.0 ** -40), math.inf))
