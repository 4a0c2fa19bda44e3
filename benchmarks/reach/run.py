"""Published reachability benchmarks: hybridlab's verdict and time next to Hylaa's.

Usage (from the repository root)::

    .venv/bin/python benchmarks/reach/run.py [--only NAME] [--hylaa-python PATH]

Each benchmark is a SpaceEx model and ``.cfg`` in ``models/spaceex/`` (written from the
published definition; source and published verdict in the file header). It is loaded
with :func:`hybridlab.io.load_spaceex` and checked with
:func:`hybridlab.verify.check_safety` (falsification by simulation, then flowpipes),
using the ``.cfg``'s forbidden set, initial set, horizon, sampling time (as the reach
step) and iteration bound (as ``max_jumps``). With ``--hylaa-python`` the Hylaa version
of the same benchmark (``hylaa_models.py``) runs in a subprocess with that interpreter,
a separate venv: Hylaa is never a dependency of hybridlab. Nothing here is a test.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
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
    Benchmark("vanderpol", "vanderpol.xml", "vanderpol.cfg", "SAFE",
              "ARCH-COMP NLN VDP, mu = 1", False),
)


def run_hybridlab(b: Benchmark) -> tuple[str, float, str]:
    start = time.perf_counter()
    try:
        problem = load_spaceex(ROOT / "models" / "spaceex" / b.xml,
                               ROOT / "models" / "spaceex" / b.cfg)
        verdict = check_safety(problem.model, safe=problem.safe_specs(),
                               **problem.reach_kwargs())
    except Exception as exc:  # a benchmark report, not a library: show what failed
        return "ERROR", time.perf_counter() - start, f"{type(exc).__name__}: {exc}"
    return verdict.status.name, time.perf_counter() - start, verdict.reason


def run_hylaa(b: Benchmark, python: str | None) -> tuple[str, float | None, str]:
    if not b.hylaa:
        return "n/a", None, "Hylaa handles affine dynamics only"
    if python is None:
        return "n/a", None, "no --hylaa-python given"
    proc = subprocess.run([python, str(HERE / "hylaa_models.py"), b.name], capture_output=True,
                          text=True, timeout=1800, check=False)
    if proc.returncode != 0:
        return "ERROR", None, (proc.stderr.strip().splitlines() or ["?"])[-1]
    data = json.loads(proc.stdout.strip().splitlines()[-1])
    return data["verdict"], float(data["time_s"]), ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", choices=[b.name for b in BENCHMARKS])
    parser.add_argument("--hylaa-python", help="the python of a venv with hylaa installed")
    parser.add_argument("--verbose", action="store_true", help="print each verdict's reason")
    args = parser.parse_args(argv)
    print(f"reach benchmarks, {time.strftime('%Y-%m-%d')}, {platform.processor() or '?'}, "
          f"Python {platform.python_version()}")
    header = ("benchmark", "published", "hybridlab", "time [s]", "Hylaa", "time [s]")
    rows = []
    for b in BENCHMARKS:
        if args.only and b.name not in args.only:
            continue
        verdict, seconds, reason = run_hybridlab(b)
        hv, hs, hreason = run_hylaa(b, args.hylaa_python)
        rows.append((b.name, b.published, verdict, f"{seconds:.2f}", hv,
                     "-" if hs is None else f"{hs:.2f}"))
        if args.verbose:
            print(f"{b.name}: hybridlab: {reason}")
            if hreason:
                print(f"{b.name}: Hylaa: {hreason}")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)) + " |"
    print(line)
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in rows:
        print("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
