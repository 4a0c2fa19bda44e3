"""Reading and writing model files (TOML) with one-line errors."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from hybridlab._files import read_bounded
from hybridlab.errors import ModelError
from hybridlab.model.schema import Model
from hybridlab.model.signals import inline_files

__all__ = ["load_model", "loads_model", "model_from_dict", "dumps_model", "model_json_schema"]


#: Branch names pydantic appends to the location of an error inside a union field
#: (``source: str | list[str]`` reports ``source.str`` and ``source.list[str]``).
_UNION_TAGS = frozenset({"str", "float", "int", "bool", "none", "list", "dict",
                         "constrained-str", "constrained-float", "constrained-int"})
_MISSING = object()


def _is_union_tag(part: str) -> bool:
    return part in _UNION_TAGS or "[" in part or part.startswith(
        ("function-", "json-or-python", "lax-or-strict"))


def _key_path(loc: tuple[Any, ...], data: Any = _MISSING) -> str:
    """The user's key path of a pydantic error location, without pydantic's branch names.

    ``data`` is the validated input: a part that is a key of the input mapping at that
    position is always kept, so a mode or state named ``str`` is reported as written.
    A union tag can only be confused with a user key where the input is no longer
    known (below a value a validator rewrote, e.g. ``g = 9.81`` into
    ``{value = 9.81}``); there a key spelt like a tag (``float``) would be dropped.

    Examples
    --------
    >>> _key_path(("transitions", 0, "source", "list[str]"), {"transitions": [{}]})
    'transitions[0].source'
    >>> _key_path(("modes", "str", "flow"), {"modes": {"str": {}}})
    'modes.str.flow'
    """
    path = ""
    current = data
    for part in loc:
        if isinstance(part, int) and not isinstance(part, bool):
            path += f"[{part}]"
            if isinstance(current, list | tuple) and -len(current) <= part < len(current):
                current = current[part]
            else:
                current = _MISSING
            continue
        part = str(part)
        if isinstance(current, Mapping) and part in current:
            current = current[part]
        elif _is_union_tag(part):
            continue  # pydantic's name of a union branch or validator, not a user key
        else:
            current = _MISSING
        path += f".{part}" if path else part
    return path


def _first_error(exc: ValidationError) -> dict[str, Any]:
    """The error to report: an unknown key first (a misspelt required key is reported
    as the key the user wrote, not as the required key now missing)."""
    errors = exc.errors(include_url=False)
    for error in errors:
        if error.get("type") == "extra_forbidden":
            return dict(error)
    return dict(errors[0])


def _from_validation_error(exc: ValidationError, data: Any = _MISSING) -> ModelError:
    error = _first_error(exc)
    cause = (error.get("ctx") or {}).get("error")
    if isinstance(cause, ModelError):
        return cause
    loc = tuple(error.get("loc", ()))
    key = _key_path(loc, data)
    kind = error.get("type", "")
    if kind == "extra_forbidden":
        return ModelError("unknown key", key=key, token=str(loc[-1]) if loc else "")
    if kind == "missing":
        return ModelError("required key is missing", key=key, token=str(loc[-1]) if loc else "")
    value = error.get("input")
    if isinstance(value, bool):
        token = "true" if value else "false"  # as written in TOML
    else:
        token = value if isinstance(value, str) else repr(value)
    if len(token) > 40:
        token = token[:37] + "..."
    return ModelError(error.get("msg", "invalid value"), key=key, token=token)


def model_from_dict(data: Mapping[str, Any], *, source: str = "<dict>",
                    path: str | Path | None = None) -> Model:
    """Validate a plain mapping (as read from TOML or JSON) into a :class:`Model`.

    A mapping with ``templates``, ``imports`` or ``instances`` describes components; its
    product is the model (:func:`hybridlab.model.library.network_from_dict`, where
    ``path``, the file, locates the imports).

    Raises
    ------
    ModelError
        One line naming ``source``, the key path and the offending token.

    Examples
    --------
    >>> model_from_dict({"name": "x", "states": {"x": 1.0}, "modes": {"m": {"flow": {"x": "-x"}}},
    ...                  "initial": {"mode": "m"}}).name
    'x'
    >>> model_from_dict({"name": "x", "states": {"x": 1.0}, "modes": {"m": {"flow": {"x": "-y"}}},
    ...                  "initial": {"mode": "m"}}, source="x.toml")
    Traceback (most recent call last):
    ...
    hybridlab.errors.ModelError: x.toml: modes.m.flow.x: unknown symbol (token 'y')
    """
    if not isinstance(data, Mapping):
        raise ModelError("a model must be a table of keys", source=source)
    data = dict(data)
    from hybridlab.model.library import is_network, network_from_dict

    if is_network(data):
        try:
            return network_from_dict(data, source=source, path=path)
        except (RecursionError, MemoryError, OverflowError):
            raise ModelError("model is too deeply nested or too large", source=source) from None
    try:
        data = inline_files(data, Path(path).parent if path is not None else Path())
        return Model.model_validate(data)
    except ValidationError as exc:
        raise _from_validation_error(exc, data).with_source(source) from None
    except ModelError as exc:
        raise exc.with_source(source) from None
    except (RecursionError, MemoryError, OverflowError):
        raise ModelError("model is too deeply nested or too large", source=source) from None


def loads_model(text: str, *, source: str = "<string>", path: str | Path | None = None) -> Model:
    """Parse TOML ``text`` into a :class:`Model`.

    Imports of components are relative to the folder of ``path`` (the file the text
    came from), else to the current folder.

    Any text yields a model or a :class:`ModelError`, never another exception.

    Examples
    --------
    >>> decay = loads_model('''
    ... name = "decay"
    ... parameters = { k = 0.5 }
    ... states = { x = 1.0 }
    ... modes.on = { flow = { x = "-k*x" } }
    ... initial = { mode = "on" }
    ... ''')
    >>> decay.name, decay.state_names, decay.parameters["k"].value
    ('decay', ('x',), 0.5)
    >>> loads_model('name = "decay"\\nstates = { x = 1.0 }\\n', source="decay.toml")
    Traceback (most recent call last):
    ...
    hybridlab.errors.ModelError: decay.toml: modes: required key is missing (token 'modes')
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"invalid TOML: {exc}", source=source) from None
    except (RecursionError, MemoryError, TypeError, ValueError) as exc:
        raise ModelError(f"invalid TOML: {type(exc).__name__}", source=source) from None
    return model_from_dict(data, source=source, path=path)


def load_model(path: str | Path) -> Model:
    """Load a model file (TOML).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.toml`` file.

    Returns
    -------
    Model

    Raises
    ------
    ModelError
        If the file cannot be read or is not a valid model.

    Examples
    --------
    >>> ball = load_model("models/bouncing_ball.toml")
    >>> ball.name, ball.state_names, ball.parameter_names, list(ball.scenarios)
    ('bouncing_ball', ('h', 'v'), ('g', 'e'), ['default', 'zeno', 'benchmark'])
    >>> load_model("models/no_such_model.toml")
    Traceback (most recent call last):
    ...
    hybridlab.errors.ModelError: models/no_such_model.toml: cannot read file: No such file or
    directory
    """
    path = Path(path)
    try:
        raw = read_bounded(path)
    except OSError as exc:
        raise ModelError(f"cannot read file: {exc.strerror}", source=str(path)) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ModelError("file is not UTF-8 text", source=str(path)) from None
    return loads_model(text, source=str(path), path=path)


#: TOML basic-string escapes with a short form; other control characters use \\uXXXX.
_SHORT_ESCAPES = {"\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r",
                  '"': '\\"', "\\": "\\\\"}


def _toml_string(value: str) -> str:
    """A TOML basic string: quotes, backslashes and every control character escaped.

    Examples
    --------
    >>> print(_toml_string('a"b\\\\c\\r\\x00\\x7f\\x85é'))
    "a\\"b\\\\c\\r\\u0000\\u007F\\u0085é"
    """
    out = []
    for ch in value:
        code = ord(ch)
        if ch in _SHORT_ESCAPES:
            out.append(_SHORT_ESCAPES[ch])
        elif code < 0x20 or 0x7F <= code <= 0x9F:
            out.append(f"\\u{code:04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value) or math.isinf(value):
            raise ValueError("non-finite number cannot be written")
        return repr(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, Mapping):
        inner = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{ " + inner + " }" if inner else "{}"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_key(key: str) -> str:
    """A bare key when TOML allows one (ASCII letters, digits, '_' and '-'), else quoted."""
    return key if _BARE_KEY.fullmatch(key) else _toml_string(key)


def dumps_model(model: Model) -> str:
    """Write ``model`` as TOML text; ``loads_model(dumps_model(m)) == m``.

    Examples
    --------
    >>> m = model_from_dict({"name": "x", "states": {"x": 1.0},
    ...                      "modes": {"m": {"flow": {"x": "-x"}}}, "initial": {"mode": "m"}})
    >>> loads_model(dumps_model(m)) == m
    True
    """
    data = model.model_dump(mode="json", exclude_defaults=True)
    lines: list[str] = []
    for key in ("name", "description"):
        if key in data:
            lines.append(f"{key} = {_toml_value(data.pop(key))}")
    transitions = data.pop("transitions", [])
    for section, content in data.items():
        lines.append(f"\n[{section}]")
        for k, v in content.items():
            if section in ("modes", "scenarios"):
                lines.append(f"\n[{section}.{_toml_key(k)}]")
                lines.extend(f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in v.items())
            else:
                lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for tr in transitions:
        lines.append("\n[[transitions]]")
        lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in tr.items())
    return "\n".join(lines) + "\n"


def model_json_schema() -> dict[str, Any]:
    """The JSON schema of model files, for editors (TOML language servers read it).

    Examples
    --------
    A model file is a flat automaton (``Model``) or a network of components
    (``Network``: templates, imports, instances):

    >>> schema = model_json_schema()
    >>> schema["title"], schema["$schema"]
    ('hybridlab model', 'https://json-schema.org/draft/2020-12/schema')
    >>> schema["anyOf"]
    [{'$ref': '#/$defs/Model'}, {'$ref': '#/$defs/Network'}]
    >>> schema["$defs"]["Model"]["required"], schema["$defs"]["Network"]["required"]
    (['name', 'states', 'modes', 'initial'], ['name'])
    """
    from pydantic.json_schema import models_json_schema

    from hybridlab.model.network import Network

    _, shared = models_json_schema([(Model, "validation"), (Network, "validation")],
                                   ref_template="#/$defs/{model}")
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "hybridlab model",
        "description": "A hybrid automaton (Model), or one built from components (Network).",
        "anyOf": [{"$ref": "#/$defs/Model"}, {"$ref": "#/$defs/Network"}],
        "$defs": shared["$defs"],
    }
