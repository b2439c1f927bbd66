"""The ontology's schema kept on disk (ontology/schema.py): a warm process reads it from there
instead of parsing the ontology with rdflib, and gets exactly the schema the triples give."""

from __future__ import annotations

import dataclasses

import pytest

from hriplan.ontology import schema as schema_module
from hriplan.ontology.schema import load_schema, schema_path
from hriplan.ontology.schema_reader import read_schema
from hriplan.ontology.vocabulary import ontology_source


@pytest.fixture
def own_cache(tmp_path, monkeypatch):
    """A cache directory of the test's own, and no schema remembered in memory."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    schema_module._schema.cache_clear()
    yield tmp_path
    schema_module._schema.cache_clear()


def _strict(value: object) -> object:
    """A value with every container's and scalar's type spelled out (1 != 1.0 != True, set != list)."""
    if isinstance(value, set | frozenset):
        return type(value).__name__, sorted((_strict(v) for v in value), key=repr)
    if isinstance(value, dict):
        return "dict", sorted((k, _strict(v)) for k, v in value.items())
    if isinstance(value, list | tuple):
        return type(value).__name__, [_strict(v) for v in value]
    if hasattr(value, "model_dump"):
        return _strict(value.model_dump())
    if isinstance(value, type):
        return "type", value.__name__
    return type(value).__name__, value


def test_the_schema_from_disk_is_the_schema_of_the_triples(own_cache):
    source = ontology_source()
    path = schema_path(source)
    assert not path.exists()
    first = load_schema(source)  # read from the triples and written
    assert path.parent == own_cache / "hriplan" and path.exists()
    schema_module._schema.cache_clear()
    again = load_schema(source)  # read from the file
    assert again is not first
    expected = read_schema(source.graph)
    for field in dataclasses.fields(expected):
        assert _strict(getattr(again, field.name)) == _strict(getattr(expected, field.name)), field.name
    # What the file must carry for the in-process reasoner: a closed enumeration and Python types.
    assert any(isinstance(r, frozenset) for r in again.data_ranges.values())
    assert again.data_ranges["isFragile"] == (bool,)
    assert again.individuals.types and again.ancestors["Glass"] >= {"Glass", "Container"}


@pytest.mark.parametrize("content", [b"", b"{not json", b'{"format": 1, "digest": "other"}'])
def test_a_damaged_or_foreign_schema_file_is_read_again_and_replaced(own_cache, content):
    source = ontology_source()
    path = schema_path(source)
    path.parent.mkdir(parents=True)
    path.write_bytes(content)
    schema = load_schema(source)
    assert schema.classes == read_schema(source.graph).classes
    assert b'"digest":"' + source.digest.encode() in path.read_bytes()


def test_a_schema_file_of_another_ontology_version_is_not_used(own_cache):
    source = ontology_source()
    load_schema(source)
    path = schema_path(source)
    record = schema_module.SchemaFile.model_validate_json(path.read_bytes())
    path.write_text(record.model_copy(update={"digest": "0" * 64, "classes": {"Nothing"}}).model_dump_json())
    schema_module._schema.cache_clear()
    assert "Nothing" not in load_schema(source).classes
