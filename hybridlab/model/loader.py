"""Reading and writing model files (TOML) with one-line errors."""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from hybridlab.errors import ModelError
from hybridlab.model.schema import Model

__all__ = ["load_model", "loads_model", "model_from_dict", "dumps_model", "model_json_schema"]


def _key_path(loc: tuple[Any, ...]) -> str:
    path = ""
    for part in loc:
        if isinstance(part, int):
            path += f"[{part}]"
        elif str(part).startswith(("function-", "json-or-python", "union[")):
            continue  # pydantic's internal validator names, not user keys
        else:
            path += f".{part}" if path else str(part)
    return path


def _from_validation_error(exc: ValidationError) -> ModelError:
    error = exc.errors(include_url=False)[0]
    cause = (error.get("ctx") or {}).get("error")
    if isinstance(cause, ModelError):
        return cause
    loc = tuple(error.get("loc", ()))
    key = _key_path(loc)
    kind = error.get("type", "")
    if kind == "extra_forbidden":
        return ModelError("unknown key", key=key, token=str(loc[-1]) if loc else "")
    if kind == "missing":
        return ModelError("required key is missing", key=key, token=str(loc[-1]) if loc else "")
    value = error.get("input")
    token = value if isinstance(value, str) else repr(value)
    if len(token) > 40:
        token = token[:37] + "..."
    return ModelError(error.get("msg", "invalid value"), key=key, token=token)


def model_from_dict(data: Mapping[str, Any], *, source: str = "<dict>") -> Model:
    """Validate a plain mapping (as read from TOML or JSON) into a :class:`Model`.

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
    try:
        return Model.model_validate(dict(data))
    except ValidationError as exc:
        raise _from_validation_error(exc).with_source(source) from None
    except ModelError as exc:
        raise exc.with_source(source) from None
    except (RecursionError, MemoryError, OverflowError):
        raise ModelError("model is too deeply nested or too large", source=source) from None


def loads_model(text: str, *, source: str = "<string>") -> Model:
    """Parse TOML ``text`` into a :class:`Model`.

    Any text yields a model or a :class:`ModelError`, never another exception.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"invalid TOML: {exc}", source=source) from None
    except (RecursionError, MemoryError, TypeError, ValueError) as exc:
        raise ModelError(f"invalid TOML: {type(exc).__name__}", source=source) from None
    return model_from_dict(data, source=source)


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
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ModelError(f"cannot read file: {exc.strerror}", source=str(path)) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ModelError("file is not UTF-8 text", source=str(path)) from None
    return loads_model(text, source=str(path))


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
        escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
        return f'"{escaped}"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, Mapping):
        inner = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{ " + inner + " }" if inner else "{}"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _toml_key(key: str) -> str:
    return key if key.replace("_", "a").replace("-", "a").isalnum() else _toml_value(key)


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
    """The JSON schema of model files, for editors (TOML language servers read it)."""
    schema = Model.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "hybridlab model"
    return schema
