"""A result in words: the one-line ``repr`` and the multi-line :meth:`SimulationResult.summary`.

Both are bounded whatever the size of the run: counts stand for the event log and the
segments, long lists of states or transitions are cut with the number left out, and every
name from a model file goes through :func:`hybridlab._text.printable`.
"""

from __future__ import annotations

import textwrap
from collections import Counter
from typing import TYPE_CHECKING

from hybridlab._text import printable

if TYPE_CHECKING:
    from hybridlab.simulation.result import SimulationResult

#: the most states, transitions or characters of a name a summary spells out
_MOST_STATES, _MOST_TRANSITIONS, _LONGEST_NAME = 12, 10, 60


def _name(text: str) -> str:
    """``text`` printable on one line and at most ``_LONGEST_NAME`` characters."""
    text = printable(text)
    return text if len(text) <= _LONGEST_NAME else text[:_LONGEST_NAME - 3] + "..."


def _listed(items: list[str], most: int, what: str) -> list[str]:
    """The first ``most`` of ``items``, and a last item saying how many were left out."""
    if len(items) <= most:
        return items
    return [*items[:most], f"... {len(items) - most} more {what}"]


def _span(result: SimulationResult) -> str:
    segments = result.segments
    t0 = float(segments.t_start[0]) if len(segments) else float(result.final.t)
    return f"t {t0!r} -> {float(result.final.t)!r}, j={result.final.j}"


def _count(k: int, noun: str) -> str:
    return f"{k} {noun}{'' if k == 1 else 's'}"


def _counts(result: SimulationResult) -> str:
    stats = result.stats
    steps = f", {_count(stats['steps'], 'step')}" if "steps" in stats else ""
    return (f"{_count(len(result.segments), 'segment')}, {_count(len(result.events), 'event')} "
            f"({_count(len(result.jumps), 'jump')}){steps}")


def short_repr(result: SimulationResult) -> str:
    """One line under 1,000 characters: status, hybrid time reached, counts, states, final mode.

    Examples
    --------
    >>> import hybridlab
    >>> hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, backend="reference")
    <SimulationResult COMPLETED: t 0.0 -> 3.0, j=1; 2 segments, 1 event (1 jump), ... steps; \
states h, v; final mode 'fall'>
    """
    states = ", ".join(_listed([_name(n) for n in result.state_names], _MOST_STATES, "states"))
    return (f"<SimulationResult {result.status.name}: {_span(result)}; {_counts(result)}; "
            f"states {states}; final mode '{_name(result.final.mode)}'>")


def _event_lines(result: SimulationResult) -> list[str]:
    events = result.events
    counts = Counter(zip(events.transition, events.kind, strict=True))
    lines = [f"  {_name(label)}: {_count(k, kind.replace('_', ' '))}"
             for (label, kind), k in counts.most_common()]
    return _listed(lines, _MOST_TRANSITIONS, "transitions")


def summary(result: SimulationResult) -> str:
    """What :meth:`SimulationResult.summary` returns (its example is there)."""
    status, final, stats = result.status, result.final, result.stats
    lines = [f"status: {status.name}: {printable(result.message)}"]
    if not status.ok:
        lines.append(f"  {status.value}")
    lines.append(f"reached: {_span(result)}")
    if result.zeno_time is not None:
        lines.append(f"zeno_time: {result.zeno_time:.12g}")
    lines.append(f"events: {len(result.events)} ({_count(len(result.jumps), 'jump')})")
    lines += _event_lines(result)
    values = _listed([f"{_name(k)}={v:.7g}" for k, v in final.state.items()],
                     _MOST_STATES, "states")
    lines += textwrap.wrap(f"final: mode {_name(final.mode)}, {', '.join(values)}", width=100,
                           subsequent_indent="  ", break_on_hyphens=False)
    run = [f"{stats.get('backend', 'unknown')} backend", _counts(result)]
    run += [f"{stats[key]} {key.replace('_', ' ')}" for key in ("events_located", "refinements")
            if key in stats]
    lines.append("run: " + ", ".join(run))
    lines += [f"{key}: {printable(str(stats[key]))}" for key in ("fallback", "handoff")
              if key in stats]
    return "\n".join(lines)
