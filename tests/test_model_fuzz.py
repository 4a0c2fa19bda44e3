"""Property: any TOML text given to the loader yields a model or a model error, never
another exception; and valid models survive the round trip through TOML."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st
from strategies import (
    MODEL_FILES,
    MODEL_TEXTS,
    arbitrary_texts,
    damaged_model_tables,
    mutated_model_texts,
    toml_document,
    toml_tables,
    valid_model_dicts,
    valid_models,
)

import hybridlab

FUZZ = settings(max_examples=250, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
# The "model or model error" properties skip shrinking: shrinking a failing nested document
# can take minutes, which would break the time budget of this file. A failure still reports
# (and stores) the example that broke the property; test_model_loading.py pins each bug
# found this way with a small explicit case.
SMOKE = settings(FUZZ, phases=[Phase.explicit, Phase.reuse, Phase.generate])


def load_or_model_error(text: str, path: Path | None = None) -> hybridlab.Model | None:
    """Load ``text``; a ModelError is fine (and must be one line naming the source).
    ``path`` is the file the text is from (its imports are relative to it)."""
    try:
        model = hybridlab.loads_model(text, source="fuzz.toml", path=path)
    except hybridlab.ModelError as error:
        message = str(error)
        assert message.startswith("fuzz.toml: "), message
        assert "\n" not in message and "\r" not in message, message
        return None
    assert isinstance(model, hybridlab.Model)
    return model


def _same(a: Any, b: Any) -> bool:
    """Equality that treats nan as equal to nan."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b


# ----------------------------------------------------------------------------------------
# the strategies themselves


@settings(FUZZ, max_examples=100)
@given(toml_tables)
def test_emitter_writes_toml_that_reads_back(table: dict[str, Any]) -> None:
    assert _same(tomllib.loads(toml_document(table)), table)


@settings(FUZZ, max_examples=30)
@given(valid_model_dicts())
def test_valid_model_strategy_gives_valid_models(data: dict[str, Any]) -> None:
    assert isinstance(hybridlab.model_from_dict(data), hybridlab.Model)


def test_bundled_texts_are_valid_models() -> None:
    assert MODEL_TEXTS
    for path, text in zip(MODEL_FILES, MODEL_TEXTS, strict=True):
        assert load_or_model_error(text, path) is not None


# ----------------------------------------------------------------------------------------
# any text: a model or a model error


@SMOKE
@given(arbitrary_texts())
@example("")
@example("\x00")
@example("[[" * 5000)
@example("a = " + "[" * 5000 + "]" * 5000)
@example("a = " + "{ b = " * 2000 + "1" + " }" * 2000)
@example('name = "x"\n[states]\nx = 1e999\n')
@example("\ud800")
def test_arbitrary_text(text: str) -> None:
    load_or_model_error(text)


@settings(SMOKE, max_examples=200)
@given(toml_tables.map(toml_document))
def test_random_toml_documents(text: str) -> None:
    load_or_model_error(text)


@settings(SMOKE, max_examples=100)
@given(damaged_model_tables().map(toml_document))
def test_damaged_model_shaped_documents(text: str) -> None:
    load_or_model_error(text)


@settings(SMOKE, max_examples=400)
@given(mutated_model_texts())
def test_mutated_bundled_models(text: str) -> None:
    load_or_model_error(text)


@SMOKE
@given(st.binary(max_size=200))
def test_arbitrary_bytes_through_load_model(tmp_path_factory: Any, raw: bytes) -> None:
    path = tmp_path_factory.getbasetemp() / "fuzz-bytes.toml"
    path.write_bytes(raw)
    try:
        model = hybridlab.load_model(path)
    except hybridlab.ModelError as error:
        assert str(error).startswith(f"{path}: ")
        assert "\n" not in str(error)
    else:
        assert isinstance(model, hybridlab.Model)


# ----------------------------------------------------------------------------------------
# round trip of generated valid models


@settings(FUZZ, max_examples=100, report_multiple_bugs=False)
@given(valid_models())
def test_generated_models_round_trip(model: hybridlab.Model) -> None:
    text = hybridlab.dumps_model(model)
    assert hybridlab.loads_model(text) == model
    assert hybridlab.dumps_model(hybridlab.loads_model(text)) == text
