"""The user-file readers (hriplan.files, hriplan.tasks.load): every problem a file can have is one
HriplanError naming the file and, where there is one, the line or the field; outputs are written whole."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from pydantic import BaseModel, ConfigDict, field_validator

from hriplan import HriplanError
from hriplan.files import atomic_path, error_location, load_model, read_data, read_text, temporaries, write_atomically
from hriplan.tasks.load import load_task

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _error(call, *args) -> str:
    with pytest.raises(HriplanError) as info:
        call(*args)
    message = str(info.value)
    assert "\n" not in message
    return message


def test_a_text_file_is_read_as_utf8(tmp_path: Path):
    (tmp_path / "t.yaml").write_bytes("name: caf\u00e9\n".encode())
    assert read_text(tmp_path / "t.yaml") == "name: caf\u00e9\n"


def test_a_missing_file_a_directory_and_binary_content_are_named(tmp_path: Path):
    assert _error(read_text, tmp_path / "no.yaml") == f"{tmp_path / 'no.yaml'}: no such file"
    assert _error(read_text, tmp_path, "task file") == f"{tmp_path}: is a directory, not a task file"
    assert _error(read_text, tmp_path) == f"{tmp_path}: is a directory, not a file"
    (tmp_path / "b.yaml").write_bytes(b"a: 1\x00")
    assert _error(read_text, tmp_path / "b.yaml", "task file") == (
        f"{tmp_path / 'b.yaml'}: not a text file (binary content), expected a task file"
    )


def test_an_unreadable_file_says_why(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    def refuse(self):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "read_bytes", refuse)
    assert _error(read_text, tmp_path / "t.yaml") == f"{tmp_path / 't.yaml'}: cannot read it (Permission denied)"


def test_text_that_is_not_utf8_names_the_line_and_the_byte(tmp_path: Path):
    (tmp_path / "t.yaml").write_bytes(b"a: 1\nb: 2\nc: \xff\n")
    assert _error(read_text, tmp_path / "t.yaml") == f"{tmp_path / 't.yaml'}: line 3: not valid UTF-8 text (byte 0xff)"


def test_json_and_yaml_are_told_apart_by_the_suffix(tmp_path: Path):
    (tmp_path / "t.json").write_text('{"a": [1, 2]}')
    (tmp_path / "t.yml").write_text("a: [1, 2]\nb: yes\n")
    assert read_data(tmp_path / "t.json") == {"a": [1, 2]}
    assert read_data(tmp_path / "t.yml") == {"a": [1, 2], "b": True}
    (tmp_path / "y.json").write_text("a: 1\n")  # YAML in a .json file is not JSON
    assert _error(read_data, tmp_path / "y.json").startswith(f"{tmp_path / 'y.json'}: line 1: not valid JSON (")
    (tmp_path / "d.json").mkdir()
    assert _error(read_data, tmp_path / "d.json").endswith("d.json: is a directory, not a JSON file")
    assert _error(read_data, tmp_path).endswith(": is a directory, not a YAML file")


def test_an_empty_file_and_a_top_level_that_is_not_a_mapping_are_refused(tmp_path: Path):
    (tmp_path / "e.yaml").write_text("  \n\n")
    assert _error(read_data, tmp_path / "e.yaml") == f"{tmp_path / 'e.yaml'}: the file is empty"
    (tmp_path / "l.yaml").write_text("- 1\n- 2\n")
    assert _error(read_data, tmp_path / "l.yaml") == (
        f"{tmp_path / 'l.yaml'}: expected a mapping of fields at the top level, got list"
    )


def test_bad_syntax_names_the_line(tmp_path: Path):
    (tmp_path / "t.json").write_text('{\n"a": 1,\n}')
    assert _error(read_data, tmp_path / "t.json").startswith(f"{tmp_path / 't.json'}: line 3: not valid JSON (")
    (tmp_path / "t.yaml").write_text("a: 1\nb: [2\nc: 3\n")
    message = _error(read_data, tmp_path / "t.yaml")
    assert message.startswith(f"{tmp_path / 't.yaml'}: line 3: not valid YAML (") and "Mark" not in message


def test_a_character_yaml_refuses_is_one_line(tmp_path: Path):
    (tmp_path / "t.yaml").write_bytes(b"a: 1\nb: \x01\n")
    assert _error(read_data, tmp_path / "t.yaml") == (
        f"{tmp_path / 't.yaml'}: line 2: not valid YAML (character U+0001 is not allowed)"
    )


def test_a_collection_as_a_key_is_one_line(tmp_path: Path):
    (tmp_path / "t.yaml").write_text("a: 1\n? [1, 2]\n: 3\n")
    assert (
        _error(read_data, tmp_path / "t.yaml")
        == f"{tmp_path / 't.yaml'}: line 2: a key must be a single value, not a list"
    )
    (tmp_path / "u.yaml").write_text("? {x: 1}\n: 3\n")
    assert _error(read_data, tmp_path / "u.yaml").endswith("line 1: a key must be a single value, not a dict")


@pytest.mark.parametrize(("key", "read"), [("on", "True"), ("no", "False"), ("1", "1"), ("null", "None")])
def test_a_key_yaml_reads_as_no_name_is_one_line_saying_to_quote_it(tmp_path: Path, key: str, read: str):
    """YAML 1.1 reads `on`, `no` and numbers as values: `on: table` became the key True, which the
    models refused as "objects.0.1: Keys should be strings"."""
    (tmp_path / "t.yaml").write_text(f"objects:\n  - name: cup\n    {key}: table\n")
    assert _error(read_data, tmp_path / "t.yaml") == (
        f"{tmp_path / 't.yaml'}: line 3: key '{key}' is read as {read}, not a name: quote it ('{key}')"
    )
    (tmp_path / "u.yaml").write_text(f"objects:\n  - name: cup\n    '{key}': table\n")
    assert read_data(tmp_path / "u.yaml") == {"objects": [{"name": "cup", key: "table"}]}


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_json_constants_that_json_does_not_allow_are_refused(tmp_path: Path, constant: str):
    (tmp_path / "t.json").write_text(f'{{"a": {constant}}}')
    assert _error(read_data, tmp_path / "t.json") == (
        f"{tmp_path / 't.json'}: not valid JSON ({constant} is not a number JSON allows)"
    )


def test_a_key_given_twice_names_both_lines_at_any_depth(tmp_path: Path):
    (tmp_path / "t.yaml").write_text("a: 1\nb:\n  c: 1\n  d: 2\n  c: 3\n")
    assert _error(read_data, tmp_path / "t.yaml") == (
        f"{tmp_path / 't.yaml'}: line 5: key 'c' is given twice (first at line 3)"
    )
    (tmp_path / "u.yaml").write_text("a: 1\nb: 2\na: 3\n")
    assert _error(read_data, tmp_path / "u.yaml").endswith("line 3: key 'a' is given twice (first at line 1)")
    (tmp_path / "v.yaml").write_text("a: {x: 1}\nb: {x: 2}\n")  # the same key in two mappings is fine
    assert read_data(tmp_path / "v.yaml") == {"a": {"x": 1}, "b": {"x": 2}}


def test_an_output_is_written_whole_through_a_temporary_file(tmp_path: Path):
    target = tmp_path / "deep" / "er" / "out.json"
    with atomic_path(target) as tmp:
        assert tmp.parent == target.parent and tmp.name.startswith(".out.json.") and tmp.suffix == ".tmp"
        assert temporaries(target) == [tmp] and not target.exists()  # nothing at the target until the end
    assert temporaries(target) == [] and target.read_bytes() == b""
    assert write_atomically(target, "caf\u00e9") == target
    assert target.read_bytes() == "caf\u00e9".encode()
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.json"]
    write_atomically(target, "second")
    assert target.read_text() == "second"


class _Goal(BaseModel):
    model_config = ConfigDict(extra="forbid")
    speed: float

    @field_validator("speed")
    @classmethod
    def _not_too_fast(cls, speed: float) -> float:
        if speed > 10.0:
            raise ValueError("faster than 10 m/s")
        return speed


class _File(BaseModel):
    model_config = ConfigDict(extra="forbid")
    goals: list[_Goal]


def test_a_model_error_is_file_field_problem(tmp_path: Path):
    (tmp_path / "t.yaml").write_text("goals:\n  - speed: 1\n  - speed: fast\n")
    assert _error(load_model, tmp_path / "t.yaml", _File) == (
        f"{tmp_path / 't.yaml'}: goals.1.speed: Input should be a valid number, unable to parse string as a number"
    )
    (tmp_path / "v.yaml").write_text("goals:\n  - speed: 11\n")
    assert _error(load_model, tmp_path / "v.yaml", _File) == f"{tmp_path / 'v.yaml'}: goals.0.speed: faster than 10 m/s"
    (tmp_path / "ok.json").write_text(json.dumps({"goals": [{"speed": 2}]}))
    assert load_model(tmp_path / "ok.json", _File) == _File(goals=[_Goal(speed=2.0)])


def test_the_error_location_drops_a_goals_union_tag():
    assert error_location(("steps", 0, "goal", "joints", "joints")) == "steps.0.goal.joints"
    assert error_location(("goals", 1, "pose", "pose", "x")) == "goals.1.pose.x"
    assert error_location(("steps", 0, "goal", "joints")) == "steps.0.goal.joints"  # nothing repeats
    assert error_location(("a", "a", "b")) == "a.a.b"  # a repeat not after a goal is kept
    assert error_location(("goal", "x", "x")) == "goal.x"
    assert error_location(("goal", "x")) == "goal.x"  # the last part is never a tag
    assert error_location(("goals", 0, "x", "x")) == "goals.0.x"
    assert error_location(("goals", "x", "x")) == "goals.x.x"  # a tag comes two after goals
    assert error_location(("x", "y", "y", "goals")) == "x.y.y.goals"  # two before the first part is no part
    assert error_location(("a", "a", "goal")) == "a.a.goal"  # the first part is never a tag
    assert error_location(()) == ""


def test_a_task_file_loads_and_its_errors_are_one_line(tmp_path: Path):
    task = load_task(EXAMPLES / "handover_full_can.yaml")
    assert task.steps and task.robot == "madar"
    (tmp_path / "t.yaml").write_text("name: t\nsteps: []\n")
    assert _error(load_task, tmp_path / "t.yaml").startswith(f"{tmp_path / 't.yaml'}: steps: ")


def test_json_keys_given_twice_and_yaml_values_json_cannot_hold_are_refused(tmp_path: Path):
    (tmp_path / "t.json").write_text('{"a": {"b": 1, "b": 2}}')
    assert _error(read_data, tmp_path / "t.json") == f"{tmp_path / 't.json'}: key 'b' is given twice"
    (tmp_path / "t.yaml").write_text("a:\n  - {when: 2026-12-02}\n")
    assert _error(read_data, tmp_path / "t.yaml") == (
        f"{tmp_path / 't.yaml'}: a.0.when: a date value, which JSON has no type for"
    )
    (tmp_path / "n.yaml").write_text("a: " + "[" * 5000 + "]" * 5000 + "\n")
    assert _error(read_data, tmp_path / "n.yaml") == f"{tmp_path / 'n.yaml'}: nested too deeply"
