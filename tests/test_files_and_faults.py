"""Output files are replaced atomically; the CLI never prints a traceback.

A failure while writing ``--out`` (a full disk) used to destroy the old file and leave a
truncated one; ``--out up.NPZ`` wrote ``up.NPZ.npz`` and said it wrote ``up.NPZ``; an
internal error printed a 40-line traceback.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab import cli
from hybridlab._files import replaced


def _disk_full(*_args, **_kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


@pytest.mark.parametrize("suffix", [".json", ".csv", ".npz"])
def test_a_failed_write_keeps_the_old_file_and_leaves_nothing_behind(tmp_path, monkeypatch,
                                                                      suffix):
    result = hybridlab.simulate("models/bouncing_ball.toml", t_end=1.0)
    target = tmp_path / f"result{suffix}"
    target.write_bytes(b"precious")
    monkeypatch.setattr(os, "fsync", _disk_full)
    with pytest.raises(OSError, match="No space left"):
        result.save(target)
    assert target.read_bytes() == b"precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]


def test_the_cli_reports_a_full_disk_in_one_line_and_keeps_the_old_file(tmp_path, monkeypatch,
                                                                          capsys):
    target = tmp_path / "out.json"
    target.write_text("precious")
    monkeypatch.setattr(os, "fsync", _disk_full)
    code = cli.main(["simulate", "models/bouncing_ball.toml", "--t-end", "1",
                     "--out", str(target)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "No space left on device" in err
    assert target.read_text() == "precious"


@pytest.mark.parametrize("name", ["up.NPZ", "up.Json", "UP.CSV"])
def test_out_writes_exactly_the_named_file(tmp_path, capsys, name):
    target = tmp_path / name
    assert cli.main(["simulate", "models/bouncing_ball.toml", "--t-end", "1",
                     "--out", str(target)]) == 0
    assert f"wrote {target}" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]
    if name.lower().endswith(".npz"):
        with np.load(target) as data:
            assert str(data["status"]) == "COMPLETED"


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    target = tmp_path / "shared.txt"
    target.write_text("old")
    target.chmod(0o640)
    with replaced(target) as fh:
        fh.write("new")
    assert target.read_text() == "new" and (target.stat().st_mode & 0o777) == 0o640


def test_an_internal_error_is_one_line_and_a_report(monkeypatch, capsys):
    def broken(_args):
        raise RuntimeError("a bug")

    monkeypatch.setattr(cli.check, "_run", broken)
    code = cli.main(["check", "models/bouncing_ball.toml"])
    err = capsys.readouterr().err
    assert code == cli.EXIT_BUG == 70
    assert err.count("\n") == 1 and err.startswith("hybridlab: internal error (RuntimeError)")
    report = err.rstrip().rsplit(" ", 1)[1]
    try:
        text = Path(report).read_text(encoding="utf-8")
        assert "Traceback" in text and "RuntimeError: a bug" in text and "'check'" in text
    finally:
        os.unlink(report)


def test_ctrl_c_in_a_command_exits_130_in_one_line(monkeypatch, capsys):
    def interrupted(_args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli.check, "_run", interrupted)
    assert cli.main(["check", "models/bouncing_ball.toml"]) == cli.EXIT_INTERRUPTED == 130
    assert capsys.readouterr().err == "hybridlab: interrupted\n"


def test_budget_options_on_the_command_line(capsys, tmp_path):
    model = tmp_path / "osc.toml"
    model.write_text('name = "osc"\nstates = { x = 1.0, v = 0.0 }\n[modes.a]\n'
                     'flow = { x = "v", v = "-x" }\n[initial]\nmode = "a"\n')
    assert cli.main(["simulate", str(model), "--t-end", "1e300", "--max-steps", "500"]) == 3
    assert capsys.readouterr().out.startswith("status: STEP_LIMIT: 500 integrator steps")
    assert cli.main(["simulate", str(model), "--t-end", "1e300", "--time-limit", "0.2"]) == 3
    assert capsys.readouterr().out.startswith("status: TIME_LIMIT")


# ----- the compiled-model cache -----------------------------------------------------------
CACHE_MODEL = """
name = "cached"
parameters = { k = 1.5 }
states = { x = 1.0 }
[modes.a]
flow = { x = "-k*x + 0.125" }
[initial]
mode = "a"
"""


def _fresh_import(text: str = CACHE_MODEL):
    """Generate and import a model's compiled module as a new process would."""
    import sys

    from hybridlab.simulation.compiled import backend
    from hybridlab.simulation.compiled.codegen import generate

    source = generate(hybridlab.compile_model(hybridlab.loads_model(text)))
    for name in [n for n in sys.modules if n.startswith("hybridlab_model_")]:
        del sys.modules[name]
    return backend._import(source)


@pytest.mark.parametrize("problem", ["world-writable", "a file", "unwritable parent"])
def test_an_unusable_cache_folder_falls_back_and_says_why(tmp_path, monkeypatch, problem):
    folder = tmp_path / "cache"
    if problem == "world-writable":
        folder.mkdir()
        folder.chmod(0o777)
        expected = "other users can write to it"
    elif problem == "a file":
        folder.write_text("not a folder")
        expected = "it cannot be written"
    else:
        (tmp_path / "ro").write_text("")
        folder = tmp_path / "ro" / "cache"
        expected = "it cannot be written"
    monkeypatch.setenv("HYBRIDLAB_CACHE_DIR", str(folder))
    with pytest.warns(RuntimeWarning, match=rf"HYBRIDLAB_CACHE_DIR.*{expected}.*for this process"):
        module, _ = _fresh_import()
    assert "hybridlab-cache-" in module.__file__
    if problem == "world-writable":
        assert list(folder.iterdir()) == []  # nothing was written or loaded there


def test_a_damaged_cache_entry_is_compiled_afresh(tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDLAB_CACHE_DIR", str(tmp_path))
    module, _ = _fresh_import()
    entries = list((tmp_path / "__pycache__").iterdir())
    assert entries
    for entry in entries:  # numba's index and code, damaged
        entry.write_bytes(b"\x80\x04garbage")
    module, _ = _fresh_import()
    result = hybridlab.simulate(hybridlab.loads_model(CACHE_MODEL), t_end=1.0)
    assert result.stats["backend"] == "compiled"
    exact = 0.125 / 1.5 + (1 - 0.125 / 1.5) * np.exp(-1.5)
    assert result.final.state["x"] == pytest.approx(exact, rel=1e-8)


def test_a_compiled_model_is_loaded_from_the_cache_by_the_next_process(tmp_path):
    import subprocess
    import sys

    script = ("import hybridlab; m = hybridlab.loads_model('''" + CACHE_MODEL + "''');"
              "r = hybridlab.simulate(m, t_end=1.0); print(r.stats['compiled_cache_hit'])")
    env = {**os.environ, "HYBRIDLAB_CACHE_DIR": str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                           text=True, timeout=300) for _ in range(2)]
    assert [r.stdout.strip() for r in runs] == ["False", "True"], [r.stderr for r in runs]


def test_a_model_too_large_to_compile_quickly_runs_on_the_reference_engine(tmp_path,
                                                                           monkeypatch):
    from hybridlab.simulation.compiled import backend

    monkeypatch.setenv("HYBRIDLAB_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(backend, "MAX_AUTO_COMPILE_LINES", 10)  # the ball's module has ~70
    model = hybridlab.loads_model(CACHE_MODEL.replace("0.125", "0.25"))
    with pytest.warns(RuntimeWarning, match=r"the reference engine runs 'cached': its "
                                             r"generated code has \d+ lines"):
        auto = hybridlab.simulate(model, t_end=1.0)
    assert auto.stats["backend"] == "reference" and "slow to compile" in auto.stats["fallback"]
    forced = hybridlab.simulate(model, t_end=1.0, backend="compiled")
    assert forced.stats["backend"] == "compiled"
    assert forced.final.state["x"] == pytest.approx(auto.final.state["x"], rel=1e-8)
    again = hybridlab.simulate(hybridlab.loads_model(CACHE_MODEL.replace("0.125", "0.25")),
                               t_end=1.0)  # compiled before: loaded from the cache
    assert again.stats["backend"] == "compiled"
