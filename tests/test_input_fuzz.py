"""Hypothesis against the readers: any input is read or refused with the reader's own one-line
error, never another exception (the model loader's own fuzzing is in test_model_fuzz.py)."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hybridlab.cli._args import finite_number, split_assignment
from hybridlab.identify.data import read_events_csv, read_frequency_csv, read_friction_csv
from hybridlab.identify.errors import DataError
from hybridlab.io import SpaceExError, loads_spaceex

_CSV_ALPHABET = st.sampled_from(list("velocity,force,frequency_hz,magnitude_db,phase_deg,"
                                     "sensor,t,edge,rising,falling\n\r\t #-+.eE0123456789"
                                     "nanif\ufeff\x00\"'"))
csv_texts = st.one_of(st.text(_CSV_ALPHABET, max_size=300), st.binary(max_size=200).map(
    lambda b: b.decode("latin-1")))
_FUZZ = settings(max_examples=150, deadline=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])


def _one_line(exc: Exception) -> None:
    assert "\n" not in str(exc), str(exc)


@_FUZZ
@given(text=csv_texts, raw=st.booleans())
def test_csv_readers_read_or_refuse_any_file(tmp_path: Path, text: str, raw: bool) -> None:
    path = tmp_path / "data.csv"
    if raw:
        path.write_bytes(text.encode("latin-1", errors="replace"))
    else:
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
    for reader in (read_friction_csv, read_frequency_csv, read_events_csv):
        try:
            reader(path)
        except DataError as exc:
            _one_line(exc)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=40))
def test_cli_numbers_parse_or_refuse_any_text(text: str) -> None:
    try:
        value = finite_number(text, "--set g")
    except ValueError as exc:
        _one_line(exc)
    else:
        assert value == value and abs(value) != float("inf")
    try:
        split_assignment(text, "--set")
    except ValueError as exc:
        _one_line(exc)


_XML_PIECES = st.sampled_from([
    '<?xml version="1.0"?>', '<sspaceex xmlns="http://www-verimag.imag.fr/xml-namespaces/'
    'sspaceex" version="0.2">', "</sspaceex>", '<component id="c">', "</component>",
    '<param name="x" type="real" local="false" d1="1" d2="1" dynamics="any"/>',
    '<location id="1" name="l">', "</location>", "<flow>x' == 1</flow>",
    "<invariant>x &lt;= 1</invariant>", '<transition source="1" target="1">', "</transition>",
    "<guard>x &gt;= 1</guard>", "<assignment>x' == 0</assignment>", '<bind component="c" as="a">',
    "</bind>", '<map key="x">x</map>', "<!DOCTYPE x [<!ENTITY a 'b'>]>", "&a;", "<", ">", "&",
    "\x00", "é", "\n"])


@_FUZZ
@given(st.lists(_XML_PIECES, max_size=30).map("".join), st.text(max_size=60))
def test_the_spaceex_importer_reads_or_refuses_any_document(xml: str, cfg: str) -> None:
    for cfg_text in (None, cfg):
        try:
            loads_spaceex(xml, cfg_text, source="fuzz.xml", cfg_source="fuzz.cfg")
        except SpaceExError as exc:
            _one_line(exc)
