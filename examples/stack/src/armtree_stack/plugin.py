"""``stack`` and ``stack_height``: stacking tagged blocks with armtree's pick and place.

``stack: {tag: block, from: [a, b, c], onto: base}`` is a sequence of armtree's
own ``pick`` and ``place`` behaviours, built when the tree loads: the first
block is put on the place ``onto``; each later one is put on the marker of the
block below, found again with the camera, so the stack grows where it really
is, not where it was meant to be. ``pick`` and ``place`` come from armtree's
registry, as a tree would name them: this package imports no skill module.

``stack_height: {tag: block, onto: base, blocks: 3}`` then checks with the
camera that the topmost marker near ``onto`` is as high as that many blocks:
the stack stands, it was not just put down beside itself.

armtree finds this module through the ``armtree`` entry point of the package.
"""

from __future__ import annotations

from typing import Any

import armtree
import numpy as np
import py_trees
from armtree.api.factories import construct
from armtree.config.constructor_params import declared_params
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.maths.perception.frames import camera_in_base, marker_in_base
from py_trees.common import Status

#: The armtree versions this plugin supports; another one refuses to load it.
ARMTREE_REQUIRES = ">=0.1,<0.2"


def _node(kind: str, name: str, **given: Any) -> py_trees.behaviour.Behaviour:
    """A registered behaviour built as the loader would: declared defaults, then ``given``."""
    factory = get_plugin_manager().registry.get("behaviour", kind).factory
    params = {p.name: p.default for p in declared_params(factory) if not p.required}
    return construct(factory, name, {**params, **given})


def stack(name: str, **params: Any) -> py_trees.composites.Sequence:
    """Stack the tagged blocks found at the places ``from`` on the place ``onto``, in order."""
    tag, onto, sources = params["tag"], params["onto"], params["from"]
    if not sources:
        raise ValueError("from: give at least one place to take a block from")
    children = []
    for i, source in enumerate(sources, start=1):
        children.append(_node("pick", f"Pick block {i} at {source}", tag=tag, **{"from": source}))
        on_top = {"tag": tag} if i > 1 else {}  # the block below's marker, seen again
        children.append(
            _node("place", f"Put it on the stack ({i} high)", at=onto, object=tag, **on_top)
        )
    return py_trees.composites.Sequence(name=name, memory=True, children=children)


stack.PARAMS = (
    armtree.Param("tag", "str", doc="tag role of the blocks", kind="tag_role"),
    armtree.Param("from", "str_list", doc="places to take a block from, bottom block first"),
    armtree.Param("onto", "str", doc="the place the stack stands on", kind="place"),
)


class StackHeight(armtree.Behaviour):
    """SUCCESS when the topmost ``tag`` marker near ``onto`` is ``blocks`` block heights up."""

    PARAMS = (
        armtree.Param("tag", "str", doc="tag role of the blocks", kind="tag_role"),
        armtree.Param("onto", "str", doc="the place the stack stands on", kind="place"),
        armtree.Param("blocks", "int", doc="how many blocks the stack should have", minimum=1),
        armtree.Param(
            "block_mm", "float", 25.0, unit="mm", doc="height of one block", exclusive_minimum=0
        ),
        armtree.Param(
            "tolerance_mm", "float", 8.0, unit="mm", doc="how far off the top may be", minimum=0
        ),
        armtree.Param(
            "radius_mm",
            "float",
            40.0,
            unit="mm",
            doc="how far from `onto` the stack may stand",
            minimum=0,
        ),
        armtree.Param("timeout_s", "float", 2.0, unit="s", doc="how long to look", minimum=0),
    )

    def initialise(self) -> None:
        """Look at frames from now on."""
        self.started = self.now()
        self.feedback_message = "looking at the stack"

    def update(self) -> Status:
        """Measure the top marker's height in the newest frame; FAILURE saying by how much."""
        frame = self.rig.camera.read()
        if frame is None or frame.timestamp < self.started:
            return self._waiting()
        base = np.asarray(self.rig.places[self.param("onto")], dtype=float)
        camera = camera_in_base(
            self.rig.camera.mount, self.rig.camera.extrinsics, self.rig.arm.pose()
        )
        tops = []
        for detection in self.rig.tracker.detect(frame):
            spec = self.rig.role_of(detection.id)
            if spec is None or spec.role != self.param("tag") or detection.tvec is None:
                continue
            xyz = marker_in_base(camera, detection.rvec, detection.tvec)[:3, 3]
            if np.linalg.norm(xyz[:2] - base[:2]) <= self.param("radius_mm"):
                tops.append(xyz)
        if not tops:
            return self._waiting()
        top = max(tops, key=lambda p: p[2])
        table = base[2] - self.param("block_mm")  # the place is the first block's top
        expected = table + self.param("blocks") * self.param("block_mm")
        self.feedback_message = f"the stack's top is at z = {top[2]:.1f} mm; {self.param('blocks')} blocks: {expected:.1f} mm"
        return (
            Status.SUCCESS
            if abs(top[2] - expected) <= self.param("tolerance_mm")
            else Status.FAILURE
        )

    def _waiting(self) -> Status:
        if self.now() - self.started > self.param("timeout_s"):
            self.feedback_message = f"no {self.param('tag')!r} marker near {self.param('onto')!r}"
            return Status.FAILURE
        return Status.RUNNING


@armtree.hookimpl
def armtree_behaviours() -> dict[str, Any]:
    """Register ``stack`` and ``stack_height``."""
    return {"stack": stack, "stack_height": StackHeight}
