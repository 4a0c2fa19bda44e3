"""A stiff affine system: tight flowpipes with a step 25 times its fastest time constant.

``x' = -x + y``, ``y' = -2000 y + 1`` (eigenvalues -1 and -2000) from ``x`` in
[0.9, 1.1], ``y`` in [-0.5, 0.5] over 5 s, with the default step (5 / 400 =
0.0125 s, so ``|lambda| r = 25`` for the fast mode). :func:`hybridlab.reach` splits
the mode by time scale (see ``docs/verification.md``, "Stiff modes"); checks:

1. the result is complete and sound: simulations from the corners of the initial
   box (Radau, tolerance 1e-10) stay inside the bounds;
2. the bounds are tight: each state's bound is at most 5 times as wide as its
   simulated range;
3. a safety spec with a thin margin (``x <= 1.11``; the simulated maximum is 1.1)
   is proved by :func:`hybridlab.verify.check_safety`.

Run ``python examples/reach_stiff.py``. Exits with status 1 if a check fails.
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.integrate import solve_ivp

import hybridlab
from hybridlab.verify import check_safety

MODEL = """
name = "stiff_pair"
description = "a slow state driven by a fast one (eigenvalues -1 and -2000)"
[parameters]
k = { value = 2000.0, unit = "1/s" }
[states]
x = { initial = 1.0 }
y = { initial = 0.0 }
[modes.run]
flow = { x = "-x + y", y = "-k*y + 1" }
[initial]
mode = "run"
"""
INITIAL = {"x": (0.9, 1.1), "y": (-0.5, 0.5)}
T_END = 5.0


def simulated_range() -> tuple[np.ndarray, np.ndarray]:
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for x0 in INITIAL["x"]:
        for y0 in INITIAL["y"]:
            sol = solve_ivp(lambda t, z: [-z[0] + z[1], -2000.0 * z[1] + 1.0], (0.0, T_END),
                            [x0, y0], method="Radau", rtol=1e-10, atol=1e-12, dense_output=True)
            z = sol.sol(np.linspace(0.0, T_END, 20001))
            lo, hi = np.minimum(lo, z.min(axis=1)), np.maximum(hi, z.max(axis=1))
    return lo, hi


def main() -> int:
    model = hybridlab.loads_model(MODEL)
    result = hybridlab.reach(model, initial=INITIAL, t_end=T_END)
    lo, hi = simulated_range()
    ok = result.complete
    for i, name in enumerate(("x", "y")):
        b_lo, b_hi = result.bounds[name]
        sound = b_lo <= lo[i] + 1e-9 and b_hi >= hi[i] - 1e-9
        ratio = (b_hi - b_lo) / (hi[i] - lo[i])
        print(f"{name}: reach [{b_lo:.6g}, {b_hi:.6g}], simulated [{lo[i]:.6g}, {hi[i]:.6g}], "
              f"width ratio {ratio:.3f}")
        ok = ok and sound and ratio <= 5.0
    verdict = check_safety(model, initial=INITIAL, t_end=T_END, safe=["x <= 1.11"])
    print(f"x <= 1.11: {verdict.status.name} ({verdict.reason})")
    ok = ok and verdict.status.name == "SAFE"
    status = "passed" if ok else "FAILED"
    print(f"{len(result.sets)} sets in {result.time_s:.2f} s; checks {status}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
