"""Settings of :func:`hybridlab.reach` and of the falsification search."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

__all__ = ["FalsifyOptions", "ReachOptions"]

_CLUSTERING = ("auto", "box", "none", "sweep")
MAX_TAYLOR_ORDER = 7
"""The highest space order of a Taylor model (``ReachOptions.taylor_order``)."""


@dataclass(frozen=True)
class ReachOptions:
    """Knobs of the reachability analysis; see ``docs/verification.md``.

    Attributes
    ----------
    step : float or None
        Time step of the flowpipes. Smaller is tighter (the dense-time bloating
        and the linearisation remainder shrink with it) and slower (linear in
        the number of steps). ``None``: the horizon divided by 400, shortened so
        that no lightly damped oscillation of an affine mode turns more than half
        a radian per step and that a known ``dwell`` has 16 steps
        (:func:`~hybridlab.reachability.api.default_step`).
    order : float
        Zonotope order kept after each step (generators per dimension); excess
        generators are boxed (Girard's method). Higher is tighter and slower.
    taylor_terms : int
        Least number of terms of the Taylor series of the correction terms in
        the slow part of a mode; more are taken (up to 80) until the remainder
        bound, sound for any number of terms, is below ``1e-15``. Modes with
        eigenvalues faster than ``1 / step`` are split by time scale and their
        fast part enclosed in closed form, so the step is not limited by
        stiffness (``docs/verification.md``, "Stiff modes").
    dwell : float or None
        Typical time between jumps, when known (:func:`hybridlab.verify.check_safety`
        takes it from its simulations): the default step gives it at least 16 steps.
    max_jumps : int
        Longest run of jumps followed; a branch cut here makes the result
        incomplete.
    clustering : {"auto", "box", "none", "sweep"}
        How the step sets that hit a guard (each cut to the guard and the
        invariant, as a box) are joined before the reset. ``"auto"``: consecutive
        hits form one group while the group's interval hull stays within twice its
        widest piece in every coordinate, so a short, compact run is one post-jump
        set and a long sweep across the guard becomes several tight ones.
        ``"box"``: the whole run in one box (fewest branches, loosest); a run of
        one hit keeps its own set, cut, where that is no wider on any state.
        ``"none"``: one post-jump set per step (tightest, most branches).
        ``"sweep"``: the whole run as a zonotope that keeps the flowpipe's
        generators plus one along the sweep of its centres, so the correlations
        between states survive the jump (a controller's tracking error stays
        small); it is cut to the guard's and the invariant's linear rows only.
    intersection : {"lp", "box"}
        How a set that hits a guard is cut down to the guard and invariant:
        ``"lp"``: exact interval hull of the zonotope intersected with the linear
        guard and invariant rows (2 n LPs per hit, HiGHS); ``"box"``: clip the
        interval hull with the axis-aligned rows only (no LP).
    max_sets : int
        Budget of flowpipe sets over all branches; exceeding it ends the
        analysis as incomplete.
    max_memory : float
        Budget, in GiB, of the memory the kept flowpipe sets take (their centres
        and generators) over all branches, shared by the pieces of a split initial
        set and by a verdict's analyses; exceeding it ends the analysis as
        incomplete, with the reason (2 by default: an 18-state set of 437
        generators takes 63 KB).
    memory_held : float
        GiB of flowpipe sets that other analyses sharing ``max_memory`` keep (the
        pieces of a split initial set, a verdict's earlier analyses); set by
        :func:`hybridlab.reach` and by verdicts, 0 by default.
    remainder_iterations : int
        Attempts to find a linearisation remainder that encloses itself
        (nonlinear modes).
    fixpoint : bool
        Stop a branch whose initial set lies inside an earlier initial set of
        the same mode (time-invariant models only).
    bloat : float
        Extra relative enlargement of every step's sets, on top of the bounds
        of the floating-point rounding (which are always added). 0 by default.
    time_budget : float or None
        Wall-clock seconds for the whole analysis (all pieces); when they run
        out the analysis stops, incomplete, with the reason and the sets so far
        (so a verdict is UNKNOWN with the tightest bound reached). ``None``: no
        limit beyond ``max_sets``.
    progress : bool or None
        Show progress on standard error once a run takes more than 3 seconds;
        ``None``: when standard error is a terminal.
    deadline : float or None
        The absolute ``time.time()`` at which the analysis stops; set by
        :func:`hybridlab.reach` from ``time_budget`` (pieces on other processes
        share it).
    flowpipe : {"zonotope", "taylor"}
        Set representation of the flowpipes of nonlinear modes. ``"zonotope"``:
        conservative linearisation, zonotopes with a Lagrange remainder.
        ``"taylor"``: Taylor models, polynomial in the initial set, validated by
        Picard iteration (:mod:`hybridlab.reachability.taylor`), for modes without
        switching functions and without time-varying inputs (others keep
        zonotopes); they follow wide initial sets of strongly nonlinear flows in
        one piece, at a higher cost per step. Affine modes are exact either way.
    observed : tuple of str
        Discrete variables to follow exactly although nothing in the model reads them.
        Others that nothing reads (a sensor's output that the logic does not use) are
        left out with the transitions that only set them, which keep the mode: each
        such transition would otherwise double the branches wherever it may fire. Such a
        variable is reported over the hull of its initial value and every constant its
        transitions assign (:mod:`hybridlab.reachability.slicing`).
        :func:`hybridlab.verify.check_safety` adds the variables its specs read.
    split : int or "auto"
        An integer ``k``: split the initial set into ``k`` pieces along each of its
        generators (each uncertain initial state or parameter) and analyse
        the pieces separately: ``k ** m`` analyses, each with a smaller set,
        so nonlinear remainders and clustering hulls shrink. ``"auto"``: bisect
        only where it is needed: a piece whose set outgrew its remainder (or, in
        :func:`hybridlab.verify.check_safety`, did not prove a spec) is cut in two
        along the initial-set direction its Taylor model bends most in (the
        direction halved least so far where that is not known) and both halves are
        analysed again, within ``max_pieces`` analyses
        (:mod:`hybridlab.reachability.bisection`).
    max_pieces : int
        The most analyses ``split="auto"`` runs, the failed pieces included.
    taylor_order : int or None
        Degree of the Taylor models in the initial-set variables (the *space
        order*, 1 to 7). ``None``: the highest whose number of monomials stays
        within 120 (7 for up to 3 uncertain directions, 3 for 5 to 7;
        :func:`hybridlab.reachability.taylor.orders`). A higher order keeps more of a
        wide set's curvature, at about twice the time per degree.
    sign_phases : bool
        Split a set that lies across the surface of a switching function
        (Coulomb friction's ``sign(v)``) whose sign moves it noticeably within a
        step, and follow each side's flow, and the sliding flow on the surface, as
        phases of the analysis (:mod:`hybridlab.reachability.phases`); each split
        and each change of phase counts as a jump. ``False``: the sign stays an
        input, free in ``[-1, 1]`` where the set meets the surface.
    lift_clocks : bool
        Step a mode whose flow is affine but for a polynomial in its clocks and
        constants (a timed reference) as an affine chain over those monomials
        (:mod:`hybridlab.reachability.lifting`) instead of linearising it step by
        step. Off by default: its tighter sets can make a set at a friction surface
        split into stick and slip phases again and again (``sign_phases``), which
        costs far more steps.

    Examples
    --------
    >>> ReachOptions(step=0.01).updated(max_jumps=5).max_jumps
    5
    """

    step: float | None = None
    order: float = 20.0
    taylor_terms: int = 10
    dwell: float | None = None
    max_jumps: int = 30
    clustering: str = "box"
    intersection: str = "lp"
    max_sets: int = 200_000
    max_memory: float = 2.0
    memory_held: float = 0.0
    remainder_iterations: int = 8
    fixpoint: bool = True
    bloat: float = 0.0
    split: int | str = 1
    max_pieces: int = 64
    taylor_order: int | None = None
    flowpipe: str = "zonotope"
    time_budget: float | None = None
    progress: bool | None = None
    deadline: float | None = None
    observed: tuple[str, ...] = ()
    sign_phases: bool = True
    lift_clocks: bool = False

    def __post_init__(self) -> None:
        if self.step is not None and not (float(self.step) > 0 and float(self.step) < 1e300):
            raise ValueError(f"step must be a positive number (got {self.step!r})")
        if self.dwell is not None and not (float(self.dwell) > 0 and float(self.dwell) < 1e300):
            raise ValueError(f"dwell must be a positive number (got {self.dwell!r})")
        if not self.order >= 1:
            raise ValueError(f"order must be at least 1 (got {self.order!r})")
        if not (isinstance(self.taylor_terms, int) and self.taylor_terms >= 2):
            raise ValueError(f"taylor_terms must be an integer >= 2 (got {self.taylor_terms!r})")
        if not (isinstance(self.max_jumps, int) and self.max_jumps >= 0):
            raise ValueError(f"max_jumps must be an integer >= 0 (got {self.max_jumps!r})")
        if self.clustering not in _CLUSTERING:
            raise ValueError(f"clustering must be one of {', '.join(_CLUSTERING)} "
                             f"(got {self.clustering!r})")
        if self.intersection not in ("lp", "box"):
            raise ValueError(f"intersection must be 'lp' or 'box' (got {self.intersection!r})")
        if not (isinstance(self.max_sets, int) and self.max_sets >= 1):
            raise ValueError(f"max_sets must be a positive integer (got {self.max_sets!r})")
        if not (isinstance(self.max_memory, (int, float)) and 0 < self.max_memory < math.inf):
            raise ValueError(f"max_memory must be a positive number of GiB "
                             f"(got {self.max_memory!r})")
        if not (isinstance(self.memory_held, (int, float)) and 0 <= self.memory_held < math.inf):
            raise ValueError(f"memory_held must be a number of GiB >= 0 "
                             f"(got {self.memory_held!r})")
        if not (isinstance(self.remainder_iterations, int) and self.remainder_iterations >= 1):
            raise ValueError("remainder_iterations must be a positive integer "
                             f"(got {self.remainder_iterations!r})")
        if self.split != "auto" and not (isinstance(self.split, int) and self.split >= 1):
            raise ValueError(f"split must be a positive integer or 'auto' (got {self.split!r})")
        if not (isinstance(self.max_pieces, int) and self.max_pieces >= 1):
            raise ValueError(f"max_pieces must be a positive integer (got {self.max_pieces!r})")
        if self.taylor_order is not None and not (
                isinstance(self.taylor_order, int) and 1 <= self.taylor_order <= MAX_TAYLOR_ORDER):
            raise ValueError(f"taylor_order must be an integer from 1 to {MAX_TAYLOR_ORDER} "
                             f"(got {self.taylor_order!r})")
        if self.flowpipe not in ("zonotope", "taylor"):
            raise ValueError(f"flowpipe must be 'zonotope' or 'taylor' (got {self.flowpipe!r})")
        if not 0 <= self.bloat < 1e-3:
            raise ValueError(f"bloat must be in [0, 1e-3) (got {self.bloat!r})")
        if isinstance(self.observed, str) or not all(isinstance(n, str) for n in self.observed):
            raise ValueError(f"observed must be a sequence of names (got {self.observed!r})")
        object.__setattr__(self, "observed", tuple(self.observed))
        if self.time_budget is not None and not (0 < float(self.time_budget) < 1e300):
            raise ValueError(f"time_budget must be a positive number of seconds "
                             f"(got {self.time_budget!r})")

    def updated(self, **changes: Any) -> ReachOptions:
        """A copy with ``changes`` applied (unknown names are a ``TypeError``)."""
        known = {f.name for f in fields(self)}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise TypeError(f"unknown reach option(s): {', '.join(unknown)}; expected one of: "
                            f"{', '.join(sorted(known))}")
        return replace(self, **changes)


@dataclass(frozen=True)
class FalsifyOptions:
    """Budget and seed of the falsification search.

    Attributes
    ----------
    samples : int
        Latin-hypercube samples of the uncertain box.
    max_corner_dims : int
        Up to this many uncertain dimensions every corner is simulated;
        beyond it ``corners`` random corners are.
    corners : int
        Random corners when there are more dimensions than ``max_corner_dims``.
    local_evals : int
        Simulations each local optimisation may spend (0: no local search).
    local_starts : int
        Local optimisations per spec, from its best samples.
    seed : int
        Seed of the ``numpy.random.Generator`` (the search is deterministic).

    Examples
    --------
    Only the centre and the corners of the uncertain box, no local search:

    >>> quick = FalsifyOptions(samples=0, local_evals=0)
    >>> quick.max_corner_dims, quick.seed
    (5, 0)
    >>> FalsifyOptions(samples=-1)
    Traceback (most recent call last):
    ...
    ValueError: FalsifyOptions.samples must be a non-negative integer (got -1)
    """

    samples: int = 16
    max_corner_dims: int = 5
    corners: int = 16
    local_evals: int = 40
    local_starts: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("samples", "max_corner_dims", "corners", "local_evals", "local_starts"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise ValueError(f"FalsifyOptions.{name} must be a non-negative integer "
                                 f"(got {value!r})")
