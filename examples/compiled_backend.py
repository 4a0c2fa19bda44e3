"""The compiled backend against the reference engine, on the trolley's stop-and-return.

One model, three runs: the reference engine (Python around scipy's
steppers), the compiled numba kernel, and the kernel with
``prove_quiet_steps=False`` (every step sampled, as the reference does). It
prints the time of each, how many steps interval bounds proved free of
events, and checks that

* the kernel and the reference fire the same transitions in the same order,
  the jumps within 1e-8 s of each other (measured: under 1e-9 s; the exits
  from the cart's stick phases before some of them are ill-conditioned, see
  ``docs/semantics.md``, Backends);
* proving steps quiet changes nothing: the same events, bit for bit.

The kernel runs use ``backend="auto"``: without numba (the ``fast`` extra)
that is the reference engine, which the script reports; its checks still
hold.

Usage::

    python examples/compiled_backend.py [--plot FILE.png]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import hybridlab

MODEL = Path(__file__).resolve().parents[1] / "models" / "trolley.toml"
SETTINGS = {"scenario": "default", "method": "DOP853", "rtol": 1e-8, "atol": 1e-10}


def timed(compiled, repeat: int, **options):
    """The last result and the median wall time of ``repeat`` runs (after one warm-up)."""
    result = hybridlab.simulate(compiled, **SETTINGS, **options)
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = hybridlab.simulate(compiled, **SETTINGS, **options)
        times.append(time.perf_counter() - start)
    return result, statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", type=Path, help="write the event-time differences here")
    parser.add_argument("--quick", action="store_true",
                        help="time one run per backend after the warm-up (for CI), not 2 and 20")
    args = parser.parse_args(argv)

    compiled = hybridlab.compile_model(hybridlab.load_model(MODEL))
    slow, fast = (1, 1) if args.quick else (2, 20)
    reference, t_ref = timed(compiled, slow, backend="reference")
    kernel, t_kernel = timed(compiled, fast, backend="auto")
    sampled, t_sampled = timed(compiled, fast, backend="auto", prove_quiet_steps=False)

    print(f"backend that ran: {kernel.stats['backend']}")
    print(f"reference engine          {t_ref * 1e3:8.2f} ms")
    print(f"compiled, every step      {t_sampled * 1e3:8.2f} ms")
    print(f"compiled, quiet steps     {t_kernel * 1e3:8.2f} ms   "
          f"({kernel.stats.get('quiet_steps', 0)} of {kernel.stats['steps']} steps proven quiet)")

    ok = True
    names = [(e.transition, e.kind) for e in kernel.events]
    if names != [(e.transition, e.kind) for e in reference.events]:
        print("FAIL: the backends fire different events")
        ok = False
    jumps = [(a.t, b.t) for a, b in zip(kernel.events, reference.events, strict=False)
             if a.kind == "jump"]
    worst = max(abs(a - b) for a, b in jumps)
    print(f"{len(kernel.events)} events; jumps: {len(jumps)}, largest time difference "
          f"{worst:.1e} s")
    if worst > 1e-8:
        print("FAIL: a jump differs by more than 1e-8 s")
        ok = False
    same = ([(e.t, e.transition, tuple(e.post.values())) for e in kernel.events]
            == [(e.t, e.transition, tuple(e.post.values())) for e in sampled.events])
    print(f"quiet steps change nothing: {same}")
    ok = ok and same

    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 3.5))
        ax.semilogy([a for a, _ in jumps], [max(abs(a - b), 1e-17) for a, b in jumps], "o",
                    ms=3)
        ax.set(xlabel="t [s]", ylabel="|t compiled - t reference| [s]",
               title="Jump times: compiled kernel against the reference engine")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        plt.close(fig)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
