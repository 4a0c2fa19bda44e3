"""The hostile-input suite: one file per case under ``tests/hostile/``, each with its verdict.

``tests/hostile/models/*.toml`` are model files; their leading comment lines say what
must happen:

* ``# expect: error: TEXT`` -- loading (and, with ``# run:``, running) raises a
  :class:`hybridlab.HybridlabError` or ``ValueError`` whose one-line message contains TEXT;
* ``# expect: status: NAME`` -- the run ends with that status (and ``# message: TEXT``
  says what its message must contain);
* ``# run: key=value ...`` -- keywords of :func:`hybridlab.simulate` (default
  ``t_end=1``); ``# backends: reference auto`` runs each backend (default: reference);
* ``# final: NAME=VALUE ...`` -- final state values (relative tolerance ``1e-7``).

``tests/hostile/cli/*.args`` hold one command line (after ``hybridlab``) and
``# expect: exit N: TEXT``: the exit code and a text on stderr, which must be one line
(never a traceback). ``{models}`` in a command line is the bundled ``models/`` folder.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import hybridlab
from hybridlab import cli

HERE = Path(__file__).parent / "hostile"
ROOT = Path(__file__).resolve().parents[1]


@dataclass
class Case:
    path: Path
    expect: str = ""
    message: str = ""
    run: dict[str, object] = field(default_factory=dict)
    backends: tuple[str, ...] = ("reference",)
    final: dict[str, float] = field(default_factory=dict)


def _value(text: str) -> object:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return {"True": True, "False": False}.get(text, text)


def _header(path: Path) -> dict[str, str]:
    fields = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        key, _, value = line[1:].partition(":")
        fields[key.strip()] = value.strip()
    return fields


def _case(path: Path) -> Case:
    head = _header(path)
    case = Case(path, head.get("expect", ""), head.get("message", ""))
    case.run = {"t_end": 1.0}
    for item in head.get("run", "").split():
        key, _, value = item.partition("=")
        case.run[key] = _value(value)
    if "backends" in head:
        case.backends = tuple(head["backends"].split())
    for item in head.get("final", "").split():
        key, _, value = item.partition("=")
        case.final[key] = float(value)
    return case


MODEL_CASES = sorted((HERE / "models").glob("*.toml"))
CLI_CASES = sorted((HERE / "cli").glob("*.args"))


def test_the_suite_is_large_and_every_case_says_what_it_expects():
    assert len(MODEL_CASES) + len(CLI_CASES) >= 200
    for path in MODEL_CASES:
        assert _case(path).expect.split(":")[0] in ("error", "status"), path.name
    for path in CLI_CASES:
        assert _header(path)["expect"].startswith("exit "), path.name


@pytest.mark.parametrize("path", MODEL_CASES, ids=lambda p: p.stem)
def test_model_case(path: Path) -> None:
    case = _case(path)
    kind, _, expected = case.expect.partition(":")
    expected = expected.strip()
    for backend in case.backends:
        if kind == "error":
            with pytest.raises((hybridlab.HybridlabError, ValueError)) as info:
                model = hybridlab.load_model(path)
                hybridlab.simulate(model, backend=backend, **case.run)
            text = str(info.value)
            assert "\n" not in text, text
            assert expected in text, text
            continue
        result = hybridlab.simulate(hybridlab.load_model(path), backend=backend, **case.run)
        assert result.status.name == expected, (backend, result.message)
        assert case.message in result.message, (backend, result.message)
        for name, value in case.final.items():
            assert result.final.state[name] == pytest.approx(value, rel=1e-7), (backend, name)


@pytest.mark.parametrize("path", CLI_CASES, ids=lambda p: p.stem)
def test_cli_case(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    head = _header(path)
    code_text, _, expected = head["expect"].removeprefix("exit ").partition(":")
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines()
             if ln.strip() and not ln.startswith("#")]
    line = lines[0] if lines else ""
    argv = shlex.split(line.replace("{models}", str(ROOT / "models")).replace("{cases}", str(HERE)))
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == int(code_text), (code, err)
    assert "Traceback" not in err and err.count("\n") <= 1, err
    assert expected.strip() in err, err
