"""Property tests of the marked YAML reader and the --set override parser."""

from __future__ import annotations

import json

import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.profile import parse_override
from armtree.yamlio import MarkedDict, MarkedList, load_yaml

# Keys PyYAML writes unquoted and reads back as strings (not booleans or nulls).
RESERVED = {"y", "n", "yes", "no", "on", "off", "true", "false", "null"}
keys = st.from_regex(r"[a-z][a-z0-9_]{0,8}", fullmatch=True).filter(lambda k: k not in RESERVED)
scalars = (
    st.none()
    | st.booleans()
    | st.integers(-(10**9), 10**9)
    | st.floats(-1e6, 1e6, allow_nan=False).map(lambda x: round(x, 3))
    | st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=12)
)
documents = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(keys, inner, max_size=4),
    max_leaves=20,
)


def _marks_inside(value, lines: list[str]) -> None:
    if isinstance(value, MarkedDict):
        for key in value:
            for mark in (value.key_marks[key], value.value_marks[key]):
                assert 1 <= mark.line <= len(lines) + 1 and mark.column >= 1
            _marks_inside(value[key], lines)
    elif isinstance(value, MarkedList):
        assert len(value.item_marks) == len(value)
        for item in value:
            _marks_inside(item, lines)


@settings(max_examples=150, deadline=None)
@given(documents, st.booleans())
def test_marked_load_equals_plain_load(doc, flow):
    text = yaml.safe_dump(doc, default_flow_style=flow, allow_unicode=True)
    data = load_yaml(text, "doc.yaml")
    assert data == yaml.safe_load(text)
    _marks_inside(data, text.splitlines())


@settings(max_examples=100, deadline=None)
@given(st.dictionaries(keys, st.integers(), min_size=1, max_size=6))
def test_key_and_value_marks_point_at_the_text(mapping):
    text = yaml.safe_dump({"root": mapping}, default_flow_style=False)
    lines = text.splitlines()
    inner = load_yaml(text, "doc.yaml")["root"]
    for key, value in mapping.items():
        k, v = inner.key_marks[key], inner.value_marks[key]
        assert lines[k.line - 1][k.column - 1 :].startswith(f"{key}:")
        assert lines[v.line - 1][v.column - 1 :] == str(value)


printable = st.characters(codec="utf-8", exclude_categories=("Cs", "Cc", "Cf", "Zl", "Zp", "Co"))
json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.text(printable, max_size=10),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(keys, inner, max_size=3),
    max_leaves=8,
)


@settings(max_examples=150, deadline=None)
@given(st.lists(keys, min_size=1, max_size=4), json_values)
def test_override_round_trip(parts, value):
    text = f"{'.'.join(parts)}={json.dumps(value, ensure_ascii=False)}"
    override = parse_override(text)
    assert override.keys == tuple(parts)
    assert override.value == value
    assert override.text == text
