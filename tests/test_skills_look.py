"""The Look step reads the camera only once its frames can be used.

Reading a frame costs a marker search (and in the simulation a render), so a look
that waits for the arm to settle must not read frames it will skip.
"""

from __future__ import annotations

import math

import numpy as np
from test_skills_fakes import TICK, FakeCamera, Marker, make_rig

from armtree.api.rig import Frame
from armtree.api.skill.actions import Look, State


class PeriodicCamera(FakeCamera):
    """A camera of ``fps`` frames a second: the frame at hand is stamped on the last
    multiple of its period, as the simulation's camera stamps its frames."""

    fps = 30.0

    def read(self) -> Frame | None:
        frame = super().read()
        if frame is None:
            return None
        stamp = math.floor(frame.timestamp * self.fps + 1e-9) / self.fps
        return Frame(frame.image, stamp, frame.camera_matrix, frame.distortion, frame.index)


def look_until_done(rig, look: Look, max_ticks: int = 100) -> State:
    """Tick ``look`` on ``rig``'s clock until it ends; its final state."""
    look.start()
    for _ in range(max_ticks):
        state = look.poll()
        if state is not State.RUNNING:
            return state
        rig.clock.advance(TICK)
    raise AssertionError("the look never ended")


def test_a_settling_look_reads_no_frame_before_its_settle_time():
    rig = make_rig([Marker(0, np.array([200.0, 0.0, 0.0]))])
    rig.clock.advance(1.0)
    look = Look(rig, rig.clock, frames=2, settle=0.3)
    assert look_until_done(rig, look) is State.DONE
    # two frames used, and no other frame read (six ticks of settling used to read six)
    assert rig.camera._index == 2


def test_a_look_on_a_periodic_camera_reads_only_frames_stamped_after_settling():
    rig = make_rig([Marker(0, np.array([200.0, 0.0, 0.0]))])
    camera = PeriodicCamera(rig.clock, rig.arm)
    rig.camera = rig.tracker.camera = camera
    stamps = []
    read = camera.read

    def recording_read():
        frame = read()
        if frame is not None:
            stamps.append(frame.timestamp)
        return frame

    camera.read = recording_read
    rig.clock.advance(1.0)
    look = Look(rig, rig.clock, frames=3, settle=0.15)
    assert look_until_done(rig, look) is State.DONE
    assert len(stamps) == 3, stamps
    assert all(stamp >= 1.15 - 1e-9 for stamp in stamps), stamps
    assert len(look.result) == 1 and look.result[0].id == 0
