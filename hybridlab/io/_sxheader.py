"""The comment lines heading an imported SpaceEx model: what a model file cannot hold."""

from __future__ import annotations

from hybridlab._text import printable
from hybridlab.io.spaceex import ConstraintSet, SpaceExProblem

__all__ = ["problem_header"]


def problem_header(problem: SpaceExProblem) -> str:
    """TOML comment lines describing what the model file cannot hold (initial set, ...).

    Examples
    --------
    >>> from hybridlab.io import load_spaceex
    >>> p = load_spaceex("models/spaceex/bouncing_ball.xml",
    ...                  "models/spaceex/bouncing_ball.cfg")
    >>> print(problem_header(p))
    # imported from models/spaceex/bouncing_ball.xml, models/spaceex/bouncing_ball.cfg
    # initial set: x in [10, 10.2], v in [0, 0]; modes: always
    # forbidden: x >= 10.25
    # time horizon 20, sampling time 0.05, max jumps 10
    """
    lines = [f"# imported from {', '.join(problem.source)}"]
    if isinstance(problem.initial, ConstraintSet):
        init = " and ".join(problem.initial.relations)
    else:
        init = ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in problem.initial.items())
    lines.append(f"# initial set: {init}; modes: {', '.join(problem.initial_modes)}")
    for name, value in problem.params.items():
        if isinstance(value, tuple):
            lines.append(f"# uncertain constant: {name} in [{value[0]:g}, {value[1]:g}]")
    for name, (lo, hi) in problem.inputs.items():
        lines.append(f"# input (varies in time): {name} in [{lo:g}, {hi:g}]")
    for f in problem.forbidden:
        where = f" in modes {', '.join(sorted(f.modes))}" if f.modes is not None else ""
        lines.append(f"# forbidden: {' and '.join(f.relations) or 'everything'}{where}")
    opts = problem.options
    parts = []
    if problem.t_end is not None:
        parts.append(f"time horizon {problem.t_end:g}")
    if opts.time_step is not None:
        parts.append(f"sampling time {opts.time_step:g}")
    if opts.max_jumps is not None:
        parts.append(f"max jumps {opts.max_jumps}")
    if parts:
        lines.append("# " + ", ".join(parts))
    for old, new in problem.renamed.items():
        lines.append(f"# renamed: {old} -> {new}")
    # names and relations come from the XML: none may end a comment line early
    return "\n".join("# " + printable(line[2:]) for line in lines)


