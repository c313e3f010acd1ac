"""Exit codes keep the cause: a link lost mid-run is a hardware fault (3), not the tree's FAILURE."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

import armtree
from armtree.hooks.plugin_manager import make_plugin_manager
from armtree.plugins.arms.common import PtyEmulator

TREE = """\
rig: sim_dobot
root:
  sequence:
    name: Root
    children:
      - move_to: {to: garbage_bin}
      - move_to: {to: home}
      - move_to: {to: garbage_bin}
      - move_to: {to: home}
"""


class CutAt:
    """A plugin that cuts the emulated arm's link at a given tick."""

    def __init__(self, tick: int, silent: bool) -> None:
        self.tick = tick
        self.silent = silent

    @armtree.hookimpl
    def armtree_tick(self, run) -> None:
        if run.tick_count != self.tick:
            return
        for stepper in run.rig.steppers:
            emulator = getattr(stepper, "__self__", None)
            if isinstance(emulator, PtyEmulator):
                emulator.inject("cut", **({"silent": 1} if self.silent else {}))


@pytest.mark.parametrize(("tick", "silent"), [(12, False), (25, False), (18, True)])
def test_a_link_lost_mid_move_ends_the_run_with_exit_3_naming_the_port(
    tmp_path: Path, tick: int, silent: bool
) -> None:
    (tmp_path / "t.yaml").write_text(textwrap.dedent(TREE))
    manager = make_plugin_manager()
    manager.register(CutAt(tick, silent), f"cut_at_{tick}")
    tree = armtree.load_tree(tmp_path / "t.yaml", manager=manager)
    result = armtree.run(tree, record=False, handle_signals=False, stop_key=False, manager=manager)
    assert result.exit_code == 3, result.message
    assert "link lost" in result.message and "/dev/" in result.message
