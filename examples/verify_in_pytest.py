"""Safety checks as test assertions: one SAFE (proved) and one UNSAFE (a counterexample).

``hybridlab.verify.assert_safe`` first simulates from the corners, centre and samples of the
initial set (falsification), then computes flowpipes (``hybridlab.reach``) and bounds every
spec over them. In a pytest file the two checks below are simply::

    def test_decay_stays_positive():
        assert_safe(DECAY, initial={"x": (1, 2)}, t_end=1, safe="x >= 0.3")

Usage::

    python examples/verify_in_pytest.py [--plot FILE.png]

Exits non-zero if the decay is not proved SAFE or the ball's speed limit is not refuted.
"""

from __future__ import annotations

import argparse
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png",
                        help="plot the counterexample's speed against the limit")
    args = parser.parse_args(argv)
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
        if args.plot:
            plot(replayed, cx.t, args.plot)
            print(f"wrote {args.plot}")
        return 0 if verdict.safe and abs(v + 13.0) < 1e-9 else 1
    print("ball: expected a counterexample")
    return 1


def plot(result: hybridlab.SimulationResult, t_violation: float, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, y = result.sample(1e-3)
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(t, y[result.state_names.index("v")], lw=1.2, label="v(t), counterexample replay")
    ax.axhline(-13.0, color="C3", ls="--", lw=1, label="spec v >= -13")
    ax.axvline(t_violation, color="0.5", lw=0.8, label="first violation")
    ax.set(xlabel="t [s]", ylabel="v [m/s]", title="assert_safe: a refuted speed limit")
    ax.legend(loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
