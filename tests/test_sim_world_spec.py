"""The ``world:`` section is declared once (plugins/sim/world_spec.py): the schema editors
read, the load-time checks and the key tables of docs/profiles.md all come from it."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import jsonschema
import pytest
import yaml

from armtree.errors import ConfigError
from armtree.loader.profile import load_profile
from armtree.plugins.sim.world_spec import WORLD

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted(
    path.name
    for path in resources.files("armtree.hardware").iterdir()
    if path.name.endswith(".yaml") and "world" in yaml.safe_load(path.read_text())
)


def world_schema() -> dict:
    """The ``world:`` schema as ``armtree schema`` wrote it into trees/armtree.schema.json."""
    schema = json.loads((ROOT / "trees" / "armtree.schema.json").read_text())
    return schema["definitions"]["profile"]["properties"]["world"]


def test_the_written_schema_is_the_declarations():
    assert world_schema() == WORLD.schema()
    assert set(world_schema()["properties"]) == set(WORLD.fields)
    assert world_schema()["additionalProperties"] is False


@pytest.mark.parametrize("name", SHIPPED)
def test_the_schema_validates_every_shipped_world(name):
    data = yaml.safe_load(resources.files("armtree.hardware").joinpath(name).read_text())
    jsonschema.Draft7Validator(world_schema()).validate(data["world"])


@pytest.mark.parametrize(
    ("change", "path", "word"),
    [
        ({"gravity": 9.8}, [], "gravity"),
        ({"table": {"texture": "marble"}}, ["table", "texture"], "marble"),
        ({"objects": {"ducky": {"kind": "ducky", "at": [0, 0], "colour": 1}}}, [], "colour"),
        ({"light": {"ambient": 2}}, ["light", "ambient"], "2"),
        ({"duckybots": {"bot": {"route": [{"park": [0, 0], "until": "never"}]}}}, [], "never"),
    ],
)
def test_the_schema_refuses_what_the_check_refuses(change, path, word):
    errors = list(jsonschema.Draft7Validator(world_schema()).iter_errors(change))
    assert errors
    assert any(list(e.absolute_path)[: len(path)] == path and word in str(e) for e in errors)


def errors_in(tmp_path: Path, old: str, new: str, overrides: tuple[str, ...] = ()):
    """The errors of sim_dobot with ``old`` replaced by ``new``, and the changed line."""
    text = resources.files("armtree.hardware").joinpath("sim_dobot.yaml").read_text()
    assert old in text
    path = tmp_path / "rig.yaml"
    path.write_text(text.replace(old, new, 1))
    first = new.splitlines()[0]
    line = next(i for i, s in enumerate(path.read_text().splitlines(), 1) if first in s)
    with pytest.raises(ConfigError) as info:
        load_profile(path, overrides)
    return path, line, info.value.errors


def test_an_unknown_world_key_is_refused_at_its_position_naming_the_keys(tmp_path):
    path, line, errors = errors_in(tmp_path, "  seed: 0\n", "  seed: 0\n  gravity: 9.8\n")
    (err,) = errors
    assert (err.file, err.line, err.column) == (str(path), line + 1, 12)
    assert err.message.startswith("world.gravity: unknown key 'gravity'")
    assert all(key in err.message for key in WORLD.fields)


def test_an_unknown_object_key_is_refused_with_a_did_you_mean(tmp_path):
    old = "ducky: {kind: ducky, at: [119, -142]"
    path, line, errors = errors_in(
        tmp_path, old, old.replace("kind: ducky,", "kind: ducky, colr: 1,")
    )
    (err,) = errors
    assert (err.file, err.line) == (str(path), line)
    assert err.message == "world.objects.ducky.colr: unknown key 'colr'; did you mean 'color'?"


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "texture: wood",
            "texture: marble",
            "world.table.texture: expected wood, plain or checker, got 'marble'",
        ),
        (
            "halt_on_collision: true",
            "halt_on_collision: maybe",
            "world.physics.halt_on_collision: expected true or false, got 'maybe'",
        ),
        (
            "ambient: 0.55}\n  objects",
            "ambient: 5}\n  objects",
            "world.light.ambient: expected a number from 0 to 1, got 5",
        ),
        (
            "speed_mm_s: 40",
            "speed_mm_s: fast",
            "world.duckybots.duckybot.speed_mm_s: expected a number > 0 (mm/s), got 'fast'",
        ),
    ],
)
def test_a_wrong_value_is_refused_at_its_position_naming_what_it_takes(tmp_path, old, new, message):
    path, line, errors = errors_in(tmp_path, old, new)
    (err,) = errors
    assert (err.file, err.line) == (str(path), line)
    assert err.message == message
    written = path.read_text().splitlines()[line - 1]
    first = new.splitlines()[0]
    assert err.column == written.index(first) + first.index(": ") + 3  # the value's column


def test_every_wrong_value_is_reported_at_once(tmp_path):
    old = "ducky: {kind: ducky, at: [119, -142]"
    _, _, errors = errors_in(tmp_path, old, old.replace("kind: ducky", "kind: duck, shape: round"))
    assert [e.message.split(":")[0] for e in errors] == [
        "world.objects.ducky.kind",
        "world.objects.ducky.shape",
    ]
    assert "did you mean 'ducky'" in errors[0].message


@pytest.mark.parametrize(
    ("override", "message"),
    [
        (
            "world.table.texture=marble",
            "world.table.texture: expected wood, plain or checker, got 'marble'",
        ),
        ("world.light.colour=1", "world.light.colour: unknown key 'colour'"),
        ("world.objects.ducky.kind=duckybot", "duckybots go under world.duckybots"),
        ("world.seed=-1", "world.seed: expected an integer from 0 to 2**63 - 1, got -1"),
    ],
)
def test_a_set_override_is_checked_by_the_same_declaration(override, message):
    with pytest.raises(ConfigError) as info:
        load_profile("sim_dobot", [override])
    (err,) = info.value.errors
    assert err.file == f"--set {override}"
    assert message in err.message


def test_an_override_that_puts_a_body_onto_another_is_refused_at_the_entry():
    with pytest.raises(ConfigError) as info:
        load_profile("sim_dobot", ["world.objects.ducky.at=[92,160]"])
    (err,) = info.value.errors
    assert "trash_a overlaps ducky" in err.message
    assert err.file.endswith("sim_dobot.yaml") and err.line is not None


def test_profiles_md_has_the_world_key_tables():
    text = (ROOT / "docs" / "profiles.md").read_text()
    for name in ("world", "world.table", "world.objects", "world.duckybots", "world.faults"):
        assert f"<!-- keys of {name}: generated" in text
    for key in WORLD.fields:
        assert f"| `{key}` |" in text
