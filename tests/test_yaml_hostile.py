"""The YAML front end under hostile input: bounded work, positioned errors, no raw exception."""

from __future__ import annotations

import time
import tracemalloc
from pathlib import Path

import pytest

import armtree
from armtree.config import yamlio
from armtree.config.yamlio import MAX_BYTES, MAX_DEPTH, load_yaml, load_yaml_file
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import get_plugin_manager


def laughs(levels: int = 10, width: int = 10) -> str:
    """The "billion laughs": each level's list names the previous level ``width`` times."""
    lines = ["l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]")
    return "\n".join(lines) + "\n"


def error_of(text: str) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_yaml(text, "f.yaml")
    return info.value


def test_an_alias_bomb_is_refused_while_it_is_read_in_bounded_time_and_memory() -> None:
    tracemalloc.start()
    start = time.perf_counter()
    error = error_of(laughs())
    elapsed = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert "aliases expanded" in error.message and "alias bomb" in error.message
    assert (error.line, error.column) == (6, 10)  # the alias that passes the limit
    assert elapsed < 5.0
    assert peak < 50e6


def test_aliases_within_the_limit_stay_shared_and_marked() -> None:
    data = load_yaml("a: &x [1, 2]\nb: *x\n", "f.yaml")
    assert data["b"] == [1, 2] and data["b"] is data["a"]
    assert data.value_marks["b"].line == 2


@pytest.mark.parametrize(("text", "column"), [("x: &a [*a]\n", 8), ("x: &a {y: [1, *a]}\n", 15)])
def test_a_recursive_alias_is_an_error_at_the_alias(text: str, column: int) -> None:
    error = error_of(text)
    assert "recursive alias" in error.message
    assert (error.line, error.column) == (1, column)


def test_deep_nesting_is_refused_before_anything_recurses() -> None:
    block = "".join(f"{'  ' * i}k{i}:\n" for i in range(MAX_DEPTH + 5)) + "  " * 300 + "end\n"
    error = error_of(block)
    assert f"deeper than {MAX_DEPTH} levels" in error.message
    assert error.line == MAX_DEPTH + 1
    flow = error_of("x: " + "[" * 3000 + "]" * 3000)
    assert flow.line == 1 and flow.column is not None


@pytest.mark.parametrize(
    ("text", "message", "where"),
    [
        (
            "x: " + "9" * 5000 + "\n",
            "cannot read '99999999999999999999... (5000 characters)' as int",
            (1, 4),
        ),
        ("x: !!float abc\n", "cannot read 'abc' as float", (1, 4)),
        ("x: !!python/object:os.system ls\n", "could not determine a constructor", (1, 4)),
        ("x: !!set {a, b}\n", "not supported here (plain data only)", (1, 4)),
        ("a: 1\na: 2\n", "key 'a' is given twice (first at line 1)", (2, 1)),
        ("a: 1\n---\nb: 2\n", "a single document", (2, 1)),
        ("a: *nowhere\n", "undefined alias", (1, 4)),
        ("a: 1\nb: x\x01y\n", "character U+0001 is not allowed", (2, 5)),
        ("a: 1\nb: \x7f\n", "character U+007F is not allowed", (2, 4)),
    ],
)
def test_bad_scalars_and_characters_are_positioned(
    text: str, message: str, where: tuple[int, int]
) -> None:
    error = error_of(text)
    assert message in error.message
    assert (error.line, error.column) == where
    assert error.file == "f.yaml"


def test_merge_keys_still_work() -> None:
    data = load_yaml("base: &b {x: 1, y: 2}\nd:\n  <<: *b\n  y: 3\n", "f.yaml")
    assert data["d"] == {"x": 1, "y": 3}
    assert data["d"].value_marks["x"].line == 1


def test_a_file_above_the_limit_is_refused_unparsed(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "big.yaml"
    path.write_bytes(b"- 1\n" * (MAX_BYTES // 4 + 1))

    def never(*args: object) -> None:
        raise AssertionError("a file above the limit was decoded or parsed")

    monkeypatch.setattr(yamlio, "decode", never)
    monkeypatch.setattr(yamlio, "load_yaml", never)
    with pytest.raises(ConfigError) as info:
        load_yaml_file(path)
    assert f"larger than {MAX_BYTES:,} bytes" in info.value.message


def test_bytes_that_are_not_utf8_are_an_error_at_their_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "latin.yaml"
    path.write_bytes(b"root:\n  success: {name: caf" + b"\xe9}\n")
    with pytest.raises(ConfigError) as info:
        load_yaml_file(path)
    assert (info.value.line, info.value.column) == (2, 22)
    assert "byte 0xe9 is not UTF-8" in info.value.message


def test_a_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "bom.yaml"
    path.write_bytes(b"\xef\xbb\xbfa: 1\n")
    assert load_yaml_file(path) == {"a": 1}


def test_a_tree_with_a_bomb_in_its_blackboard_fails_check_quickly(tmp_path: Path) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(laughs().replace("l", "x") + "blackboard: {bomb: *x9}\nroot: {success: {}}\n")
    # the first load imports every plugin, which is not what is timed
    assert get_plugin_manager().registry.names("behaviour")
    start = time.perf_counter()
    with pytest.raises(ConfigError) as info:
        armtree.load_tree(tree)
    assert time.perf_counter() - start < 10.0
    assert info.value.file == str(tree) and info.value.line is not None


def test_limits_are_module_constants_a_user_can_read() -> None:
    assert yamlio.MAX_NODES >= 100_000 and yamlio.MAX_BYTES >= 1_000_000
