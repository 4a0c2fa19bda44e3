"""Model files: one-line load errors, the round trip, the Python API and the JSON schema."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import pydantic
import pytest
import sympy as sp
from strategies import MODEL_FILES, ROOT

import hybridlab
from hybridlab import (
    Initial,
    Mode,
    Model,
    ModelError,
    Parameter,
    Scenario,
    Schedule,
    State,
    Transition,
    dumps_model,
    load_model,
    loads_model,
    model_from_dict,
    model_json_schema,
)

BALL = """\
name = "ball"

[parameters]
g = 9.81
e = 0.8

[states]
h = 10.0
v = 0.0

[definitions]
energy = "0.5*v**2 + g*h"

[modes.fall]
flow = { h = "v", v = "-g" }
invariant = ["h >= 0"]

[[transitions]]
name = "bounce"
source = "fall"
target = "fall"
guard = "h <= 0"
reset = { v = "-e*v" }

[initial]
mode = "fall"

[scenarios.default]
t_end = 10.0
"""


def edited(old: str, new: str) -> str:
    assert BALL.count(old) == 1, old
    return BALL.replace(old, new)


def load_error(tmp_path: Path, text: str) -> tuple[Path, ModelError]:
    path = tmp_path / "ball.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(path)
    return path, info.value


def test_base_model_is_valid(tmp_path: Path) -> None:
    path = tmp_path / "ball.toml"
    path.write_text(BALL)
    model = load_model(path)
    assert model.state_names == ("h", "v")
    assert model.parameter_names == ("g", "e")
    assert list(model.modes) == ["fall"]
    assert [tr.name for tr in model.transitions] == ["bounce"]


# ----------------------------------------------------------------------------------------
# load-time errors: FILE: KEY.PATH: message (token 'X')

ERRORS = [
    # unknown keys
    pytest.param(('guard = "h <= 0"', 'guards = "h <= 0"'),
                 "transitions[0].guards: unknown key (token 'guards')", id="guards"),
    pytest.param(('name = "ball"', 'name = "ball"\nparameter = 1'),
                 "parameter: unknown key (token 'parameter')", id="top-level-typo"),
    pytest.param(('invariant = ["h >= 0"]', 'invariants = ["h >= 0"]'),
                 "modes.fall.invariants: unknown key (token 'invariants')", id="invariants"),
    pytest.param(("g = 9.81", "g = { value = 9.81, units = \"m\" }"),
                 "parameters.g.units: unknown key (token 'units')", id="parameter-key"),
    pytest.param(("t_end = 10.0", "t_end = 10.0\ntend = 1.0"),
                 "scenarios.default.tend: unknown key (token 'tend')", id="scenario-key"),
    # unknown symbols
    pytest.param(('"-g"', '"-gg"'), "modes.fall.flow.v: unknown symbol (token 'gg')",
                 id="symbol-in-flow"),
    pytest.param(('"h <= 0"', '"hh <= 0"'),
                 "transitions[0].guard[0]: unknown symbol (token 'hh')", id="symbol-in-guard"),
    pytest.param(('"-e*v"', '"-ee*v"'), "transitions[0].reset.v: unknown symbol (token 'ee')",
                 id="symbol-in-reset"),
    pytest.param(('"h >= 0"', '"hh >= 0"'),
                 "modes.fall.invariant[0]: unknown symbol (token 'hh')", id="symbol-in-invariant"),
    pytest.param(('"0.5*v**2 + g*h"', '"0.5*w**2"'),
                 "definitions.energy: unknown symbol (token 'w')", id="symbol-in-definition"),
    # flows and states
    pytest.param(('flow = { h = "v", v = "-g" }', 'flow = { h = "v" }'),
                 "modes.fall.flow: state 'v' has no flow in mode 'fall' (token 'v')",
                 id="state-without-flow"),
    pytest.param(('flow = { h = "v", v = "-g" }', 'flow = { h = "v", v = "-g", w = "1" }'),
                 "modes.fall.flow.w: flow given for an unknown state (token 'w')",
                 id="flow-for-unknown-state"),
    # transitions
    pytest.param(('target = "fall"', 'target = "rise"'),
                 "transitions[0].target: transition target is not a mode (token 'rise')",
                 id="unknown-target"),
    pytest.param(('source = "fall"', 'source = "rise"'),
                 "transitions[0].source: transition source is not a mode (token 'rise')",
                 id="unknown-source"),
    pytest.param(('reset = { v = "-e*v" }', 'reset = { w = "-e*v" }'),
                 "transitions[0].reset.w: reset of an unknown state (token 'w')",
                 id="reset-unknown-state"),
    pytest.param(('"h <= 0"', '"h == 0"'),
                 "transitions[0].guard[0]: only inequalities (<, <=, >, >=) are allowed "
                 "(token '==')", id="guard-eq"),
    pytest.param(('"h <= 0"', '"h != 0"'),
                 "transitions[0].guard[0]: only inequalities (<, <=, >, >=) are allowed "
                 "(token '!=')", id="guard-ne"),
    pytest.param(('"h <= 0"', '"h"'),
                 "transitions[0].guard[0]: an inequality such as 'x >= 0' is expected "
                 "(token 'h')", id="guard-bare"),
    pytest.param(('"h <= 0"', '"h <= 0 or v < 0"'),
                 "transitions[0].guard[0]: 'or' is not supported; use one transition per "
                 "alternative (token 'or')", id="guard-or"),
    pytest.param(('"h <= 0"', '["v < 0", "h^2 <= 0"]'),
                 "transitions[0].guard[1]: '^' is not a power; use '**' (token '^')",
                 id="guard-caret"),
    pytest.param(('guard = "h <= 0"\n', ""),
                 "transitions[0].guard: a transition needs a guard or a schedule "
                 "(token 'bounce')", id="no-guard-no-schedule"),
    pytest.param(('guard = "h <= 0"', "guard = []"),
                 "transitions[0].guard: a transition needs a guard or a schedule "
                 "(token 'bounce')", id="empty-guard"),
    pytest.param(('name = "bounce"', 'name = "bounce"\nschedule = { period = "hh" }'),
                 "transitions[0].schedule.period: unknown symbol (token 'hh')",
                 id="symbol-in-period"),
    pytest.param(('name = "bounce"', 'name = "bounce"\nschedule = { period = "h" }'),
                 "transitions[0].schedule.period: unknown symbol (token 'h')",
                 id="state-in-period"),
    pytest.param(('source = "fall"', "source = []"),
                 "transitions[0].source: a transition needs at least one source mode",
                 id="no-source"),
    pytest.param(('source = "fall"', 'source = ["fall", "rise"]'),
                 "transitions[0].source[1]: transition source is not a mode (token 'rise')",
                 id="unknown-source-in-list"),
    pytest.param(('reset = { v = "-e*v" }', 'reset = { v = "-e*v" }\n\n[[transitions]]\n'
                  'name = "bounce"\nsource = "fall"\ntarget = "fall"\nguard = "h <= 0"'),
                 "transitions[1].name: transition name used twice (token 'bounce')",
                 id="duplicate-transition"),
    pytest.param(('mode = "fall"', 'mode = "rise"'),
                 "initial.mode: initial mode is not a mode (token 'rise')", id="initial-mode"),
    # names
    pytest.param(("g = 9.81", "sin = 9.81"),
                 "parameters.sin: name shadows a built-in function or constant (token 'sin')",
                 id="shadow-sin"),
    pytest.param(("g = 9.81", "sqrt = 9.81"),
                 "parameters.sqrt: name shadows a built-in function or constant (token 'sqrt')",
                 id="shadow-sqrt"),
    pytest.param(("g = 9.81", "t = 9.81"),
                 "parameters.t: name shadows the time symbol (token 't')", id="shadow-t"),
    pytest.param(("h = 10.0", "pi = 10.0"),
                 "states.pi: name shadows a built-in function or constant (token 'pi')",
                 id="shadow-pi"),
    pytest.param(("h = 10.0", "t = 10.0"),
                 "states.t: name shadows the time symbol (token 't')", id="state-t"),
    pytest.param(('energy = "0.5*v**2 + g*h"', 'exp = "v"'),
                 "definitions.exp: name shadows a built-in function or constant (token 'exp')",
                 id="shadow-definition"),
    pytest.param(("g = 9.81", "g = 9.81\nh = 1.0"),
                 "states.h: name already declared in [parameters] (token 'h')",
                 id="duplicate-parameter-state"),
    pytest.param(('energy = "0.5*v**2 + g*h"', 'g = "v"'),
                 "definitions.g: name already declared in [parameters] (token 'g')",
                 id="duplicate-parameter-definition"),
    pytest.param(('energy = "0.5*v**2 + g*h"', 'v = "h"'),
                 "definitions.v: name already declared in [states] (token 'v')",
                 id="duplicate-state-definition"),
    # definition cycles
    pytest.param(('energy = "0.5*v**2 + g*h"', 'a = "b"\nb = "a"'),
                 "definitions.b: definitions refer to each other in a cycle (token 'a -> b -> a')",
                 id="cycle-2"),
    pytest.param(('energy = "0.5*v**2 + g*h"', 'a = "a + 1"'),
                 "definitions.a: definitions refer to each other in a cycle (token 'a -> a')",
                 id="cycle-self"),
    # scenarios
    pytest.param(("t_end = 10.0", "t_end = 10.0\nparameters = { q = 1.0 }"),
                 "scenarios.default.parameters.q: unknown parameter (token 'q')",
                 id="scenario-parameter"),
    pytest.param(("t_end = 10.0", "t_end = 10.0\ninitial = { w = 1.0 }"),
                 "scenarios.default.initial.w: unknown state (token 'w')", id="scenario-state"),
    pytest.param(("t_end = 10.0", 't_end = 10.0\nmode = "rise"'),
                 "scenarios.default.mode: scenario mode is not a mode (token 'rise')",
                 id="scenario-mode"),
    pytest.param(("t_end = 10.0", "t_end = 0.0"),
                 "scenarios.default.t_end: t_end must be greater than t_start (token '0.0')",
                 id="t_end-zero"),
    pytest.param(("t_end = 10.0", "t_end = 5.0\nt_start = 5.0"),
                 "scenarios.default.t_end: t_end must be greater than t_start (token '5.0')",
                 id="t_end-equal"),
    pytest.param(("t_end = 10.0", "t_end = 1.0\nt_start = 2.0"),
                 "scenarios.default.t_end: t_end must be greater than t_start (token '1.0')",
                 id="t_end-before"),
    # non-finite numbers
    pytest.param(("g = 9.81", "g = inf"),
                 "parameters.g.value: Input should be a finite number (token 'inf')",
                 id="inf-parameter"),
    pytest.param(("g = 9.81", "g = nan"),
                 "parameters.g.value: Input should be a finite number (token 'nan')",
                 id="nan-parameter"),
    pytest.param(("g = 9.81", "g = { value = -inf }"),
                 "parameters.g.value: Input should be a finite number (token '-inf')",
                 id="inf-parameter-table"),
    pytest.param(("h = 10.0", "h = nan"),
                 "states.h.initial: Input should be a finite number (token 'nan')",
                 id="nan-state"),
    pytest.param(("t_end = 10.0", "t_end = inf"),
                 "scenarios.default.t_end: Input should be a finite number (token 'inf')",
                 id="inf-t_end"),
    pytest.param(("t_end = 10.0", "t_end = 1.0\nparameters = { g = nan }"),
                 "scenarios.default.parameters.g: Input should be a finite number (token 'nan')",
                 id="nan-scenario-parameter"),
    pytest.param(("t_end = 10.0", "t_end = 1.0\ninitial = { h = inf }"),
                 "scenarios.default.initial.h: Input should be a finite number (token 'inf')",
                 id="inf-scenario-initial"),
    pytest.param(('"-g"', '"-g*1e400"'),
                 "modes.fall.flow.v: number is not finite (token '1e400')", id="inf-literal"),
    # structure
    pytest.param(('[initial]\nmode = "fall"\n', ""),
                 "initial: required key is missing (token 'initial')", id="missing-initial"),
    pytest.param(("g = 9.81", 'g = "abc"'),
                 "parameters.g: Input should be a valid dictionary or instance of Parameter "
                 "(token 'abc')", id="parameter-string"),
]


@pytest.mark.parametrize(("edit", "message"), ERRORS)
def test_load_errors_are_one_line_with_file_key_and_token(
    tmp_path: Path, edit: tuple[str, str], message: str
) -> None:
    path, error = load_error(tmp_path, edited(*edit))
    assert str(error) == f"{path}: {message}"
    assert error.source == str(path)


@pytest.mark.parametrize(
    ("edit", "key", "token"),
    [
        # a misspelt required key must be reported as the unknown key the user wrote,
        # not only as the required key that is now missing
        pytest.param(("flow = {", "flw = {"), "modes.fall.flw", "flw", id="flw-in-mode"),
        pytest.param(('name = "ball"', 'nme = "ball"'), "nme", "nme", id="top-level-nme"),
        pytest.param(('source = "fall"', 'sorce = "fall"'), "transitions[0].sorce", "sorce",
                     id="sorce-in-transition"),
    ],
)
def test_misspelt_required_key_is_named(
    tmp_path: Path, edit: tuple[str, str], key: str, token: str
) -> None:
    path, error = load_error(tmp_path, edited(*edit))
    assert str(error) == f"{path}: {key}: unknown key (token {token!r})"


@pytest.mark.parametrize(
    ("edit", "key", "token"),
    [
        # fields typed as a union (float | expression, mode | list of modes) must not leak
        # pydantic's branch names ('.float', '.str') into the key path
        pytest.param(('name = "bounce"', 'name = "bounce"\nschedule = { period = nan }'),
                     "transitions[0].schedule.period", "nan", id="nan-period"),
        pytest.param(('source = "fall"', "source = 1"), "transitions[0].source", "1",
                     id="number-source"),
    ],
)
def test_union_fields_report_the_users_key(
    tmp_path: Path, edit: tuple[str, str], key: str, token: str
) -> None:
    _, error = load_error(tmp_path, edited(*edit))
    assert (error.key, error.token) == (key, token)


def test_model_error_is_a_value_error_with_fields(tmp_path: Path) -> None:
    path, error = load_error(tmp_path, edited('"-g"', '"-gg"'))
    assert isinstance(error, ValueError)
    assert isinstance(error, hybridlab.HybridlabError)
    assert (error.source, error.key, error.token, error.message) == (
        str(path), "modes.fall.flow.v", "gg", "unknown symbol")


@pytest.mark.parametrize(
    "text",
    [
        'name = "ball',
        "name = ball",
        "[states\nh = 1.0",
        "a = 1\na = 2",
        "= 1",
        "x = [1, 2",
        "x = { y = 1\n}",
        "\x00",
    ],
)
def test_bad_toml_is_a_model_error(tmp_path: Path, text: str) -> None:
    path, error = load_error(tmp_path, text)
    assert str(error).startswith(f"{path}: invalid TOML: ")
    assert "\n" not in str(error)


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.toml"
    with pytest.raises(ModelError) as info:
        load_model(path)
    assert str(info.value) == f"{path}: cannot read file: No such file or directory"


def test_file_that_is_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes('name = "Müller"\n'.encode("latin-1"))
    with pytest.raises(ModelError) as info:
        load_model(path)
    assert str(info.value) == f"{path}: file is not UTF-8 text"


def test_loads_model_names_its_source() -> None:
    with pytest.raises(ModelError) as info:
        loads_model(edited('"-g"', '"-gg"'), source="inline")
    assert str(info.value) == "inline: modes.fall.flow.v: unknown symbol (token 'gg')"
    with pytest.raises(ModelError) as info:
        loads_model(edited('"-g"', '"-gg"'))
    assert str(info.value) == "<string>: modes.fall.flow.v: unknown symbol (token 'gg')"


def test_model_from_dict_refuses_a_non_table() -> None:
    with pytest.raises(ModelError) as info:
        model_from_dict([1, 2], source="data.json")  # type: ignore[arg-type]
    assert str(info.value) == "data.json: a model must be a table of keys"


def test_message_stays_on_one_line_when_a_key_contains_a_newline(tmp_path: Path) -> None:
    # mode names are free text; a key path built from one must not break the one-line format
    text = edited('[modes.fall]', '[modes."fa\\nll"]').replace('"fall"', '"fa\\nll"')
    text = text.replace('"-g"', '"-gg"')
    _, error = load_error(tmp_path, text)
    assert "\n" not in str(error)
    assert "unknown symbol (token 'gg')" in str(error)


def test_declared_name_is_usable_or_refused_where_declared() -> None:
    # 'ﬁ' (U+FB01) is an identifier, but Python's parser NFKC-normalises it to 'fi', so a
    # flow that uses the declared name cannot find it; either accept it or refuse the
    # declaration itself
    text = ('name = "lig"\n[states]\n"ﬁ" = 1.0\n[modes.m]\nflow = { "ﬁ" = "-ﬁ" }\n'
            '[initial]\nmode = "m"\n')
    try:
        model = loads_model(text, source="lig.toml")
    except ModelError as error:
        assert error.key == "states.ﬁ", str(error)
    else:
        assert model.state_names == ("ﬁ",)


# ----------------------------------------------------------------------------------------
# accepted forms


def test_shorthand_and_table_forms_are_the_same_model() -> None:
    long = edited("g = 9.81", 'g = { value = 9.81, unit = "1", description = "" }')
    long = long.replace("h = 10.0", "h = { initial = 10.0 }")
    long = long.replace('guard = "h <= 0"', 'guard = ["h <= 0"]')
    long = long.replace('invariant = ["h >= 0"]', 'invariant = "h >= 0"')
    assert loads_model(long) == loads_model(BALL)


def test_guards_and_invariants_parse_to_inequalities() -> None:
    model = loads_model(edited('guard = "h <= 0"', 'guard = ["0 <= v <= 1", "h <= 0 and v < 0"]'))
    h, v = sp.symbols("h v", real=True)
    [bounce] = model.symbolic.transitions
    assert [(g.expr, g.strict) for g in bounce.guard] == [
        (v, False), (1 - v, False), (-h, False), (-v, True)]
    assert [(i.expr, i.strict) for i in model.symbolic.modes["fall"].invariants] == [(h, False)]


def test_definitions_are_substituted_in_dependency_order() -> None:
    model = loads_model(edited('energy = "0.5*v**2 + g*h"', 'b = "2*a"\na = "v + 1"')
                        .replace('"-g"', '"-b"'))
    v = sp.Symbol("v", real=True)
    assert model.symbolic.definitions == {"b": 2 * (v + 1), "a": v + 1}
    assert model.symbolic.modes["fall"].flow[1] == -2 * (v + 1)


# ----------------------------------------------------------------------------------------
# round trip


@pytest.mark.parametrize("path", MODEL_FILES, ids=[p.name for p in MODEL_FILES])
def test_bundled_models_round_trip(path: Path) -> None:
    model = load_model(path)
    text = dumps_model(model)
    assert loads_model(text) == model
    assert dumps_model(loads_model(text)) == text


def test_bundled_models_exist() -> None:
    names = {p.name for p in MODEL_FILES}
    assert {"bouncing_ball.toml", "thermostat.toml", "friction_oscillator.toml",
            "relay_sliding.toml"} <= names


def test_dumped_ball_is_exactly_the_canonical_text() -> None:
    assert dumps_model(loads_model(BALL)) == (
        'name = "ball"\n'
        "\n[parameters]\n"
        "g = { value = 9.81 }\n"
        "e = { value = 0.8 }\n"
        "\n[states]\n"
        "h = { initial = 10.0 }\n"
        "v = { initial = 0.0 }\n"
        "\n[definitions]\n"
        'energy = "0.5*v**2 + g*h"\n'
        "\n[modes]\n"
        "\n[modes.fall]\n"
        'flow = { h = "v", v = "-g" }\n'
        'invariant = ["h >= 0"]\n'
        "\n[initial]\n"
        'mode = "fall"\n'
        "\n[scenarios]\n"
        "\n[scenarios.default]\n"
        "t_end = 10.0\n"
        "\n[[transitions]]\n"
        'name = "bounce"\n'
        'source = "fall"\n'
        'target = "fall"\n'
        'guard = ["h <= 0"]\n'
        'reset = { v = "-e*v" }\n'
    )


def test_round_trip_equality_survives_compilation() -> None:
    # equality must compare the model, not whether a compiled cache happens to be attached
    model = loads_model(BALL)
    hybridlab.compile_model(model)
    assert loads_model(dumps_model(model)) == model


def test_compiled_and_fresh_copies_compare_equal() -> None:
    compiled, fresh = loads_model(BALL), loads_model(BALL)
    hybridlab.simulate(compiled, 0.1)
    assert compiled == fresh


@pytest.mark.parametrize(
    ("old", "new"),
    [
        pytest.param('name = "ball"', 'name = "ball"\ndescription = "line\\rbreak"', id="CR"),
        pytest.param('name = "ball"', 'name = "ball"\ndescription = "nul\\u0000"', id="NUL"),
        pytest.param('name = "ball"', 'name = "ball"\ndescription = "del\\u007F"', id="DEL"),
        pytest.param('name = "ball"', 'name = "ball"\ndescription = "tab\\tnew\\nline"',
                     id="tab-newline"),
        pytest.param('name = "bounce"', 'name = "bo\\u0001unce"', id="control-in-name"),
        pytest.param("[modes.fall]", '[modes."fa ll"]', id="space-in-mode"),
        pytest.param("[modes.fall]", '[modes."fäll"]', id="non-ascii-mode"),
        pytest.param("[modes.fall]", '[modes."²"]', id="superscript-mode"),
    ],
)
def test_strings_and_keys_round_trip(old: str, new: str) -> None:
    text = edited(old, new)
    if old == "[modes.fall]":
        mode = tomllib.loads(new + "\n")["modes"]
        [name] = mode
        text = text.replace('"fall"', json.dumps(name, ensure_ascii=False))
    model = loads_model(text)
    assert loads_model(dumps_model(model)) == model


def test_non_ascii_identifiers_round_trip() -> None:
    text = ('name = "greek"\n[parameters]\n"λ" = 0.5\n[states]\n"θ" = 1.0\n'
            '[modes.m]\nflow = { "θ" = "-λ*θ" }\n[initial]\nmode = "m"\n')
    model = loads_model(text)
    assert model.state_names == ("θ",)
    assert loads_model(dumps_model(model)) == model


# ----------------------------------------------------------------------------------------
# Python API


def python_ball() -> Model:
    return Model(
        name="ball",
        parameters={"g": 9.81, "e": 0.8},
        states={"h": 10.0, "v": 0.0},
        definitions={"energy": "0.5*v**2 + g*h"},
        modes={"fall": Mode(flow={"h": "v", "v": "-g"}, invariant=["h >= 0"])},
        transitions=[Transition(name="bounce", source="fall", target="fall", guard="h <= 0",
                                reset={"v": "-e*v"})],
        initial=Initial(mode="fall"),
        scenarios={"default": Scenario(t_end=10.0)},
    )


def test_python_model_equals_the_toml_model() -> None:
    assert python_ball() == loads_model(BALL)


def test_python_model_with_explicit_objects_equals_the_toml_model() -> None:
    model = Model(
        name="ball",
        parameters={"g": Parameter(value=9.81), "e": Parameter(value=0.8)},
        states={"h": State(initial=10.0), "v": State(initial=0.0)},
        definitions={"energy": "0.5*v**2 + g*h"},
        modes={"fall": {"flow": {"h": "v", "v": "-g"}, "invariant": "h >= 0"}},
        transitions=[{"name": "bounce", "source": "fall", "target": "fall",
                      "guard": ["h <= 0"], "reset": {"v": "-e*v"}}],
        initial={"mode": "fall"},
        scenarios={"default": {"t_end": 10.0}},
    )
    assert model == loads_model(BALL)


def test_changed_python_model_differs() -> None:
    assert python_ball() != loads_model(edited("e = 0.8", "e = 0.7"))


@pytest.mark.parametrize(
    ("obj", "field", "value"),
    [
        (python_ball(), "name", "other"),
        (python_ball(), "transitions", []),
        (Parameter(value=1.0), "value", 2.0),
        (State(initial=1.0), "initial", 2.0),
        (Mode(flow={"x": "-x"}), "flow", {}),
        (Transition(name="a", source="m", target="m", guard="x <= 0"), "guard", []),
        (Schedule(period=1.0), "period", 2.0),
        (Initial(mode="m"), "mode", "n"),
        (Scenario(t_end=1.0), "t_end", 2.0),
    ],
    ids=lambda v: type(v).__name__ if isinstance(v, pydantic.BaseModel) else None,
)
def test_models_are_frozen(obj: pydantic.BaseModel, field: str, value: Any) -> None:
    with pytest.raises(pydantic.ValidationError, match="Instance is frozen"):
        setattr(obj, field, value)


@pytest.mark.parametrize(
    ("cls", "kwargs"),
    [
        (Parameter, {"value": 1.0, "units": "m"}),
        (State, {"initial": 1.0, "inital": 2.0}),
        (Mode, {"flow": {"x": "-x"}, "flw": {"x": "-x"}}),
        (Transition, {"name": "a", "source": "m", "target": "m", "guards": "x <= 0"}),
        (Schedule, {"period": 1.0, "offset": 0.0}),
        (Initial, {"mode": "m", "state": {}}),
        (Scenario, {"t_end": 1.0, "tend": 1.0}),
    ],
)
def test_unknown_keys_rejected_in_python(cls: type[pydantic.BaseModel], kwargs: dict) -> None:
    with pytest.raises(pydantic.ValidationError) as info:
        cls(**kwargs)
    [error] = info.value.errors()
    assert error["type"] == "extra_forbidden"


def test_unknown_top_level_key_rejected_in_python() -> None:
    data = python_ball().model_dump()
    data["parameter"] = {}
    with pytest.raises(pydantic.ValidationError) as info:
        Model(**data)
    assert [e["type"] for e in info.value.errors()] == ["extra_forbidden"]


def test_meaning_errors_in_python_name_key_and_token() -> None:
    with pytest.raises(pydantic.ValidationError) as info:
        Model(name="x", states={"x": 1.0}, modes={"m": Mode(flow={"x": "-y"})},
              initial=Initial(mode="m"))
    [error] = info.value.errors()
    cause = error["ctx"]["error"]
    assert isinstance(cause, ModelError)
    assert str(cause) == "modes.m.flow.x: unknown symbol (token 'y')"


def test_updated_copy_is_validated() -> None:
    ball = python_ball()
    lighter = ball.updated_copy(name="ball2")
    assert (lighter.name, ball.name) == ("ball2", "ball")
    with pytest.raises(pydantic.ValidationError):
        ball.updated_copy(initial={"mode": "rise"})


def test_non_finite_numbers_rejected_in_python() -> None:
    with pytest.raises(pydantic.ValidationError):
        Parameter(value=float("nan"))
    with pytest.raises(pydantic.ValidationError):
        State(initial=float("inf"))
    with pytest.raises(pydantic.ValidationError):
        Scenario(t_end=1.0, parameters={"g": float("inf")})


# ----------------------------------------------------------------------------------------
# JSON schema

SCHEMA_FILE = ROOT / "docs" / "model.schema.json"


def test_schema_describes_the_top_level_keys() -> None:
    schema = model_json_schema()
    assert isinstance(schema, dict)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["title"] == "hybridlab model"
    assert schema["anyOf"] == [{"$ref": "#/$defs/Model"}, {"$ref": "#/$defs/Network"}]
    flat = schema["$defs"]["Model"]
    assert flat["type"] == "object"
    assert list(flat["properties"]) == list(Model.model_fields)
    assert {"name", "description", "parameters", "states", "definitions", "modes", "transitions",
            "initial", "scenarios"} <= set(flat["properties"])
    assert flat["required"] == ["name", "states", "modes", "initial"]
    assert flat["additionalProperties"] is False
    network = schema["$defs"]["Network"]
    assert set(network["properties"]) == {"name", "description", "imports", "templates",
                                          "instances", "scenarios", "qualify"}
    for name in ("Network", "Template", "Instance", "SyncTransition"):
        assert schema["$defs"][name]["additionalProperties"] is False
    for name in ("Parameter", "State", "Mode", "Transition", "Schedule", "Initial", "Scenario"):
        assert schema["$defs"][name]["additionalProperties"] is False
    assert set(schema["$defs"]["Mode"]["properties"]) >= {"flow", "invariant"}
    assert schema["$defs"]["Transition"]["required"] == ["name", "source", "target"]
    assert schema["$defs"]["Scenario"]["required"] == ["t_end"]


def test_schema_is_json_serialisable() -> None:
    schema = model_json_schema()
    assert json.loads(json.dumps(schema)) == schema


def test_committed_schema_file_is_in_sync() -> None:
    assert SCHEMA_FILE.read_text(encoding="utf-8") == (
        json.dumps(model_json_schema(), indent=2) + "\n"
    ), "docs/model.schema.json is stale: run `hybridlab schema --out docs/model.schema.json`"


def _schema_errors(value: Any, schema: dict, root: dict, path: str = "") -> list[str]:
    """The JSON-schema subset pydantic emits here: $ref, type (one or a list), properties,
    additionalProperties, required, items, anyOf, min/maxLength, exclusiveMinimum."""
    if "$ref" in schema:
        name = schema["$ref"].removeprefix("#/$defs/")
        return _schema_errors(value, root["$defs"][name], root, path)
    if "anyOf" in schema:
        options = [_schema_errors(value, s, root, path) for s in schema["anyOf"]]
        return [] if any(not o for o in options) else [f"{path}: matches no anyOf branch"]
    kinds = {"object": dict, "array": list, "string": str, "boolean": bool,
             "integer": int, "number": (int, float), "null": type(None)}
    kind = schema.get("type")

    def matches(k: str) -> bool:
        return isinstance(value, kinds[k]) and not (k in ("integer", "number")
                                                     and isinstance(value, bool))

    if kind and not any(matches(k) for k in ([kind] if isinstance(kind, str) else kind)):
        return [f"{path}: {type(value).__name__} is not {kind}"]
    errors = []
    if isinstance(value, dict):
        props = schema.get("properties", {})
        errors += [f"{path}.{k}: required" for k in schema.get("required", ()) if k not in value]
        for k, v in value.items():
            sub = props.get(k, schema.get("additionalProperties", True))
            if sub is False:
                errors.append(f"{path}.{k}: not allowed")
            elif isinstance(sub, dict):
                errors += _schema_errors(v, sub, root, f"{path}.{k}")
    if isinstance(value, list) and "items" in schema:
        for i, v in enumerate(value):
            errors += _schema_errors(v, schema["items"], root, f"{path}[{i}]")
    if isinstance(value, str) and not (schema.get("minLength", 0) <= len(value)
                                       <= schema.get("maxLength", len(value))):
        errors.append(f"{path}: wrong length")
    if "exclusiveMinimum" in schema and not value > schema["exclusiveMinimum"]:
        errors.append(f"{path}: not > {schema['exclusiveMinimum']}")
    return errors


def test_schema_checker_finds_errors() -> None:
    schema = model_json_schema()
    assert _schema_errors({"name": "x", "nme": 1}, schema, schema) == [": matches no anyOf branch"]
    flat = schema["$defs"]["Model"]
    assert _schema_errors({"name": "x", "nme": 1}, flat, schema) == [
        ".states: required", ".modes: required", ".initial: required", ".nme: not allowed"]


def test_dumped_models_satisfy_the_schema() -> None:
    schema = model_json_schema()
    for path in MODEL_FILES:
        data = tomllib.loads(dumps_model(load_model(path)))
        assert _schema_errors(data, schema, schema) == [], path.name


@pytest.mark.parametrize("path", MODEL_FILES, ids=[p.name for p in MODEL_FILES])
def test_bundled_model_files_satisfy_the_schema(path: Path) -> None:
    # editors validate the file as written: the shorthands the loader accepts
    # (g = 9.81, guard = "h <= 0", invariant = "h >= 0") must be allowed by the schema
    schema = model_json_schema()
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    assert _schema_errors(data, schema, schema) == []


def test_shorthand_forms_satisfy_the_schema() -> None:
    # BALL uses 'g = 9.81', 'h = 10.0' and 'guard = "h <= 0"', all accepted by the loader
    schema = model_json_schema()
    assert _schema_errors(tomllib.loads(BALL), schema, schema) == []
