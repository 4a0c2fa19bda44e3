"""The whitelisted expression language: what it accepts, what it refuses, and that
refusing is all it does (no model text ever runs as code)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import sympy as sp
from strategies import toml_string

import hybridlab
from hybridlab import ExpressionError, ModelError
from hybridlab.model.expressions import (
    CONSTANTS,
    FUNCTIONS,
    Inequality,
    check_name,
    parse_expression,
    parse_relation,
)

x, y, z = sp.symbols("x y z", real=True)
SYMBOLS = {"x": x, "y": y, "z": z}


def error_of(text: str, *, relation: bool = False) -> str:
    parse = parse_relation if relation else parse_expression
    with pytest.raises(ExpressionError) as info:
        parse(text, SYMBOLS)
    return str(info.value)


# ----------------------------------------------------------------------------------------
# accepted language


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("x", x),
        ("-x", -x),
        ("+x", x),
        ("x + y", x + y),
        ("x - y", x - y),
        ("x*y", x * y),
        ("x/y", x / y),
        ("x**2", x**2),
        ("x**2**3", x**8),
        ("2*(x + 1)", 2 * x + 2),
        ("0.5*x", sp.Float(0.5) * x),
        ("1e3", sp.Float(1000.0)),
        ("7", sp.Integer(7)),
        ("pi*x", sp.pi * x),
    ],
)
def test_arithmetic_becomes_sympy(text: str, expected: sp.Expr) -> None:
    assert parse_expression(text, SYMBOLS) == expected


def test_whitelist_is_exactly_the_documented_set() -> None:
    assert set(FUNCTIONS) == {
        "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
        "exp", "log", "sqrt", "abs", "sign", "min", "max", "clip",
    }
    assert dict(CONSTANTS) == {"pi": sp.pi}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("sin(x)", sp.sin(x)),
        ("cos(x)", sp.cos(x)),
        ("tan(x)", sp.tan(x)),
        ("asin(x)", sp.asin(x)),
        ("acos(x)", sp.acos(x)),
        ("atan(x)", sp.atan(x)),
        ("atan2(y, x)", sp.atan2(y, x)),
        ("sinh(x)", sp.sinh(x)),
        ("cosh(x)", sp.cosh(x)),
        ("tanh(x)", sp.tanh(x)),
        ("exp(x)", sp.exp(x)),
        ("log(x)", sp.log(x)),
        ("sqrt(x)", sp.sqrt(x)),
        ("abs(x)", sp.Abs(x)),
        ("sign(x)", sp.sign(x)),
        ("min(x, y)", sp.Min(x, y)),
        ("min(x, y, z)", sp.Min(x, y, z)),
        ("max(x, y)", sp.Max(x, y)),
        ("max(x, y, z)", sp.Max(x, y, z)),
        ("clip(x, y, z)", sp.Min(sp.Max(x, y), z)),
        ("pi", sp.pi),
        ("sin(pi*x) + exp(-abs(y))", sp.sin(sp.pi * x) + sp.exp(-sp.Abs(y))),
    ],
)
def test_every_whitelisted_function_parses(text: str, expected: sp.Expr) -> None:
    assert parse_expression(text, SYMBOLS) == expected


def test_definitions_may_map_to_whole_expressions() -> None:
    assert parse_expression("2*E", {"E": x**2}) == 2 * x**2


# ----------------------------------------------------------------------------------------
# relations


def test_chained_comparison_becomes_two_inequalities() -> None:
    assert parse_relation("0 <= x <= 1", SYMBOLS) == [
        Inequality(x, False, "0 <= x"),
        Inequality(1 - x, False, "x <= 1"),
    ]


def test_and_conjunction_gives_one_inequality_per_operand() -> None:
    assert parse_relation("x >= 0 and y < 0 and z > x", SYMBOLS) == [
        Inequality(x, False, "x >= 0"),
        Inequality(-y, True, "y < 0"),
        Inequality(z - x, True, "z > x"),
    ]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("x < y", Inequality(y - x, True, "x < y")),
        ("x <= y", Inequality(y - x, False, "x <= y")),
        ("x > y", Inequality(x - y, True, "x > y")),
        ("x >= y", Inequality(x - y, False, "x >= y")),
        ("x >= 2*(y + 1)", Inequality(x - 2 * y - 2, False, "x >= 2*(y + 1)")),
    ],
)
def test_inequalities_are_normalised_to_nonnegative_expressions(
    text: str, expected: Inequality
) -> None:
    assert parse_relation(text, SYMBOLS) == [expected]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("x == 0", "only inequalities (<, <=, >, >=) are allowed (token '==')"),
        ("x != 0", "only inequalities (<, <=, >, >=) are allowed (token '!=')"),
        ("x is y", "only inequalities (<, <=, >, >=) are allowed (token 'is')"),
        ("x in y", "only inequalities (<, <=, >, >=) are allowed (token 'in')"),
        ("0 <= x == 1", "only inequalities (<, <=, >, >=) are allowed (token '==')"),
        ("x", "an inequality such as 'x >= 0' is expected (token 'x')"),
        ("x - 1", "an inequality such as 'x >= 0' is expected (token 'x - 1')"),
        ("x >= 0 or y < 0",
         "'or' is not supported; use one transition per alternative (token 'or')"),
        ("x >= 0 and (y < 0 or z < 0)",
         "'or' is not supported; use one transition per alternative (token 'or')"),
        ("x >= 0 & y < 0",
         "'&' is not supported; combine inequalities with 'and' (token '&')"),
    ],
)
def test_relations_that_are_not_conjunctions_of_inequalities(text: str, message: str) -> None:
    assert error_of(text, relation=True) == message


def test_comparison_inside_an_expression_is_refused() -> None:
    assert error_of("x < 1") == (
        "a comparison is not allowed here; an expression is expected (token 'x < 1')"
    )


# ----------------------------------------------------------------------------------------
# refused language


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("x^2", "'^' is not a power; use '**' (token '^')"),
        ("x % 2", "'%' is not supported (token '%')"),
        ("x // 2", "'//' is not supported (token '//')"),
        ("x @ y", "'@' is not supported (token '@')"),
        ("x | y", "'|' is not supported (token '|')"),
        ("x << 1", "'<<' is not supported (token '<<')"),
        ("x >> 1", "'>>' is not supported (token '>>')"),
        ("~x", "operator not allowed (token '~')"),
    ],
)
def test_operators_outside_the_language(text: str, message: str) -> None:
    assert error_of(text) == message


def test_not_is_named_by_its_whole_token() -> None:
    # the token of a rejected unary operator is cut to one character: 'not x' names 'n'
    assert error_of("not x") == "operator not allowed (token 'not')"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("sin()", "sin() takes 1 argument(s), got 0 (token 'sin')"),
        ("sin(x, y)", "sin() takes 1 argument(s), got 2 (token 'sin')"),
        ("sqrt(x, y)", "sqrt() takes 1 argument(s), got 2 (token 'sqrt')"),
        ("atan2(x)", "atan2() takes 2 argument(s), got 1 (token 'atan2')"),
        ("atan2(x, y, z)", "atan2() takes 2 argument(s), got 3 (token 'atan2')"),
        ("clip(x, y)", "clip() takes 3 argument(s), got 2 (token 'clip')"),
        ("min(x)", "min() takes at least 2 argument(s), got 1 (token 'min')"),
        ("max()", "max() takes at least 2 argument(s), got 0 (token 'max')"),
        ("sin(x=1)", "keyword arguments are not allowed (token 'sin')"),
        ("max(*x)", "starred arguments are not allowed (token 'max')"),
        ("sin", "function used without arguments (token 'sin')"),
    ],
)
def test_function_arity_and_call_form(text: str, message: str) -> None:
    assert error_of(text) == message


@pytest.mark.parametrize("name", ["foo", "eval", "exec", "open", "getattr", "print", "x"])
def test_unknown_functions(name: str) -> None:
    assert error_of(f"{name}(1)") == f"unknown function (token {name!r})"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("__import__('os').system('touch /tmp/x')",
         "only the built-in functions can be called (token \"__import__('os').system\")"),
        ("__import__('os')", "unknown function (token '__import__')"),
        ("x.real", "attribute access is not allowed (token 'real')"),
        ("().__class__", "attribute access is not allowed (token '__class__')"),
        ("__class__", "unknown symbol (token '__class__')"),
        ("__builtins__", "unknown symbol (token '__builtins__')"),
        ("__builtins__['open']", "indexing is not allowed (token \"__builtins__['open']\")"),
        ("x[0]", "indexing is not allowed (token 'x[0]')"),
        ("lambda: 1", "Lambda is not allowed in an expression (token 'lambda: 1')"),
        ("(lambda: 1)()", "only the built-in functions can be called (token 'lambda: 1')"),
        ("'text'", "only numbers are allowed as literals (token \"'text'\")"),
        ("b'x'", "only numbers are allowed as literals (token \"b'x'\")"),
        ("f'{x}'", "JoinedStr is not allowed in an expression (token \"f'{x}'\")"),
        ("[i for i in x]", "ListComp is not allowed in an expression (token '[i for i in x]')"),
        ("{i for i in x}", "SetComp is not allowed in an expression (token '{i for i in x}')"),
        ("(i for i in x)",
         "GeneratorExp is not allowed in an expression (token '(i for i in x)')"),
        ("(y := 1)", "NamedExpr is not allowed in an expression (token 'y := 1')"),
        ("x if y else z", "conditional expressions are not allowed; use min/max/sign or modes "
                          "(token 'x if y else z')"),
        ("eval('1')", "unknown function (token 'eval')"),
        ("open('f')", "unknown function (token 'open')"),
        ("sin(x)(y)", "only the built-in functions can be called (token 'sin(x)')"),
        ("True", "only numbers are allowed as literals (token 'True')"),
        ("None", "only numbers are allowed as literals (token 'None')"),
        ("1j", "only numbers are allowed as literals (token '1j')"),
        ("(x, y)", "Tuple is not allowed in an expression (token '(x, y)')"),
        ("x; y", "syntax error: invalid syntax (token '; y')"),
        ("import os", "syntax error: invalid syntax (token 'import os')"),
        ("w", "unknown symbol (token 'w')"),
        ("1e400", "number is not finite (token '1e400')"),
        ("x/0", "division by zero (token 'x/0')"),
        ("", "empty expression"),
        ("x" * 10_001, "expression longer than 10000 characters (token 'xxxxxxxxxxxxxxxxxxxx...')"),
        ("-" * 300 + "x", "expression nested too deeply (token '" + "-" * 40 + "')"),
    ],
)
def test_code_and_other_non_expressions_are_refused(text: str, message: str) -> None:
    assert error_of(text) == message


@pytest.mark.parametrize("text", ["0**-1", "log(0)", "x + 1/(2 - 2)**3"])
def test_literal_subexpressions_that_are_not_finite_are_refused(text: str) -> None:
    # 'x/0' and '1e400' are refused; the same values reached through '**' or log must be
    # too, else a flow silently becomes complex infinity (sympy zoo)
    with pytest.raises(ExpressionError):
        parse_expression(text, SYMBOLS)


def test_expression_errors_are_value_errors() -> None:
    with pytest.raises(ValueError, match="unknown symbol"):
        parse_expression("w", SYMBOLS)


# ----------------------------------------------------------------------------------------
# declared names


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("sin", "name shadows a built-in function or constant (token 'sin')"),
        ("sqrt", "name shadows a built-in function or constant (token 'sqrt')"),
        ("pi", "name shadows a built-in function or constant (token 'pi')"),
        ("t", "name shadows the time symbol (token 't')"),
        ("_x", "names may not start with '_' (token '_x')"),
        ("1x", "not a valid name (letters, digits and '_', not a keyword) (token '1x')"),
        ("if", "not a valid name (letters, digits and '_', not a keyword) (token 'if')"),
        ("a-b", "not a valid name (letters, digits and '_', not a keyword) (token 'a-b')"),
    ],
)
def test_names_that_cannot_be_declared(name: str, message: str) -> None:
    with pytest.raises(ExpressionError) as info:
        check_name(name)
    assert str(info.value) == message


@pytest.mark.parametrize("name", ["x", "T_out", "m_C", "x1", "theta"])
def test_names_that_can_be_declared(name: str) -> None:
    assert check_name(name) is None


# ----------------------------------------------------------------------------------------
# model files with hostile expressions: refused, and nothing runs

ATTACKS = [
    "__import__('os').system('touch {marker}')",
    "__import__('pathlib').Path('{marker}').touch()",
    "open('{marker}', 'w')",
    "eval(\"open('{marker}', 'w')\")",
    "exec(\"open('{marker}', 'w')\")",
    "(lambda: __import__('os').system('touch {marker}'))()",
    "[__import__('os').system('touch {marker}') for _ in [1]]",
    "f\"{{__import__('os').system('touch {marker}')}}\"",
    "(q := __import__('os').system('touch {marker}'))",
    "().__class__.__bases__[0].__subclasses__()",
    "__builtins__['open']('{marker}', 'w')",
    "getattr(__import__('os'), 'system')('touch {marker}')",
    "x.__class__.__init__.__globals__['os'].system('touch {marker}')",
    "sin(__import__('os').system('touch {marker}'))",
    "x if __import__('os').system('touch {marker}') else x",
    "x + 0*open('{marker}', 'w').close()",
]


def hostile_model(where: str, expression: str) -> str:
    slots = {"flow": '"-g"', "guard": '"h <= 0"', "reset": '"-e*v"', "invariant": '"h >= 0"',
             "definition": '"0.5*v**2 + g*h"'}
    slots[where] = toml_string(expression)
    return textwrap.dedent(f"""\
        name = "ball"

        [parameters]
        g = 9.81
        e = 0.8

        [states]
        h = 10.0
        v = 0.0

        [definitions]
        energy = {slots["definition"]}

        [modes.fall]
        flow = {{ h = "v", v = {slots["flow"]} }}
        invariant = [{slots["invariant"]}]

        [[transitions]]
        name = "bounce"
        source = "fall"
        target = "fall"
        guard = {slots["guard"]}
        reset = {{ v = {slots["reset"]} }}

        [initial]
        mode = "fall"
        """)


def test_hostile_model_template_is_valid_when_harmless(tmp_path: Path) -> None:
    path = tmp_path / "ball.toml"
    path.write_text(hostile_model("flow", "-g"))
    assert hybridlab.load_model(path).symbolic.modes["fall"].flow[1] == -sp.Symbol("g", real=True)


@pytest.mark.parametrize("where", ["flow", "guard", "reset", "invariant", "definition"])
@pytest.mark.parametrize("attack", ATTACKS)
def test_hostile_expressions_are_refused_without_side_effects(
    tmp_path: Path, attack: str, where: str
) -> None:
    marker = tmp_path / "pwned"
    expression = attack.format(marker=marker)
    if where in ("guard", "invariant"):
        expression += " >= 0"
    path = tmp_path / "ball.toml"
    path.write_text(hostile_model(where, expression))
    with pytest.raises(ModelError) as info:
        hybridlab.load_model(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert "\n" not in message
    assert not marker.exists()


def test_hostile_expression_error_names_key_and_token(tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    path = tmp_path / "ball.toml"
    path.write_text(hostile_model("reset", f"__import__('os').system('touch {marker}')"))
    with pytest.raises(ModelError) as info:
        hybridlab.load_model(path)
    assert str(info.value) == (
        f"{path}: transitions[0].reset.v: only the built-in functions can be called "
        "(token \"__import__('os').system\")"
    )
    assert not marker.exists()


def test_integer_power_tower_is_refused_quickly() -> None:
    # '9**9**9' is 11 characters but an integer of 369 million digits; the parser folds
    # literal arithmetic eagerly, so loading must refuse it rather than compute it
    script = textwrap.dedent("""\
        import hybridlab
        text = '''name = "x"
        [states]
        x = 1.0
        [modes.m]
        flow = { x = "9**9**9" }
        [initial]
        mode = "m"
        '''
        try:
            hybridlab.loads_model(text)
        except hybridlab.ModelError:
            print("ModelError")
        else:
            print("loaded")
        """)
    try:
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                              timeout=8)
    except subprocess.TimeoutExpired:
        pytest.fail("loading a model with the flow '9**9**9' did not finish within 8 s")
    assert done.stdout == "ModelError\n"


def test_a_stray_backslash_is_a_one_line_error_and_no_python_warning(recwarn):
    """A backslash other than a line continuation is refused before Python parses the text,
    which would otherwise print a warning about its escape sequences to standard error."""
    for text in ['x + "\\#"', "x \\ 2"]:
        with pytest.raises(ExpressionError, match="unexpected character"):
            parse_expression(text, SYMBOLS)
    assert not [w for w in recwarn if issubclass(w.category, (SyntaxWarning, DeprecationWarning))]
    assert parse_expression("x + \\\n 1", SYMBOLS) == x + 1
