"""Property tests of the loaders: any YAML text gives a tree (or profile) or a positioned
ConfigError; never another exception, and in bounded time."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import armtree
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import get_plugin_manager

#: Words the loaders react to, so generated documents reach past the first check.
WORDS = st.sampled_from(
    [
        "root", "sequence", "selector", "parallel", "children", "child", "success", "failure",
        "running", "inverter", "retry", "timeout", "subtree", "file", "with", "name", "tick_hz",
        "blackboard", "params", "rig", "move_to", "to", "pick", "tag", "search", "home",
        "duckybot", "arm", "type", "dobot_v1", "camera", "sim", "fps", "places", "tags", "id",
        "size_mm", "world", "objects", "planner", "prm", "milestones", "tracker", "aruco",
        "watchdog", "tick_s", "{key}", "{}", "sim_dobot", "port", "obstacles", "box",
    ]
)  # fmt: skip
SCALARS = st.one_of(
    WORDS,
    st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.none(),
    st.text(max_size=12),
)
DOCUMENTS = st.recursive(
    SCALARS,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(WORDS, inner, max_size=4)),
    max_leaves=25,
)


def as_yaml(document: object, flow: bool) -> str:
    return yaml.safe_dump(document, default_flow_style=flow, allow_unicode=True)


TEXTS = st.one_of(
    st.builds(as_yaml, DOCUMENTS, st.booleans()),
    st.text(max_size=200),
    st.builds(
        lambda doc, junk, at: (lambda t: t[: at % (len(t) + 1)] + junk + t[at % (len(t) + 1) :])(
            as_yaml(doc, False)
        ),
        DOCUMENTS,
        st.text(alphabet="{}[]:&*!|>-#'\"\n\t %@`,?\x07", max_size=6),
        st.integers(min_value=0, max_value=400),
    ),
)

FOLDER = Path(tempfile.mkdtemp(prefix="armtree-fuzz-"))


@pytest.fixture(scope="module", autouse=True)
def plugins_loaded() -> None:
    """Load the plugins once before timing: the first load imports every component."""
    assert get_plugin_manager().registry.names("behaviour")


def loads_or_points(load, text: str, name: str) -> None:
    path = FOLDER / name
    path.write_text(text, encoding="utf-8", errors="surrogateescape")
    start = time.perf_counter()
    try:
        load(path)
    except ConfigError as exc:
        for error in exc.errors:
            assert error.file is not None, error.format()
            assert error.line is not None or error.file != str(path), error.format()
            assert "Traceback" not in error.message
    assert time.perf_counter() - start < 5.0


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(TEXTS)
def test_property_any_text_is_a_tree_or_a_positioned_error(text: str) -> None:
    loads_or_points(armtree.load_tree, text, "fuzz_tree.yaml")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(TEXTS)
def test_property_any_text_is_a_profile_or_a_positioned_error(text: str) -> None:
    loads_or_points(armtree.load_profile, text, "fuzz_profile.yaml")
