"""Every public name docs/plugins.md tells a plugin author to use exists (issue 29): dotted
armtree names import, `rig.X`, `self.X`, `runtime.X` and `context.X` are attributes, the
rig table's methods are the interfaces' own."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import inspect
import re
from pathlib import Path
from typing import Any

import pytest

import armtree
from armtree.api.rig import MotionStatus, Rig, RigContext
from armtree.maths.motion.kinematics import KinematicModel
from armtree.plugins.arms.common import PtyEmulator
from armtree.runtime.runner import Run

DOC = Path(__file__).resolve().parents[1] / "docs" / "plugins.md"
TEXT = DOC.read_text()
CODE = "\n".join(re.findall(r"```(?:python|yaml|bash)?\n(.*?)```", TEXT, re.S))
#: Backticked text of the page (code spans), and the names used in its code blocks.
SPANS = re.findall(r"`([^`\n]+)`", TEXT)


def resolve(dotted: str) -> Any:
    """The object ``a.b.c`` names: the longest module prefix imported, the rest attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            found: Any = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for name in parts[cut:]:
            found = getattr(found, name)
        return found
    raise ModuleNotFoundError(dotted)


#: A dotted name that is a file's (``armtree.schema.json``), not a Python one.
FILES = (".json", ".yaml", ".py", ".md", ".png")
DOTTED = sorted(
    name
    for name in {m for span in SPANS for m in re.findall(r"\barmtree(?:\.[A-Za-z_]\w*)+", span)}
    | set(re.findall(r"\barmtree(?:\.[A-Za-z_]\w*)+", CODE))
    if not name.endswith(FILES)
)
IMPORTS = sorted(
    {
        f"{module}.{name.strip()}"
        for module, names in re.findall(r"from (armtree[\w.]*) import ([\w, ]+)", CODE)
        for name in names.split(",")
    }
)


def test_the_page_names_what_this_test_reads():
    assert len(DOTTED) > 30 and len(IMPORTS) >= 5
    assert "armtree.api.rig.Tool" in DOTTED and "armtree.TagRole" in DOTTED


@pytest.mark.parametrize("dotted", DOTTED + IMPORTS)
def test_every_armtree_name_on_the_page_exists(dotted):
    resolve(dotted)


def attributes(cls: type) -> set[str]:
    """What instances of ``cls`` have: class attributes, annotations, dataclass fields, and
    what its ``__init__`` sets on ``self``."""
    names = set(dir(cls))
    for klass in cls.__mro__:
        names |= set(getattr(klass, "__annotations__", {}))
        init = vars(klass).get("__init__")
        if init is not None:
            with contextlib.suppress(OSError, TypeError):  # no source: a C type's
                names |= set(re.findall(r"self\.(\w+)\s*(?::[^=\n]*)?=", inspect.getsource(init)))
    if dataclasses.is_dataclass(cls):
        names |= {f.name for f in dataclasses.fields(cls)}
    return names


#: What ``rig.X`` is, for the names the page gives below it (``rig.arm.model``).
PARTS = {
    "arm": armtree.api.rig.ArmDriver,
    "tool": armtree.api.rig.Tool,
    "camera": armtree.api.rig.Camera,
}
#: What each prefix names on the page; ``self`` is a behaviour's (a skill's), or in the emulator's
#: paragraph a ``PtyEmulator``'s.
ON = {
    "rig": (Rig,),
    "self": (armtree.Behaviour, armtree.ArmSkill, PtyEmulator),
    "runtime": (Run,),
    "context": (RigContext,),
}


def named_on(prefix: str) -> list[str]:
    pattern = rf"(?<![\w.]){prefix}\.([a-z_]\w*(?:\.[a-z_]\w*)?)"
    return sorted({m for span in SPANS for m in re.findall(pattern, span)})


@pytest.mark.parametrize(
    ("prefix", "name"), [(p, n) for p in ON for n in named_on(p)], ids=lambda v: str(v)
)
def test_every_attribute_the_page_names_exists(prefix, name):
    first, _, rest = name.partition(".")
    assert any(first in attributes(cls) for cls in ON[prefix]), f"{prefix}.{first}"
    if rest and prefix == "rig" and first in PARTS:
        assert rest in attributes(PARTS[first]), f"{prefix}.{name}"


def rig_table() -> list[tuple[str, str, str]]:
    rows = re.findall(r"^\| `(rig\.\w+)`[^|]*\| `(\w+)` \| (.*) \|$", TEXT, re.M)
    assert len(rows) >= 6, rows
    return rows


@pytest.mark.parametrize(("part", "interface", "used"), rig_table(), ids=lambda v: v[:20])
def test_the_rig_tables_interfaces_have_the_methods_it_lists(part, interface, used):
    cls = getattr(armtree.api.rig, interface, None) or getattr(armtree, interface)
    assert part.split(".")[1] in attributes(Rig)
    # Methods named after `rig.arm.model` are the kinematic model's.
    own, _, model = used.partition("`rig.arm.model`")
    for names, owner in ((own, cls), (model, KinematicModel)):
        for method in re.findall(r"`(\w+)\(", names):
            if method[0].isupper():
                continue  # a class it returns (`Frame`, `Detection`)
            assert method in attributes(owner), f"{owner.__name__}.{method}"


def test_the_motion_statuses_the_page_names_are_motionstatus_members():
    named = re.search(r"`status` is a `MotionStatus` \(([^)]*)\)", TEXT)
    assert named is not None
    for member in re.findall(r"`([A-Z]+)`", named.group(1)):
        assert member in MotionStatus.__members__
