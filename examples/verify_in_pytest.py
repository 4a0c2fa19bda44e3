"""Safety checks as test assertions: one SAFE (proved) and one UNSAFE (a counterexample).

``hybridlab.verify.assert_safe`` first simulates from the corners, centre and samples of the
initial set (falsification), then computes flowpipes (``hybridlab.reach``) and bounds every
spec over them. In a pytest file the two checks below are simply::

    def test_decay_stays_positive():
        assert_safe(DECAY, initial={"x": (1, 2)}, t_end=1, safe="x >= 0.3")

Usage::

    python examples/verify_in_pytest.py

Exits non-zero if the decay is not proved SAFE or the ball's speed limit is not refuted.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hybridlab
from hybridlab.verify import SafetyAssertionError, assert_safe

BALL = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"
DECAY = hybridlab.loads_model("""
name = "decay"
states = { x = 1.0 }
[modes.run]
flow = { x = "-x" }
[initial]
mode = "run"
""")


def main() -> int:
    # 1. proved: x = x0 exp(-t) >= exp(-1) > 0.3 for x0 in [1, 2] and t in [0, 1]
    verdict = assert_safe(DECAY, initial={"x": (1.0, 2.0)}, t_end=1.0, safe="x >= 0.3")
    print(f"decay: {verdict.status.name}: {verdict.reason}")

    # 2. refuted: dropped from up to 10 m, the ball is faster than 13 m/s before it lands
    try:
        assert_safe(BALL, initial={"h": (5.0, 10.0)}, t_end=2.0, safe="v >= -13")
    except SafetyAssertionError as failure:
        print("ball: the assertion fails with\n" + str(failure))
        cx = failure.verdict.counterexample
        replayed = cx.replay()  # the same run, bit for bit
        v = replayed(cx.t)[replayed.state_names.index("v")]
        print(f"replayed: v({cx.t:.9f}) = {v:.9f}")
        return 0 if verdict.safe and abs(v + 13.0) < 1e-9 else 1
    print("ball: expected a counterexample")
    return 1


if __name__ == "__main__":
    sys.exit(main())
