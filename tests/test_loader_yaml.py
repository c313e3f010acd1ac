"""Property tests of the marked YAML reader and the --set override parser."""

from __future__ import annotations

import json

import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from armtree.config.yamlio import _FLOAT_12, MarkedDict, MarkedList, load_yaml
from armtree.loader.profile import parse_override

# Keys PyYAML writes unquoted and reads back as strings (not booleans or nulls).
RESERVED = {"y", "n", "yes", "no", "on", "off", "true", "false", "null"}
keys = st.from_regex(r"[a-z][a-z0-9_]{0,8}", fullmatch=True).filter(lambda k: k not in RESERVED)
scalars = (
    st.none()
    | st.booleans()
    | st.integers(-(10**9), 10**9)
    | st.floats(-1e6, 1e6, allow_nan=False).map(lambda x: round(x, 3))
    # Text that YAML 1.2 reads as a float (``0E0``), as the marked reader does on purpose and
    # PyYAML's YAML 1.1 does not, is left out: the two readers differ there by design.
    | st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=12).filter(
        lambda t: not _FLOAT_12.match(t)
    )
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
                assert mark.line >= 1 and mark.line <= len(lines) + 1 and mark.column >= 1
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


leaves = st.sampled_from(
    [{"success": {}}, {"failure": None}, {"running": {}}, {"tick_counter": {"duration": 2}}]
)


def _composite(children):
    return st.sampled_from(["sequence", "selector", "parallel"]).map(lambda t: {t: children})


def _decorator(child):
    return st.sampled_from(
        [
            lambda c: {"inverter": {"child": c}},
            lambda c: {"retry": {"num_failures": 2, "child": c}},
            lambda c: {"timeout": {"duration": 1.5, "child": c}},
        ]
    ).map(lambda make: make(child))


trees = st.recursive(
    leaves,
    lambda inner: (
        st.lists(inner, min_size=1, max_size=4).flatmap(_composite) | inner.flatmap(_decorator)
    ),
    max_leaves=25,
)


def _preorder(node) -> list[str]:
    ((ntype, spec),) = node.items()
    if isinstance(spec, list):
        return [ntype, *(t for child in spec for t in _preorder(child))]
    if isinstance(spec, dict) and "child" in spec:
        return [ntype, *_preorder(spec["child"])]
    return [ntype]


def _core_manager():
    from armtree.hooks import builtin_behaviours
    from armtree.hooks.plugin_manager import PluginManager

    manager = PluginManager(autoload=False)
    manager.register(builtin_behaviours, "core_behaviours")
    return manager


MANAGER = _core_manager()


@settings(max_examples=40, deadline=None)
@given(trees, st.booleans(), st.data())
def test_random_trees_load_and_one_unknown_type_is_pinpointed(tmp_path_factory, root, flow, data):
    import armtree

    directory = tmp_path_factory.mktemp("t")
    path = directory / "t.yaml"
    path.write_text(yaml.safe_dump({"root": root}, default_flow_style=flow, sort_keys=False))
    tree = armtree.load_tree(path, manager=MANAGER)
    expected = _preorder(root)
    assert len(tree.nodes) == len(expected)
    assert sorted(i.type for i in tree.nodes.values()) == sorted(expected)
    victim = data.draw(st.integers(0, len(expected) - 1))
    counter = iter(range(len(expected)))

    def rename(node):
        ((ntype, spec),) = node.items()
        new_type = "zzz_unknown" if next(counter) == victim else ntype
        if isinstance(spec, list):
            spec = [rename(child) for child in spec]
        elif isinstance(spec, dict) and "child" in spec:
            spec = {**spec, "child": rename(spec["child"])}
        return {new_type: spec}

    text = yaml.safe_dump({"root": rename(root)}, default_flow_style=flow, sort_keys=False)
    path.write_text(text)
    try:
        armtree.load_tree(path, manager=MANAGER)
    except armtree.ConfigError as exc:
        errors = exc.errors
    else:
        raise AssertionError("an unknown node type was accepted")
    assert len(errors) == 1 and "unknown node type 'zzz_unknown'" in errors[0].message
    line = text.splitlines()[errors[0].line - 1]
    assert line[errors[0].column - 1 :].startswith("zzz_unknown:")
