"""Published reachability benchmarks: hybridlab's verdict and time next to Hylaa's.

Usage (from the repository root)::

    .venv/bin/python benchmarks/reach/run.py [--only NAME] [--timeout SECONDS]
                                             [--hylaa-python PATH] [--flowstar PATH]
                                             [--cfg-step] [--verbose]

Each benchmark is a SpaceEx model and ``.cfg`` in ``models/spaceex/`` (written from the
published definition; source and published verdict in the file header). It is loaded
with :func:`hybridlab.io.load_spaceex` and checked with
:func:`hybridlab.verify.check_safety` (falsification by simulation, then flowpipes),
using the ``.cfg``'s forbidden set, initial set, horizon and iteration bound (as
``max_jumps``), and otherwise default options: the step is hybridlab's own choice. With
``--cfg-step`` the ``.cfg``'s sampling time is the reach step, as for Hylaa, which
always takes it. With ``--hylaa-python`` the Hylaa version
of the same benchmark (``hylaa_models.py``) runs in a subprocess with that interpreter,
a separate venv: Hylaa is never a dependency of hybridlab. With ``--timeout`` every
hybridlab instance runs in a process of its own (this script with ``--worker NAME``), killed
and reported ``TIMEOUT`` after that many seconds; the same limit then applies to Hylaa.
The "tightest bound" column is the verdict's ``margin``: SAFE, the smallest proven margin;
UNKNOWN, the lowest lower bound of a spec over the flowpipes; UNSAFE, the most negative
margin of the counterexample. Times: "whole" is the whole process from its start
(interpreter, imports, loading; measured by this script around the subprocess, so only
with ``--timeout`` for hybridlab), "in-process" from the loaded tool to the verdict
(hybridlab: loading the SpaceEx files and the check; Hylaa: building and running its
automaton). hybridlab's bytecode is compiled before the runs, as pip compiles an installed
package's (Hylaa's). With ``--flowstar PATH`` (a Flow* 2.1.0 binary, built outside this
project: see README.md) the nonlinear instances also run through Flow* on the model files in
``flowstar/`` (one subprocess each, in a scratch directory, under the same time limit as
Hylaa; the coupled oscillators' initial box is cut into 16 pieces, one subprocess per piece,
SAFE only if every piece is, times summed); its verdict, its whole-process time, its own
"Total time cost" (the CPU time of its flowpipe computation and safety check, as
"in-process") and the ratios hybridlab / Flow* (where both reach the same SAFE or UNSAFE
verdict) are added to the table. Nothing here is a test.
"""

from __future__ import annotations

import argparse
import compileall
import itertools
import json
import math
import os
import platform
import re
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT))

from hybridlab.io import load_spaceex  # noqa: E402
from hybridlab.verify import check_safety  # noqa: E402


@dataclass(frozen=True)
class Benchmark:
    name: str
    xml: str
    cfg: str
    published: str
    source: str
    hylaa: bool  # Hylaa can run it (affine dynamics)


BENCHMARKS = (
    Benchmark("bouncing_ball", "bouncing_ball.xml", "bouncing_ball.cfg", "SAFE",
              "SpaceEx example bball (CAV 2011); closed form", True),
    Benchmark("bouncing_ball_fast", "bouncing_ball.xml", "bouncing_ball_fast.cfg", "UNSAFE",
              "SpaceEx example bball; closed form", True),
    Benchmark("crane", "crane.xml", "crane.cfg", "SAFE",
              "JuliaReach ReachabilityBenchmarks Crane (BFFPSV18), x >= -1.8", True),
    Benchmark("crane_unsafe", "crane.xml", "crane_unsafe.cfg", "UNSAFE",
              "defined here: the crane with x >= -1.5; simulation", True),
    Benchmark("vanderpol", "vanderpol.xml", "vanderpol.cfg", "SAFE",
              "ARCH-COMP NLN VDP, mu = 1", False),
    Benchmark("coupled_vanderpol", "coupled_vanderpol.xml", "coupled_vanderpol.cfg", "SAFE",
              "ARCH-COMP NLN CVDP23 (b in [1, 3]); CORA coupledVanDerPol_ARCH23.m", False),
    Benchmark("laub_loomis_w001", "laub_loomis.xml", "laub_loomis_w001.cfg", "SAFE",
              "ARCH-COMP NLN LALO, W = 0.01, x4 < 4.5", False),
    Benchmark("laub_loomis_w005", "laub_loomis.xml", "laub_loomis_w005.cfg", "SAFE",
              "ARCH-COMP NLN LALO, W = 0.05, x4 < 4.5", False),
    Benchmark("laub_loomis_w01", "laub_loomis.xml", "laub_loomis_w01.cfg", "SAFE",
              "ARCH-COMP NLN LALO, W = 0.1, x4 < 5", False),
    Benchmark("spacecraft_sra01", "spacecraft.xml", "spacecraft_sra01.cfg", "SAFE",
              "ARCH-COMP AFF SRA01 (abort at t = 120); CORA rendezvous_SRA01.m", True),
    Benchmark("spacecraft_sra02", "spacecraft.xml", "spacecraft_sra02.cfg", "SAFE",
              "ARCH-COMP AFF SRA02 (abort in [120, 125]); CORA rendezvous_SRA02.m", True),
    Benchmark("spacecraft_sra03", "spacecraft.xml", "spacecraft_sra03.cfg", "SAFE",
              "ARCH-COMP AFF SRA03 (abort in [120, 145]); CORA rendezvous_SRA03.m", True),
    Benchmark("spacecraft_sra04", "spacecraft.xml", "spacecraft_sra04.cfg", "SAFE",
              "ARCH-COMP AFF SRA04 (abort at t = 240); CORA rendezvous_SRA04.m", True),
    Benchmark("building_bldf01", "building.xml", "building.cfg", "SAFE",
              "ARCH-COMP AFF BLDF01 / BDS01; ARCH-COMP17 SpaceEx BLDF01.xml", True),
    Benchmark("platoon_plad01_bnd42", "platoon.xml", "platoon_plad01_bnd42.cfg", "SAFE",
              "ARCH-COMP AFF PLAD01-BND42; CORA platoon_PLAD01_BND30.m", True),
    Benchmark("platoon_plad01_bnd30", "platoon.xml", "platoon_plad01_bnd30.cfg", "SAFE",
              "ARCH-COMP AFF PLAD01-BND30; CORA platoon_PLAD01_BND30.m", True),
    Benchmark("gearbox_grbx01", "gearbox.xml", "gearbox_grbx01.cfg", "SAFE",
              "ARCH-COMP AFF GRBX01-MES01; CORA gearbox.m, JuliaReach Gearbox", True),
    Benchmark("gearbox_grbx02", "gearbox.xml", "gearbox_grbx02.cfg", "SAFE",
              "ARCH-COMP AFF GRBX02-MES01; JuliaReach Gearbox", True),
    Benchmark("room_heating", "room_heating.xml", "room_heating.cfg", "SAFE",
              "defined here after Fehnker and Ivancic (HSCC 2004), CORA roomHeating.m; "
              "checked by simulation only", True),
    Benchmark("stiff2d", "stiff2d.xml", "stiff2d.cfg", "SAFE",
              "defined here: eigenvalues -1 and -2000; closed form", True),
)
BY_NAME = {b.name: b for b in BENCHMARKS}


@dataclass(frozen=True)
class FlowstarModel:
    """A Flow* model file in ``flowstar/``, run on its initial box whole or cut into pieces.

    Parameters
    ----------
    file : str
        The model file; its ``init`` block gives the whole initial box.
    split : tuple of (str, int)
        Variables of the initial box and the number of equal intervals to cut each into.
        Every piece of the product is a Flow* run of its own, on the file with that piece
        as its ``init`` intervals. Empty: one run on the file as it is.
    """

    file: str
    split: tuple[tuple[str, int], ...] = ()

    def pieces(self) -> list[tuple[str, str]]:
        """The models to run, as ``(label, model text)``; the label names the piece.

        The cuts are computed in decimal arithmetic from the file's interval bounds, and
        neighbouring pieces share the same bound, so the pieces cover the box exactly.

        Returns
        -------
        list of (str, str)
            One entry per piece (one, labelled ``""``, without a split); each text starts
            with a comment line naming the piece.

        Raises
        ------
        ValueError
            If a split variable does not occur exactly once as ``VAR in [LO, HI]``.
        """
        text = (HERE / "flowstar" / self.file).read_text()
        if not self.split:
            return [("", text)]
        cuts = []  # per split variable: (pattern of its init line, its intervals)
        for var, n in self.split:
            pattern = re.compile(rf"^(\s*{re.escape(var)}\s+in\s*)\[([^,\]]+),([^\]]+)\]",
                                 re.MULTILINE)
            found = pattern.findall(text)
            if len(found) != 1:
                raise ValueError(f"{self.file}: {var} in [lo, hi] occurs {len(found)} times")
            lo, hi = Decimal(found[0][1].strip()), Decimal(found[0][2].strip())
            edges = [_decimal(lo + (hi - lo) * i / n) for i in range(n + 1)]
            cuts.append((pattern, [(var, edges[i], edges[i + 1]) for i in range(n)]))
        count = math.prod(n for _, n in self.split)
        pieces = []
        for number, box in enumerate(itertools.product(*(c[1] for c in cuts)), 1):
            label = ", ".join(f"{var} in [{lo}, {hi}]" for var, lo, hi in box)
            piece = text
            for (pattern, _), (_, left, right) in zip(cuts, box, strict=True):
                piece = pattern.sub(rf"\g<1>[{left}, {right}]", piece)
            pieces.append((label, f"# piece {number} of {count}, made by run.py from "
                                  f"{self.file}: {label}\n{piece}"))
        return pieces


def _decimal(value: Decimal) -> str:
    """``value`` in plain decimal notation, without trailing zeros."""
    return format(value.normalize(), "f")


# Flow* versions of the nonlinear instances (flowstar/*.model; settings and their sources in
# each file's header and in README.md). Flow* 2.1.0 has one unsafe set per continuous model,
# a conjunction: the coupled oscillators' model checks y1 >= 2.75, and y2 by their symmetry.
# CVDP23 is proved piece by piece: b cut into 4, x1 and x2 into 2 each, 16 Flow* runs.
FLOWSTAR_MODELS = {
    "vanderpol": FlowstarModel("vanderpol.model"),
    "coupled_vanderpol": FlowstarModel("coupled_vanderpol.model",
                                       split=(("b", 4), ("x1", 2), ("x2", 2))),
    "laub_loomis_w001": FlowstarModel("laub_loomis_w001.model"),
    "laub_loomis_w005": FlowstarModel("laub_loomis_w005.model"),
    "laub_loomis_w01": FlowstarModel("laub_loomis_w01.model"),
}


@dataclass(frozen=True)
class Outcome:
    verdict: str  # SAFE, UNSAFE, UNKNOWN, ERROR, TIMEOUT, n/a
    seconds: float | None  # in-process: from the loaded tool to the verdict
    reason: str
    margin: float | None = None  # the verdict's tightest bound, when it has one
    whole: float | None = None  # the whole process, interpreter start-up and imports included


def run_hybridlab(b: Benchmark, cfg_step: bool = False) -> Outcome:
    """Load and check one benchmark in this process (the ``.cfg``'s step only if asked)."""
    start = time.perf_counter()
    try:
        problem = load_spaceex(ROOT / "models" / "spaceex" / b.xml,
                               ROOT / "models" / "spaceex" / b.cfg)
        kwargs = problem.reach_kwargs()
        if not cfg_step:
            kwargs.pop("step", None)
        verdict = check_safety(problem.model, safe=problem.safe_specs(), **kwargs)
    except Exception as exc:  # a benchmark report, not a library: show what failed
        return Outcome("ERROR", time.perf_counter() - start, f"{type(exc).__name__}: {exc}")
    margin = getattr(verdict, "margin", None)
    return Outcome(verdict.status.name, time.perf_counter() - start, verdict.reason,
                   None if margin is None or not math.isfinite(margin) else float(margin))


def run_hybridlab_isolated(b: Benchmark, timeout: float, cfg_step: bool = False) -> Outcome:
    """Check one benchmark in a process of its own; TIMEOUT after ``timeout`` seconds.

    The child is this script with ``--worker NAME`` (one JSON line back). It runs in a new
    session so that the whole process group, with any worker processes it started, is
    killed on timeout.
    """
    start = time.perf_counter()
    proc, out, err = _run_group([sys.executable, str(Path(__file__).resolve()), "--worker",
                                 b.name] + (["--cfg-step"] if cfg_step else []), timeout)
    if out is None:
        return Outcome("TIMEOUT", time.perf_counter() - start,
                       f"no verdict within {timeout:g} s (process killed)")
    lines = out.strip().splitlines()
    if proc.returncode != 0 or not lines:
        tail = (err.strip().splitlines() or [f"exit status {proc.returncode}"])[-1]
        return Outcome("ERROR", time.perf_counter() - start, tail)
    data = json.loads(lines[-1])
    return Outcome(data["verdict"], data["time_s"], data["reason"], data["margin"],
                   whole=time.perf_counter() - start)


def _run_group(args: list[str], timeout: float | None, **popen) -> tuple[
        subprocess.Popen, str | None, str]:
    """Run ``args`` in a session of its own: ``(process, stdout, stderr)``, with ``stdout``
    ``None`` when ``timeout`` ran out (the whole process group is then killed)."""
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, **popen)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            proc.kill()
        proc.communicate()
        return proc, None, ""
    return proc, out, err


def _worker(name: str, cfg_step: bool) -> int:
    o = run_hybridlab(BY_NAME[name], cfg_step)
    print(json.dumps({"verdict": o.verdict, "time_s": o.seconds, "reason": o.reason,
                      "margin": o.margin}))
    return 0


def run_hylaa(b: Benchmark, python: str | None, timeout: float | None) -> Outcome:
    if not b.hylaa:
        return Outcome("n/a", None, "Hylaa handles affine dynamics only")
    if python is None:
        return Outcome("n/a", None, "no --hylaa-python given")
    start = time.perf_counter()
    proc, out, err = _run_group([python, str(HERE / "hylaa_models.py"), b.name],
                                1800 if timeout is None else timeout)
    if out is None:
        return Outcome("TIMEOUT", None, "Hylaa gave no verdict in time (process killed)")
    if proc.returncode != 0:
        return Outcome("ERROR", None, (err.strip().splitlines() or ["?"])[-1])
    data = json.loads(out.strip().splitlines()[-1])
    return Outcome(data["verdict"], float(data["time_s"]), "", whole=time.perf_counter() - start)


_ANSI = re.compile(r"\x1b\[[0-9;]*m")


def parse_flowstar(out: str) -> tuple[str, float | None, str]:
    """Flow* 2.1.0's verdict, its own time cost and a reason, from its standard output.

    Flow* prints "Result of the safety verification on the computed flowpipes: SAFE" (or
    UNSAFE, UNKNOWN) and "Total time cost: T seconds" (``clock()`` around its flowpipe
    computation and safety check, parsing excluded). When the flowpipes stop before the
    horizon ("Computation not completed") it still prints SAFE if the flowpipes it has are
    safe: that is reported UNKNOWN here, the horizon not being covered.
    """
    text = _ANSI.sub("", out)
    verdict = re.search(r"safety verification on the computed flowpipes:\s*(SAFE|UNSAFE|UNKNOWN)",
                        text)
    cost = re.search(r"Total time cost:\s*([0-9.eE+-]+)\s*seconds", text)
    seconds = float(cost.group(1)) if cost else None
    flowpipes = re.search(r"Computation (not )?completed: (\d+) flowpipe", text)
    if verdict is None:
        return "ERROR", seconds, "no verdict in Flow*'s output"
    status = verdict.group(1)
    if flowpipes and flowpipes.group(1):
        reason = (f"computation not completed ({flowpipes.group(2)} flowpipes): the horizon is "
                  f"not covered; Flow* says {status} for the flowpipes it has")
        return ("UNSAFE" if status == "UNSAFE" else "UNKNOWN"), seconds, reason
    n = flowpipes.group(2) if flowpipes else "?"
    return status, seconds, f"{n} flowpipes computed, Flow* says {status}"


def run_flowstar(b: Benchmark, binary: str | None, timeout: float | None) -> Outcome:
    """Run Flow* on the benchmark's model, piece by piece when its initial box is cut.

    Parameters
    ----------
    b : Benchmark
        The instance; only those in ``FLOWSTAR_MODELS`` have a Flow* model.
    binary : str or None
        The Flow* 2.1.0 binary (``n/a`` without one).
    timeout : float or None
        Seconds for the whole instance, all its pieces together (1800 if ``None``).

    Returns
    -------
    Outcome
        SAFE only if every piece is SAFE, with the times summed over the pieces: "whole"
        the wall time around each subprocess, "in-process" Flow*'s own "Total time cost".
        Otherwise the verdict of the first piece that is not SAFE (UNKNOWN, UNSAFE,
        TIMEOUT or ERROR), with that piece named in the reason and the times summed up to
        it; the remaining pieces are not run (the instance can no longer be SAFE).
    """
    model = FLOWSTAR_MODELS.get(b.name)
    if model is None:
        return Outcome("n/a", None, "no Flow* model (only the nonlinear instances have one)")
    if binary is None:
        return Outcome("n/a", None, "no --flowstar given")
    pieces = model.pieces()
    deadline = time.perf_counter() + (1800 if timeout is None else timeout)
    whole: float | None = 0.0
    seconds: float | None = 0.0
    costs = []
    # a scratch directory: Flow* writes its outputs/ and images/ into its working directory
    with tempfile.TemporaryDirectory(prefix="flowstar-") as scratch:
        for number, (label, text) in enumerate(pieces, 1):
            o = _run_flowstar_model(binary, text, scratch, deadline - time.perf_counter())
            whole, seconds = _sum(whole, o.whole), _sum(seconds, o.seconds)
            if o.verdict != "SAFE":
                where = "" if len(pieces) == 1 else f"piece {number} of {len(pieces)} ({label}): "
                return Outcome(o.verdict, seconds, where + o.reason, whole=whole)
            costs.append(_seconds(o.seconds))
    if len(pieces) == 1:
        return Outcome("SAFE", seconds, o.reason, whole=whole)
    split = ", ".join(f"{var} into {n}" for var, n in model.split)
    return Outcome("SAFE", seconds, f"all {len(pieces)} pieces SAFE ({split}); Flow*'s time "
                                    f"cost per piece [s]: {' '.join(costs)}", whole=whole)


def _run_flowstar_model(binary: str, text: str, scratch: str, timeout: float) -> Outcome:
    """Run Flow* once on the model ``text`` in the directory ``scratch``.

    The model is written to ``scratch`` and given to Flow* on its standard input. With
    ``timeout`` (seconds) not positive, Flow* is not started and the outcome is TIMEOUT.
    """
    if timeout <= 0:
        return Outcome("TIMEOUT", None, "Flow* gave no verdict in time (no time left)")
    path = Path(scratch) / "model"
    path.write_text(text)
    with open(path) as stdin:
        start = time.perf_counter()
        proc, out, err = _run_group([binary], timeout, stdin=stdin, cwd=scratch)
        if out is None:
            return Outcome("TIMEOUT", None, "Flow* gave no verdict in time (process killed)")
        whole = time.perf_counter() - start
    verdict, seconds, reason = parse_flowstar(out)
    if proc.returncode != 0 and verdict == "ERROR":
        reason = (err.strip().splitlines() or [f"exit status {proc.returncode}"])[-1]
    return Outcome(verdict, seconds, reason, whole=whole)


def _sum(total: float | None, value: float | None) -> float | None:
    """``total + value``, or ``None`` when either is unknown."""
    return None if total is None or value is None else total + value


def _ratio(ours: float | None, theirs: float | None) -> str:
    return "-" if ours is None or not theirs else f"{ours / theirs:.3g}"


def _seconds(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def _bound(margin: float | None) -> str:
    return "-" if margin is None else f"{margin:.4g}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", choices=[b.name for b in BENCHMARKS])
    parser.add_argument("--hylaa-python", help="the python of a venv with hylaa installed")
    parser.add_argument("--flowstar", metavar="PATH",
                        help="a Flow* 2.1.0 binary: also run the nonlinear instances with it")
    parser.add_argument("--verbose", action="store_true", help="print each verdict's reason")
    parser.add_argument("--timeout", type=float, metavar="SECONDS",
                        help="run each hybridlab instance in a process of its own and report "
                             "TIMEOUT after this many seconds (also bounds Hylaa)")
    parser.add_argument("--cfg-step", action="store_true", dest="cfg_step",
                        help="give hybridlab the .cfg's sampling time as its step (Hylaa "
                             "always takes it)")
    parser.add_argument("--worker", choices=[b.name for b in BENCHMARKS],
                        help=argparse.SUPPRESS)  # internal: the child of --timeout
    args = parser.parse_args(argv)
    if args.worker:
        return _worker(args.worker, args.cfg_step)
    if args.timeout is not None and not (math.isfinite(args.timeout) and args.timeout > 0):
        parser.error("--timeout must be a positive number of seconds")
    if args.flowstar and not (os.path.isfile(args.flowstar) and os.access(args.flowstar, os.X_OK)):
        parser.error(f"--flowstar: {args.flowstar} is not an executable file")
    # hybridlab's bytecode compiled first, as pip compiles an installed package's (Hylaa's):
    # with PYTHONDONTWRITEBYTECODE set, an editable checkout would otherwise be compiled
    # from source in every process (about 0.2 s of each whole-process time)
    compileall.compile_dir(ROOT / "hybridlab", quiet=1)
    print(f"reach benchmarks, {time.strftime('%Y-%m-%d')}, {platform.processor() or '?'}, "
          f"Python {platform.python_version()}"
          + ("" if args.timeout is None else f", timeout {args.timeout:g} s per instance")
          + (", hybridlab with the .cfg's step" if args.cfg_step else
             ", hybridlab with default options"))
    header: tuple[str, ...] = ("benchmark", "published", "hybridlab", "whole [s]", "in-process [s]",
              "tightest bound", "Hylaa", "whole [s]", "in-process [s]")
    if args.flowstar:
        header += ("Flow*", "whole [s]", "in-process [s]", "hybridlab/Flow* whole",
                   "hybridlab/Flow* in-process")
    rows = []
    for b in BENCHMARKS:
        if args.only and b.name not in args.only:
            continue
        o = (run_hybridlab(b, args.cfg_step) if args.timeout is None
             else run_hybridlab_isolated(b, args.timeout, args.cfg_step))
        h = run_hylaa(b, args.hylaa_python, args.timeout)
        row: tuple[str, ...] = (b.name, b.published, o.verdict, _seconds(o.whole),
                                _seconds(o.seconds), _bound(o.margin), h.verdict,
                                _seconds(h.whole), _seconds(h.seconds))
        f = None
        if args.flowstar:
            f = run_flowstar(b, args.flowstar, args.timeout)
            # a ratio of times only where both tools reach the same verdict
            same = o.verdict == f.verdict and o.verdict in ("SAFE", "UNSAFE")
            row += (f.verdict, _seconds(f.whole), _seconds(f.seconds),
                    _ratio(o.whole, f.whole) if same else "-",
                    _ratio(o.seconds, f.seconds) if same else "-")
        rows.append(row)
        if args.verbose:
            print(f"{b.name}: hybridlab: {o.reason}", flush=True)
            if h.reason:
                print(f"{b.name}: Hylaa: {h.reason}", flush=True)
            if f is not None and f.reason:
                print(f"{b.name}: Flow*: {f.reason}", flush=True)
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)) + " |"
    print(line)
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in rows:
        print("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
