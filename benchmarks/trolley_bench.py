"""What the two trolley benchmarks share: time one job four ways and check its events.

Implementations, all at the same ``method``/``rtol``/``atol``, interleaved run by run:

* ``scipy``: the plain ``solve_ivp`` restart loop of ``scipy_trolley.py``;
* ``scipy+max_step``: the same loop with ``max_step = SAFE_MAX_STEP`` (10 ms), which
  it needs to see every breakaway of the cart (without it a breakaway whose force
  window falls inside one solver step is missed, and the free drop's stick/slip
  history departs from the model's);
* ``hl reference``: ``hybridlab.simulate(..., backend="reference")``;
* ``hl compiled``: ``backend="compiled"`` (printed as n/a when the option or numba
  is missing).

Before anything is timed, ``trolley_check.check`` confirms at tight tolerances that
the scipy program and hybridlab's reference backend produce the same events.
Accuracy is measured against hybridlab's reference backend at ``rtol = 1e-12``,
``atol = 1e-14`` (the "truth"): missing or extra events by name, and the largest
event-time error of observable events (sensor edges, the pendulum's turning points,
manoeuvre transitions) and of the cart's stick/slip events.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import scipy_trolley
import trolley_check
from common import Report, time_calls

import hybridlab

__all__ = ["TOLERANCES", "run_job"]

METHOD = "DOP853"
#: (rtol, atol) levels timed; the middle one is hybridlab's default.
TOLERANCES = ((1e-6, 1e-9), (1e-8, 1e-10), (1e-10, 1e-12))
TRUTH_RTOL, TRUTH_ATOL = 1e-12, 1e-14
#: The trolley jobs take seconds each: at most this many timed repetitions.
MAX_REPEAT = 5
#: calls of one implementation in a row per round (the first is the switched one)
BLOCK = 3
SCENARIOS = {"free_drop": "free_drop", "stop_and_return": "default"}


def _compiled_available() -> bool:
    if "backend" not in hybridlab.SimulationOptions.__dataclass_fields__:
        return False
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def _hl(compiled: hybridlab.CompiledModel, scenario: str, backend: str | None, method: str,
        rtol: float, atol: float) -> tuple[tuple[float, str], ...]:
    kw = {"backend": backend} if backend else {}
    result = hybridlab.simulate(compiled, scenario=scenario, method=method, rtol=rtol,
                                atol=atol, **kw)
    if not result.status.ok:
        raise RuntimeError(f"hybridlab stopped early: {result.status.name}: {result.message}")
    if backend == "compiled" and result.stats.get("backend") not in (None, "compiled"):
        raise RuntimeError(f"backend='compiled' fell back to {result.stats.get('backend')!r}")
    return trolley_check.hybridlab_events(result)


def _scipy(job: str, method: str, rtol: float, atol: float,
           max_step: float) -> tuple[tuple[float, str], ...]:
    fn = scipy_trolley.free_drop if job == "free_drop" else scipy_trolley.stop_and_return
    return fn(method=method, rtol=rtol, atol=atol, max_step=max_step).events


def _sci(x: float) -> str:
    return "nan" if math.isnan(x) else f"{x:.1e}"


def run_job(job: str, repeat: int, name: str, title: str) -> Report:
    """Check, time and measure the accuracy of ``job`` ("free_drop" or "stop_and_return")."""
    scenario = SCENARIOS[job]
    repeat = min(repeat, MAX_REPEAT)
    compiled = hybridlab.compile_model(hybridlab.load_model(scipy_trolley.MODEL))
    agreement = trolley_check.check(job, compiled)
    horizon = trolley_check.FREE_DROP_FRICTION_HORIZON if job == "free_drop" else math.inf
    ref = trolley_check.reference_backend().get("backend")
    truth = _hl(compiled, scenario, ref, METHOD, TRUTH_RTOL, TRUTH_ATOL)
    has_compiled = _compiled_available()

    labels = ["scipy", "scipy+max_step", "hl reference", "hl compiled"]
    report = Report(name, title)
    speed_rows, acc_rows = [], []
    for rtol, atol in TOLERANCES:
        fns: list[Callable[[], Any]] = [
            lambda r=rtol, a=atol: _scipy(job, METHOD, r, a, math.inf),
            lambda r=rtol, a=atol: _scipy(job, METHOD, r, a, trolley_check.SAFE_MAX_STEP),
            lambda r=rtol, a=atol: _hl(compiled, scenario, ref, METHOD, r, a),
        ]
        if has_compiled:
            fns.append(lambda r=rtol, a=atol: _hl(compiled, scenario, "compiled", METHOD, r, a))
        timed = time_calls(fns, repeat=repeat, block=BLOCK)
        med = [tm.median for tm, _ in timed] + [math.nan] * (4 - len(timed))
        switched = [tm.switched_median for tm, _ in timed] + [math.nan] * (4 - len(timed))
        record: dict[str, Any] = {"method": METHOD, "rtol": rtol, "atol": atol}
        for label, (tm, events) in zip(labels, timed, strict=False):
            acc = trolley_check.compare(events, truth, friction_until=horizon)
            record[label] = {**tm.as_dict(), "mismatched": {n: acc.counts[n]
                                                           for n in acc.mismatched()},
                             "observable_dt": acc.observable_dt(),
                             "friction_dt": acc.friction_dt(),
                             "events": len(events)}
            bad = acc.mismatched()
            acc_rows.append([label, f"{rtol:g}",
                             "ok" if not bad else f"{len(bad)} names, " + str(sum(
                                 abs(acc.counts[n][0] - acc.counts[n][1]) for n in bad)),
                             _sci(acc.observable_dt()), _sci(acc.friction_dt())])
        ratios = {
            "ref/scipy": med[2] / med[0], "ref/scipy+max_step": med[2] / med[1],
            "compiled/scipy": med[3] / med[0], "compiled/scipy+max_step": med[3] / med[1],
            "compiled/ref": med[3] / med[2],
        }
        speedups = {"scipy/compiled": med[0] / med[3],
                    "scipy/compiled switched": switched[0] / switched[3]}
        record["speedups"] = speedups
        record["ratios_median"] = ratios
        report.records.append(record)
        speed_rows.append([METHOD, f"{rtol:g}", f"{atol:g}",
                           *("n/a" if math.isnan(m) else f"{1e3 * m:.0f}" for m in med),
                           *("n/a" if math.isnan(v) else f"{v:.2f}" for v in ratios.values()),
                           *("n/a" if math.isnan(v) else f"{v:.1f}" for v in speedups.values())])
    report.records.append({"repeat": repeat, "truth": {"rtol": TRUTH_RTOL, "atol": TRUTH_ATOL,
                                                       "events": len(truth)},
                           "check": {"counts": agreement.counts,
                                     "observable_dt": agreement.observable_dt(),
                                     "friction_dt": agreement.friction_dt()},
                           "compiled_backend": has_compiled})
    report.tables.append((
        f"Speed (median of {repeat} rounds of {BLOCK - 1} warm runs each, the implementations "
        "alternating round by round, ms), ratios (hybridlab time / scipy time: below 1 "
        "hybridlab is faster) and the compiled backend's speed-up over the plain scipy loop, "
        "warm and switched (right after another implementation ran)",
        ["method", "rtol", "atol", "scipy", "scipy+ms", "hl ref", "hl comp", "ref/scipy",
         "ref/scipy+ms", "comp/scipy", "comp/scipy+ms", "comp/ref", "x warm", "x switched"],
        speed_rows))
    report.tables.append((
        f"Accuracy against hybridlab reference at rtol {TRUTH_RTOL:g}, atol {TRUTH_ATOL:g} "
        f"({len(truth)} events)",
        ["implementation", "rtol", "count mismatches (names, events)", "max|dt| observable [s]",
         "max|dt| stick/slip [s]"],
        acc_rows))
    report.notes += [
        f"Checked before timing (rtol {trolley_check.CHECK_RTOL:g}): scipy+max_step and the "
        f"hl reference backend have the same events; observable times agree to "
        f"{agreement.observable_dt():.1e} s, stick/slip times to {agreement.friction_dt():.1e} s.",
        "scipy+ms = the scipy loop with max_step = "
        f"{trolley_check.SAFE_MAX_STEP:g} s; observable = sensor edges, the pendulum's "
        "turning points and manoeuvre transitions.",
    ]
    if job == "free_drop":
        report.notes.append(
            "Stick/slip events are compared up to "
            f"{trolley_check.FREE_DROP_FRICTION_HORIZON:g} s; after that the settled cart's "
            "nanometre stick/slip cycles depend on the tolerance in every implementation.")
    if not has_compiled:
        report.notes.append("hl compiled: n/a (no backend option or numba not installed).")
    return report
