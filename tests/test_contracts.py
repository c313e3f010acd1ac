"""The public names plugins and trees rely on (armtree.ConfigError, clocks, Param, motion handles) behave as documented."""

import numpy as np
import pytest

import armtree
from armtree.api.clock import VirtualClock
from armtree.api.rig import MotionHandle, MotionStatus
from armtree.config.params import Param, check_value


def test_config_error_is_value_error_with_location():
    err = armtree.ConfigError("bad", file="t.yaml", line=3, column=7)
    assert isinstance(err, ValueError)
    assert (err.file, err.line, err.column) == ("t.yaml", 3, 7)
    assert str(err) == "t.yaml:3:7: bad"


def test_virtual_clock_only_moves_forward():
    clock = VirtualClock()
    clock.advance(0.05)
    clock.sleep_until(1.0)
    assert clock.now() == pytest.approx(1.0)
    with pytest.raises(ValueError):
        clock.advance(-1)


@pytest.mark.parametrize(
    ("ptype", "value", "ok"),
    [
        ("int", 3, True),
        ("int", True, False),
        ("int", "3", False),
        ("float", 2, True),
        ("float", float("nan"), False),
        ("vector", [1, 2.5], True),
        ("vector", [1, "a"], False),
        ("bool", 1, False),
        ("str", "x", True),
    ],
)
def test_check_value_types(ptype, value, ok):
    param = Param("p", ptype)
    if ok:
        check_value(param, value)
    else:
        with pytest.raises(ValueError):
            check_value(param, value)


def test_motion_handle_terminal_status_is_final():
    handle = MotionHandle("move", np.zeros(3))
    handle.update(MotionStatus.RUNNING, 0.5)
    handle.update(MotionStatus.DONE)
    handle.update(MotionStatus.FAILED, error=RuntimeError("late"))
    assert handle.status is MotionStatus.DONE and handle.progress == 1.0 and handle.error is None
