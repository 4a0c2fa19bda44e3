"""Every name numpy, math, sympy, functools, numba and Python's builtins define, as a model name.

The test suite (``tests/test_name_capture.py``) declares a hundred chosen dangerous names;
this sweep declares *every* name those namespaces export that the model grammar accepts,
in models of ``--chunk`` names each (two states, the rest parameters), and checks that each
model behaves exactly like its *twin*, the same model with every name replaced by
``n0, n1, ...``:

* the reference engine's final state (flows, the guard, the reset, an invariant, all
  reading the names next to ``exp(1)``, ``pi`` and the grammar's functions),
* an observer evaluated along the run,
* reach's bounds over an affine mode, and
* that the numba kernel's generated source holds no name but its own
  (``--backend auto`` also runs the compiled kernel, a compile per model).

Usage::

    .venv/bin/python benchmarks/name_capture_sweep.py [--chunk 150] [--backend auto]

It prints one line per chunk and a summary, and exits 1 if any chunk differs from its twin.
"""

from __future__ import annotations

import argparse
import builtins
import functools
import io
import math
import sys
import time
import tokenize
from collections.abc import Sequence

import numpy as np
import sympy

import hybridlab
from hybridlab.errors import ExpressionError
from hybridlab.model.expressions import check_name
from hybridlab.simulation.compiled.codegen import generate
from hybridlab.simulation.observe import Observer


def candidate_names() -> list[str]:
    """Every exported name of the namespaces a printer or generated code could touch."""
    pools = [dir(np), dir(math), dir(sympy), dir(builtins), dir(functools)]
    try:
        import numba
        pools.append(dir(numba))
    except ImportError:
        pass
    names = set()
    for pool in pools:
        for name in pool:
            try:
                check_name(name)
            except ExpressionError:
                continue
            names.add(name)
    return sorted(names)


def model_of(names: Sequence[str]) -> hybridlab.Model:
    """Two states (the first two names) and every other name a parameter."""
    s0, s1, *params = names
    drive = " + ".join(params)
    return hybridlab.model_from_dict({
        "name": "sweep",
        "parameters": {p: 0.001 * (k + 1) for k, p in enumerate(params)},
        "states": {s0: 1.0, s1: 0.5},
        "modes": {
            "up": {"flow": {s0: f"-{s0} + exp(1) + 0.01*({drive}) + pi*{params[0]}",
                            s1: f"-{s1} + asin(0.5)*{params[1]} + sin({s0})*{params[-1]}"},
                   "invariant": [f"{s0} <= 10 + {params[2]}"]},
            "down": {"flow": {s0: f"-{s0} + exp(-1)*{params[3]}", s1: f"-{s1} + {params[4]}"}},
        },
        "transitions": [{"name": "switch", "source": "up", "target": "down",
                         "guard": f"{s0} >= 2.2 + {params[5]} - exp(1)*{params[6]}",
                         "reset": {s0: f"{s0}*exp(1)/(exp(1) + {params[7]})"}}],
        "initial": {"mode": "up"},
    })


def affine_of(names: Sequence[str]) -> hybridlab.Model:
    """One affine mode over the names, for reach."""
    s0, s1, *params = names
    return hybridlab.model_from_dict({
        "name": "affine", "parameters": {p: 0.001 * (k + 1) for k, p in enumerate(params)},
        "states": {s0: 1.0, s1: 0.0},
        "modes": {"run": {"flow": {s0: f"-{s0} + exp(1)*{params[0]} + pi",
                                   s1: f"{s0} - 2*{s1} + {' + '.join(params[1:])}"}}},
        "initial": {"mode": "run"},
    })


def _kernel_names(model: hybridlab.Model) -> set[str]:
    """The names (not attributes) in the numba kernel source of ``model``."""
    text = generate(hybridlab.compile_model(model)).text
    found, previous = set(), None
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.NAME and previous != ".":
            found.add(tok.string)
        previous = tok.string
    return found


def check_chunk(names: Sequence[str], backend: str) -> list[str]:
    """Differences between the model over ``names`` and its twin (empty: none)."""
    twin = [f"n{k}" for k in range(len(names))]
    problems = []
    a = hybridlab.simulate(model_of(names), t_end=3.0, backend=backend, rtol=1e-10, atol=1e-12)
    b = hybridlab.simulate(model_of(twin), t_end=3.0, backend=backend, rtol=1e-10, atol=1e-12)
    fa = np.array(list(a.final.state.values()))
    fb = np.array(list(b.final.state.values()))
    if a.status != b.status or len(a.events) != len(b.events) or not np.allclose(fa, fb,
                                                                                 rtol=1e-9):
        problems.append(f"simulate: {a.status.name} {fa} against {b.status.name} {fb}")
    text = f"exp(1)*{names[2]} + pi*{names[3]} + {names[0]}"
    va = Observer(hybridlab.compile_model(model_of(names)), [text]).evaluate(a, [0.0])[0, 0]
    expected = math.e * 0.001 + math.pi * 0.002 + 1.0
    if not math.isclose(va, expected, rel_tol=1e-12):
        problems.append(f"observer: {va} against {expected}")
    ra = hybridlab.reach(affine_of(names), initial={names[0]: (0.9, 1.1)}, t_end=1.0, step=0.05)
    rb = hybridlab.reach(affine_of(twin), initial={"n0": (0.9, 1.1)}, t_end=1.0, step=0.05)
    for sa, sb in zip(names[:2], twin[:2], strict=True):
        if not np.allclose(ra.bounds[sa], rb.bounds[sb], rtol=1e-12):
            problems.append(f"reach {sa}: {ra.bounds[sa]} against {rb.bounds[sb]}")
    # the twin's source holds only the kernel's own vocabulary (its names are n0, n1, ...)
    leaked = (_kernel_names(model_of(names)) & set(names)) - _kernel_names(model_of(twin))
    if leaked:
        problems.append(f"kernel source names {sorted(leaked)[:5]}")
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--chunk", type=int, default=150, help="names per model")
    parser.add_argument("--backend", default="reference", choices=("reference", "auto"))
    args = parser.parse_args(argv)
    names = candidate_names()
    print(f"{len(names)} declarable names from numpy, math, sympy, builtins, functools, numba")
    start, failed = time.perf_counter(), 0
    for k in range(0, len(names), args.chunk):
        chunk = names[k:k + args.chunk]
        if len(chunk) < 10:
            chunk = names[-10:]
        problems = check_chunk(chunk, args.backend)
        failed += bool(problems)
        print(f"{chunk[0]:>20} .. {chunk[-1]:<20} {len(chunk):4d} names: "
              f"{'; '.join(problems) or 'same as the twin'}")
    print(f"{failed} of {-(-len(names) // args.chunk)} chunks differ; "
          f"{time.perf_counter() - start:.0f} s")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
