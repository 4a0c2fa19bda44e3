"""What runs in a worker for a split :func:`hybridlab.reach`: one piece of the initial set.

A worker process receives the model as its JSON text (compiled models cannot
be pickled) with everything :func:`~hybridlab.reachability.system.build_system`
needs, compiles it once per process
(:func:`hybridlab.simulation.executors.compiled_for`) and returns the piece's
:class:`ReachResult`. Serial runs and thread pools skip all of this and share
the caller's system.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hybridlab.reachability.constants import mode_constants, with_constants
from hybridlab.reachability.hybrid import run_analysis
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.result import ReachResult
from hybridlab.reachability.sets import Zonotope
from hybridlab.reachability.spec import Spec
from hybridlab.reachability.system import build_system
from hybridlab.simulation.executors import compiled_for

__all__ = ["Piece", "run_piece"]


@dataclass(frozen=True)
class Piece:
    """One piece of a split initial set, as sent to a worker process.

    Attributes
    ----------
    model, key : str
        The model's JSON text and its content hash.
    p : numpy.ndarray
        Parameter vector.
    uncertain, bounded : mapping
        Uncertain constant parameters and bounded inputs, ``name -> (lo, hi)``.
    options : ReachOptions
    mode : str
        Initial mode.
    initial : Zonotope
        This piece of the (extended) initial set.
    t_start, t_end : float
    stop_unproved : tuple of Spec
        Specs whose first unproved set ends the analysis (see :func:`hybridlab.reach`).

    Examples
    --------
    A piece is plain data: it pickles, for a worker process (see :func:`run_piece`).

    >>> import pickle
    >>> import hybridlab
    >>> from hybridlab.simulation.executors import model_key, model_text
    >>> model = hybridlab.load_model("models/thermostat.toml")
    >>> text, compiled = model_text(model), hybridlab.compile_model(model)
    >>> piece = Piece(text, model_key(text), compiled.parameter_vector(), {}, {},
    ...               ReachOptions(step=0.1), "heat", Zonotope([20.0], [[1.0]]), 0.0, 1.0)
    >>> sent = pickle.loads(pickle.dumps(piece))
    >>> sent.key == piece.key, sent.mode, sent.initial.center.tolist(), sent.t_end
    (True, 'heat', [20.0], 1.0)
    """

    model: str
    key: str
    p: np.ndarray
    uncertain: Mapping[str, tuple[float, float]]
    bounded: Mapping[str, tuple[float, float]]
    options: ReachOptions
    mode: str
    initial: Zonotope
    t_start: float
    t_end: float
    stop_unproved: tuple[Spec, ...] = ()


def run_piece(piece: Piece) -> ReachResult:
    """Analyse one piece in this process (building the system from the model text).

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.simulation.executors import model_key, model_text
    >>> model = hybridlab.load_model("models/thermostat.toml")
    >>> text, compiled = model_text(model), hybridlab.compile_model(model)
    >>> piece = Piece(text, model_key(text), compiled.parameter_vector(), {}, {},
    ...               ReachOptions(step=0.1), "heat", Zonotope([20.0], [[1.0]]), 0.0, 1.0)
    >>> result = run_piece(piece)
    >>> result.complete, sorted(result.reachable_modes)
    (True, ['cool', 'heat'])
    """
    compiled = compiled_for(piece.model, piece.key)
    system = build_system(compiled, piece.p, dict(piece.uncertain), dict(piece.bounded))
    system = with_constants(system, mode_constants(system, piece.mode, piece.initial))
    return run_analysis(system, piece.options, piece.mode, piece.initial, piece.t_start,
                        piece.t_end, piece.p, piece.stop_unproved)
