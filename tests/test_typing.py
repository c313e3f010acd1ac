"""mypy passes on core/ and the plugins (the package ships py.typed, so plugin authors'
type checkers read these signatures), and the domain types are the ones signatures name."""

from __future__ import annotations

import importlib.util
import inspect
import typing
from pathlib import Path

import pytest

from armtree.api.rig import Rig, RigContext
from armtree.api.views import ProfileView, TreeView
from armtree.loader.profile import Profile
from armtree.loader.tree import Tree

ROOT = Path(__file__).resolve().parent.parent


def _typecheck_tool():
    spec = importlib.util.spec_from_file_location("typecheck", ROOT / "tools" / "typecheck.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.timeout(600)
def test_mypy_passes_on_core_and_the_plugins(tmp_path):
    report, status = _typecheck_tool().check(cache_dir=tmp_path / "mypy_cache")
    assert status == 0, report
    assert "Success: no issues found" in report


def test_the_loader_classes_are_what_the_protocols_promise():
    for cls, protocol in ((Profile, ProfileView), (Tree, TreeView)):
        members = {name for name in vars(protocol) if not name.startswith("_")}
        members |= set(typing.get_type_hints(protocol))
        fields = set(getattr(cls, "__dataclass_fields__", {}))
        missing = {m for m in members if not hasattr(cls, m) and m not in fields}
        assert missing == set(), f"{cls.__name__} lacks {missing} of {protocol.__name__}"


def test_rig_and_context_name_the_profile_type():
    assert "ProfileView" in str(inspect.get_annotations(Rig)["profile"])
    assert "ProfileView" in str(inspect.get_annotations(RigContext)["profile"])
