"""Hypothesis strategies shared by the test modules (kept in one place, as attrs does).

Four families feed the "any text gives a model or a model error" property and the
round trip:

* :func:`arbitrary_texts` -- any text at all, plus text drawn from TOML punctuation;
* :func:`toml_documents` -- syntactically valid TOML built from random nested data
  (written by the small emitter :func:`toml_document` below), both free-form and
  model-shaped with random damage;
* :func:`mutated_model_texts` -- the bundled ``models/*.toml`` with characters, lines,
  keys, numbers or expression strings changed;
* :func:`valid_model_dicts` / :func:`valid_models` -- small valid automata (1-3
  states, 1-3 modes, 0-3 transitions, linear flows).

Expression text comes from :func:`expression_texts`, a grammar of names, numbers,
operators and calls that covers both the accepted language and the usual escape
attempts. Its ``**`` only ever has a small literal or a name as exponent, so it cannot
build integer power towers (which are reported separately, see test_expressions.py).
"""

from __future__ import annotations

import copy
import keyword
import re
import unicodedata
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from hybridlab.model.expressions import FUNCTIONS, RESERVED_NAMES
from hybridlab.simulation.options import METHODS

ROOT = Path(__file__).resolve().parents[1]
MODEL_FILES = tuple(sorted((ROOT / "models").glob("*.toml")))
MODEL_TEXTS = tuple(path.read_text(encoding="utf-8") for path in MODEL_FILES)

#: Keys a model file may contain, used to make random data look like a model.
MODEL_KEYS = (
    "name", "description", "parameters", "states", "definitions", "modes", "transitions",
    "initial", "scenarios", "value", "unit", "flow", "invariant", "source", "target",
    "guard", "reset", "priority", "schedule", "period", "phase", "mode", "t_end",
    "t_start", "method", "rtol", "atol", "max_step", "flw", "guards",
)

# ----------------------------------------------------------------------------------------
# Text without lone surrogates (they cannot be written to a UTF-8 file).
_CHARS = st.characters(exclude_categories=("Cs",))
plain_texts = st.text(_CHARS, max_size=12)


# ----------------------------------------------------------------------------------------
# (a) arbitrary text
_TOML_ALPHABET = st.sampled_from(list('[]{}=,."\'#\\\n\r\t +-_:0123456789abcdefxyz'))


def arbitrary_texts() -> st.SearchStrategy[str]:
    """Any text, and text made of TOML punctuation and a few letters."""
    return st.one_of(st.text(), st.text(_TOML_ALPHABET, max_size=80))


# ----------------------------------------------------------------------------------------
# Expression-like text: a small grammar of names, operators and calls.
EXPRESSION_NAMES = (
    "x", "y", "h", "v", "g", "e", "t", "pi", "T", "k", "K", "u", "energy", "friction",
    "sin", "exp", "__import__", "__class__", "__builtins__", "os", "eval", "open", "foo",
)
_NUMBERS = ("0", "1", "2", "3", "0.5", "1e3", "1e-3", "1e400", "-1", "2.5", "007", "0x1f",
            "1_000", ".5", "1.", "'s'", '"s"', "True", "None", "1j", "b'x'", "...")
_BINARY = ("+", "-", "*", "/", "^", "%", "//", "@", "&", "|", "<<", ">>", "<", "<=", ">",
           ">=", "==", "!=", "and", "or", "is", "in", "not in")
_CALLABLE = (*FUNCTIONS, "foo", "eval", "exec", "open", "__import__", "getattr", "print")
_TEMPLATES = (
    "lambda: {0}", "[{0} for _ in {1}]", "{{{0}: {1}}}", "({0} := {1})", "f'{{{0}}}'",
    "{0}[{1}]", "{0}.real", "{0}.__class__", "{0} if {1} else 0", "({0}, {1})", "[{0}]",
    "*{0}", "not {0}", "~{0}", "{0}({1})", "yield {0}", "await {0}",
)


def expression_texts(max_leaves: int = 12) -> st.SearchStrategy[str]:
    """Expression-like text over :data:`EXPRESSION_NAMES`, valid or not."""
    atoms = st.one_of(st.sampled_from(EXPRESSION_NAMES), st.sampled_from(_NUMBERS))

    def extend(sub: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
        binary = st.builds("{} {} {}".format, sub, st.sampled_from(_BINARY), sub)
        power = st.builds("({})**{}".format, sub,
                          st.sampled_from(("2", "3", "0.5", "-1", "x", "(-2)", "0")))
        unary = st.builds("-{}".format, sub)
        paren = st.builds("({})".format, sub)
        call = st.builds(lambda f, args: f"{f}({', '.join(args)})",
                         st.sampled_from(_CALLABLE), st.lists(sub, max_size=4))
        template = st.builds(lambda tpl, a, b: tpl.format(a, b),
                             st.sampled_from(_TEMPLATES), sub, sub)
        return st.one_of(binary, power, unary, paren, call, template)

    return st.recursive(atoms, extend, max_leaves=max_leaves)


# ----------------------------------------------------------------------------------------
# (b) a small TOML emitter and random TOML data
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def toml_string(text: str) -> str:
    """A TOML basic string for ``text`` (control characters as ``\\uXXXX``)."""
    out = []
    for ch in text:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(key: str) -> str:
    """A bare key when TOML allows one, else a quoted key."""
    return key if _BARE_KEY.fullmatch(key) else toml_string(key)


def toml_value(value: Any) -> str:
    """An inline TOML value (scalars, arrays, inline tables)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        # repr gives 'inf', '-inf', 'nan', '1e+16', '-0.0': all valid TOML floats
        return repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        inner = ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items())
        return "{ " + inner + " }" if inner else "{}"
    return value.isoformat()  # datetime.date


def _is_table_array(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _emit(table: dict[str, Any], path: tuple[str, ...], lines: list[str]) -> None:
    nested = []
    for key, value in table.items():
        if (isinstance(value, dict) and len(path) < 3) or _is_table_array(value):
            nested.append((key, value))
        else:
            lines.append(f"{toml_key(key)} = {toml_value(value)}")
    for key, value in nested:
        sub = (*path, key)
        header = ".".join(toml_key(k) for k in sub)
        if isinstance(value, dict):
            lines.append(f"[{header}]")
            _emit(value, sub, lines)
        else:
            for item in value:
                lines.append(f"[[{header}]]")
                _emit(item, sub, lines)


def toml_document(table: dict[str, Any]) -> str:
    """Write ``table`` as a TOML document: tables as ``[a.b]``, arrays of tables as
    ``[[a]]``, deeper tables inline. ``tomllib.loads`` of the result gives ``table`` back.
    """
    lines: list[str] = []
    _emit(table, (), lines)
    return "\n".join(lines) + "\n"


toml_keys = st.one_of(st.sampled_from(MODEL_KEYS), plain_texts)
toml_scalars = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(),
    plain_texts,
    expression_texts(max_leaves=4),
    st.dates(),
)
toml_data = st.recursive(
    toml_scalars,
    lambda children: st.one_of(st.lists(children, max_size=4),
                               st.dictionaries(toml_keys, children, max_size=4)),
    max_leaves=16,
)
toml_tables = st.dictionaries(toml_keys, toml_data, max_size=6)


# ----------------------------------------------------------------------------------------
# (d) valid small automata
def _declarable(name: str) -> bool:
    return (name.isidentifier() and not keyword.iskeyword(name) and not name.startswith("_")
            and name not in RESERVED_NAMES
            # the parser NFKC-normalises names; only such names can be referred to
            and unicodedata.normalize("NFKC", name) == name)


identifiers = st.one_of(
    st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,5}", fullmatch=True),
    st.text(st.characters(categories=("Lu", "Ll", "Lo")), min_size=1, max_size=3),
).filter(_declarable)

finite_floats = st.floats(allow_nan=False, allow_infinity=False)
positive_floats = st.floats(min_value=0.0, exclude_min=True, allow_infinity=False)
small_floats = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)


def _literal(value: float) -> str:
    return repr(value) if value >= 0 else f"({value!r})"


@st.composite
def linear_expressions(draw: st.DrawFn, variables: list[str], coefficients: list[str]) -> str:
    """``c0 + c1*x1 + ...`` with parameter names or number literals as coefficients."""
    coefficient = st.one_of(st.sampled_from(coefficients) if coefficients else st.nothing(),
                            small_floats.map(_literal))
    terms = [draw(coefficient)]
    for var in draw(st.lists(st.sampled_from(variables), max_size=3)):
        terms.append(f"{draw(coefficient)}*{var}")
    return " + ".join(terms)


@st.composite
def relation_texts(draw: st.DrawFn, variables: list[str], coefficients: list[str]) -> str:
    """One inequality, a chained one, or an ``and`` of two."""
    side = linear_expressions(variables, coefficients)
    op = st.sampled_from(("<", "<=", ">", ">="))
    kind = draw(st.sampled_from(("simple", "chained", "and")))
    if kind == "simple":
        return f"{draw(st.sampled_from(variables))} {draw(op)} {draw(side)}"
    if kind == "chained":
        lo, hi = sorted(draw(st.lists(small_floats, min_size=2, max_size=2)))
        return f"{_literal(lo)} <= {draw(st.sampled_from(variables))} <= {_literal(hi)}"
    return (f"{draw(st.sampled_from(variables))} {draw(op)} {draw(side)} and "
            f"{draw(st.sampled_from(variables))} {draw(op)} {draw(side)}")


@st.composite
def valid_model_dicts(draw: st.DrawFn) -> dict[str, Any]:
    """A plain mapping (as read from TOML) of a valid small automaton."""
    n_states = draw(st.integers(1, 3))
    n_params = draw(st.integers(0, 3))
    n_defs = draw(st.integers(0, 2))
    names = draw(st.lists(identifiers, min_size=n_states + n_params + n_defs,
                          max_size=n_states + n_params + n_defs, unique=True))
    states, params, defs = (names[:n_states], names[n_states:n_states + n_params],
                            names[n_states + n_params:])
    text = st.text(_CHARS, max_size=10)

    data: dict[str, Any] = {"name": draw(st.text(_CHARS, min_size=1, max_size=10))}
    if draw(st.booleans()):
        data["description"] = draw(text)
    if params:
        data["parameters"] = {
            p: draw(st.one_of(finite_floats,
                              st.fixed_dictionaries({"value": finite_floats},
                                                    optional={"unit": text, "description": text})))
            for p in params
        }
    data["states"] = {
        s: draw(st.one_of(finite_floats,
                          st.fixed_dictionaries({"initial": finite_floats},
                                                optional={"unit": text, "description": text})))
        for s in states
    }
    variables = [*states, "t"]
    if defs:
        data["definitions"] = {}
        for i, d in enumerate(defs):
            data["definitions"][d] = draw(linear_expressions([*variables, *defs[:i]], params))
    usable = [*variables, *defs]

    # "*" is the wildcard of transitions and "" no name: neither may name a mode
    mode_names = draw(st.lists(st.text(_CHARS, max_size=6).filter(lambda m: m not in ("", "*")),
                               min_size=1, max_size=3, unique=True))
    data["modes"] = {}
    for m in mode_names:
        mode: dict[str, Any] = {"flow": {s: draw(linear_expressions(usable, params))
                                         for s in states}}
        if draw(st.booleans()):
            mode["invariant"] = draw(st.lists(relation_texts(usable, params), max_size=2))
        if draw(st.booleans()):
            mode["description"] = draw(text)
        data["modes"][m] = mode

    transitions = []
    for name in draw(st.lists(st.text(_CHARS, min_size=1, max_size=6), max_size=3, unique=True)):
        tr: dict[str, Any] = {"name": name, "source": draw(st.sampled_from(mode_names)),
                              "target": draw(st.sampled_from(mode_names))}
        kind = draw(st.sampled_from(("guard", "schedule", "both")))
        if kind in ("guard", "both"):
            guards = draw(st.lists(relation_texts(usable, params), min_size=1, max_size=2))
            tr["guard"] = guards[0] if len(guards) == 1 and draw(st.booleans()) else guards
        if kind in ("schedule", "both"):
            tr["schedule"] = draw(st.fixed_dictionaries({"period": positive_floats},
                                                        optional={"phase": finite_floats}))
        if draw(st.booleans()):
            tr["reset"] = {s: draw(linear_expressions(usable, params))
                           for s in draw(st.lists(st.sampled_from(states), unique=True))}
        if draw(st.booleans()):
            tr["priority"] = draw(st.integers(-5, 5))
        if draw(st.booleans()):
            tr["description"] = draw(text)
        transitions.append(tr)
    if transitions:
        data["transitions"] = transitions
    data["initial"] = {"mode": draw(st.sampled_from(mode_names))}

    scenarios = {}
    for name in draw(st.lists(st.text(_CHARS, max_size=6), max_size=2, unique=True)):
        t_start, t_end = sorted(draw(st.lists(finite_floats, min_size=2, max_size=2,
                                              unique=True)))
        scenario: dict[str, Any] = {"t_end": t_end}
        if draw(st.booleans()):
            scenario["t_start"] = t_start
        elif t_end <= 0.0:
            scenario["t_end"] = abs(t_end) + 1.0
        if params and draw(st.booleans()):
            scenario["parameters"] = {p: draw(finite_floats)
                                      for p in draw(st.lists(st.sampled_from(params),
                                                             unique=True))}
        if draw(st.booleans()):
            scenario["initial"] = {s: draw(finite_floats)
                                   for s in draw(st.lists(st.sampled_from(states), unique=True))}
        if draw(st.booleans()):
            scenario["mode"] = draw(st.sampled_from(mode_names))
        if draw(st.booleans()):
            scenario["method"] = draw(st.sampled_from(METHODS))
        for key in ("rtol", "atol", "max_step"):
            if draw(st.booleans()):
                scenario[key] = draw(positive_floats)
        scenarios[name] = scenario
    if scenarios:
        data["scenarios"] = scenarios
    return data


def valid_models() -> st.SearchStrategy[Any]:
    """:class:`hybridlab.Model` objects built from :func:`valid_model_dicts`."""
    from hybridlab import model_from_dict

    return valid_model_dicts().map(model_from_dict)


# ----------------------------------------------------------------------------------------
# (b, continued) model-shaped data with random damage
def _slots(node: Any) -> list[tuple[Any, Any]]:
    """Every (container, key-or-index) pair inside ``node``."""
    out: list[tuple[Any, Any]] = []
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in list(items):
        out.append((node, key))
        if isinstance(value, dict | list):
            out.extend(_slots(value))
    return out


@st.composite
def damaged_model_tables(draw: st.DrawFn) -> dict[str, Any]:
    """A valid model mapping with 1-3 keys deleted, replaced or added."""
    data = copy.deepcopy(draw(valid_model_dicts()))
    for _ in range(draw(st.integers(1, 3))):
        container, key = draw(st.sampled_from(_slots(data)))
        action = draw(st.sampled_from(("delete", "replace", "add")))
        if action == "delete":
            del container[key]
        elif action == "replace":
            container[key] = draw(st.one_of(toml_data, expression_texts(max_leaves=4)))
        elif isinstance(container, dict):
            container[draw(toml_keys)] = draw(toml_data)
        else:
            container.append(draw(toml_data))
    return data


def toml_documents() -> st.SearchStrategy[str]:
    """Valid TOML text: free-form random tables and damaged model-shaped tables."""
    return st.one_of(toml_tables, damaged_model_tables()).map(toml_document)


# ----------------------------------------------------------------------------------------
# (c) mutations of the bundled model files
_STRING = re.compile(r'"((?:[^"\\\n]|\\.)*)"')
_KEY = re.compile(r"(?m)(?:^|[{,]\s*)([A-Za-z_][A-Za-z0-9_]*)\s*=")
_NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])")
_NUMBER_TEXTS = ("inf", "-inf", "nan", "+nan", "0", "-0.0", "1e400", "1e-400", "-1", "1_0",
                 "0x10", "99999999999999999999999", "1979-05-27", "true", '"1.0"', "[]", "{}")


def _replace_match(draw: st.DrawFn, text: str, pattern: re.Pattern[str], group: int,
                   replacement: st.SearchStrategy[str]) -> str:
    matches = list(pattern.finditer(text))
    if not matches:
        return text
    match = draw(st.sampled_from(matches))
    start, end = match.span(group)
    return text[:start] + draw(replacement) + text[end:]


@st.composite
def _mutate(draw: st.DrawFn, text: str) -> str:
    op = draw(st.sampled_from(("delete_char", "duplicate_char", "replace_char", "delete_line",
                               "duplicate_line", "swap_lines", "replace_key", "swap_keys",
                               "replace_expression", "replace_number")))
    if op.endswith("_char"):
        if not text:
            return text
        i = draw(st.integers(0, len(text) - 1))
        if op == "delete_char":
            return text[:i] + text[i + 1:]
        if op == "duplicate_char":
            return text[:i] + text[i] + text[i:]
        return text[:i] + draw(st.one_of(_TOML_ALPHABET, _CHARS)) + text[i + 1:]
    if op.endswith("_line") or op == "swap_lines":
        lines = text.split("\n")
        i = draw(st.integers(0, len(lines) - 1))
        if op == "delete_line":
            del lines[i]
        elif op == "duplicate_line":
            lines.insert(i, lines[i])
        else:
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        return "\n".join(lines)
    if op == "replace_key":
        return _replace_match(draw, text, _KEY, 1,
                              st.one_of(st.sampled_from(MODEL_KEYS), identifiers))
    if op == "swap_keys":
        keys = list(_KEY.finditer(text))
        if len(keys) < 2:
            return text
        a, b = sorted(draw(st.lists(st.sampled_from(keys), min_size=2, max_size=2,
                                    unique_by=lambda m: m.start(1))),
                      key=lambda m: m.start(1))
        return (text[:a.start(1)] + b.group(1) + text[a.end(1):b.start(1)] + a.group(1)
                + text[b.end(1):])
    if op == "replace_expression":
        return _replace_match(draw, text, _STRING, 0, expression_texts().map(toml_string))
    return _replace_match(draw, text, _NUMBER, 0, st.sampled_from(_NUMBER_TEXTS))


@st.composite
def mutated_model_texts(draw: st.DrawFn) -> str:
    """A bundled model file with 1-3 random mutations."""
    text = draw(st.sampled_from(MODEL_TEXTS))
    for _ in range(draw(st.integers(1, 3))):
        text = draw(_mutate(text))
    return text


# ----------------------------------------------------------------------------------------
# (e) safety spec text ("[MODE, ...:] RELATION"), valid or not
_SPEC_MODES = ("fall", "rise", "*", "fall, fall", "fall,", "1x", "", "fall: fall")


def spec_texts() -> st.SearchStrategy[str]:
    """Spec-like text: an optional mode list, then relation-like or arbitrary text."""
    relation = st.builds("{} {} {}".format, expression_texts(max_leaves=4),
                         st.sampled_from(("<", "<=", ">", ">=", "==", "and", ":")),
                         expression_texts(max_leaves=4))
    body = st.one_of(relation, expression_texts(max_leaves=6), arbitrary_texts())
    prefixed = st.builds("{}: {}".format, st.sampled_from(_SPEC_MODES), body)
    return st.one_of(body, prefixed)


def any_model_texts() -> st.SearchStrategy[str]:
    """Everything above, mixed."""
    return st.one_of(arbitrary_texts(), toml_documents(), mutated_model_texts())


__all__ = [
    "MODEL_FILES",
    "MODEL_KEYS",
    "MODEL_TEXTS",
    "any_model_texts",
    "arbitrary_texts",
    "damaged_model_tables",
    "expression_texts",
    "finite_floats",
    "identifiers",
    "mutated_model_texts",
    "toml_data",
    "toml_document",
    "toml_documents",
    "toml_tables",
    "valid_model_dicts",
    "spec_texts",
    "valid_models",
]
