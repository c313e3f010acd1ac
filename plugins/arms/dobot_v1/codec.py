"""The Dobot V1.0 original firmware's 42-byte frames, both directions.

A frame is ``0xA5``, ten little-endian float32 and ``0x5A``; no length, no
checksum (Dobot protocol, frame format). Host-to-arm fields are ``state, axis, x, y, z,
rHead, isGrab, startVel, endVel, maxVel`` (Dobot protocol, host-to-arm frame); arm-to-host status fields
are ``x, y, z, rHead, baseAngle, longArmAngle, shortArmAngle, pawArmAngle,
isGrab, gripperAngle`` (Dobot protocol, status frame). Units: mm and degrees.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from armtree.plugins.arms.common import FixedFrameParser

HEADER = 0xA5
TAIL = 0x5A
FRAME_LEN = 42
_FLOATS = struct.Struct("<10f")

# States (Dobot protocol, host-to-arm states)
STATE_JOINT_JOG = 2
STATE_MOVE_XYZ = 3
STATE_MOVE_JOINTS = 6
STATE_LINEAR_JOG = 7
STATE_CONFIG = 9
STATE_SPEED = 10

# Move modes, F8 of states 3 and 6: the official client's enum order (Dobot protocol)
MODE_JUMP = 0
MODE_MOVJ = 1
MODE_MOVL = 2

# Jog axis codes (Dobot protocol, table 2.5)
AXIS_STOP = 0
AXIS_GRAB = 9
AXIS_RELEASE = 10

# State 9 sub-modes
CONFIG_JOG = 0
CONFIG_PLAYBACK = 1


def encode_frame(values: Sequence[float]) -> bytes:
    """Pack ten floats into a 42-byte frame; fewer values are padded with 0.0."""
    if len(values) > 10:
        raise ValueError(f"a frame holds 10 floats, got {len(values)}")
    padded = list(values) + [0.0] * (10 - len(values))
    return bytes([HEADER]) + _FLOATS.pack(*padded) + bytes([TAIL])


def decode_frame(frame: bytes) -> tuple[float, ...]:
    """The ten floats of a 42-byte frame; raises ValueError if it is not one."""
    if len(frame) != FRAME_LEN or frame[0] != HEADER or frame[-1] != TAIL:
        raise ValueError(f"not a Dobot V1 frame: {frame[:8].hex(' ')}...")
    return _FLOATS.unpack(frame[1:-1])


def _values(record: Command | Status) -> list[float]:
    # Field by field rather than dataclasses.astuple, whose deep copy of every float
    # costs more than packing the frame.
    return [getattr(record, f.name) for f in fields(record)]


def frame_parser() -> FixedFrameParser:
    """A resynchronising parser of 42-byte frames (drop bytes until 0xA5, check 0x5A)."""
    return FixedFrameParser(bytes([HEADER]), FRAME_LEN, bytes([TAIL]))


@dataclass(frozen=True)
class Command:
    """A host-to-arm frame's ten fields, as named by the official client."""

    state: float
    axis: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    r_head: float = 0.0
    is_grab: float = 0.0
    start_vel: float = 0.0
    end_vel: float = 0.0
    max_vel: float = 0.0

    def encode(self) -> bytes:
        """The 42 bytes on the wire."""
        return encode_frame(_values(self))

    @classmethod
    def decode(cls, frame: bytes) -> Command:
        """Parse a host-to-arm frame."""
        return cls(*decode_frame(frame))


@dataclass(frozen=True)
class Status:
    """An arm-to-host status frame: Cartesian pose, joint angles and tool (mm, degrees)."""

    x: float
    y: float
    z: float
    r_head: float
    base: float
    rear: float
    fore: float
    paw: float
    is_grab: float
    gripper: float

    def encode(self) -> bytes:
        """The 42 bytes on the wire."""
        return encode_frame(_values(self))

    @classmethod
    def decode(cls, frame: bytes) -> Status:
        """Parse a status frame."""
        return cls(*decode_frame(frame))

    @property
    def joints(self) -> tuple[float, float, float]:
        """``(base, rear, fore)`` in degrees."""
        return (self.base, self.rear, self.fore)


def move_joints(
    q: Sequence[float] | np.ndarray,
    r_head: float = 0.0,
    suction: bool = False,
    mode: int = MODE_MOVJ,
    gripper: float = 0.0,
    pause: float = 0.0,
) -> Command:
    """State 6: go to joint angles ``q`` (base, rear, fore; degrees)."""
    base, rear, fore = q
    return Command(
        STATE_MOVE_JOINTS, 0.0, base, rear, fore, r_head, float(suction), mode, gripper, pause
    )


def move_xyz(
    xyz: Sequence[float],
    r_head: float = 0.0,
    suction: bool = False,
    mode: int = MODE_MOVJ,
    gripper: float = 0.0,
    pause: float = 0.0,
) -> Command:
    """State 3: go to Cartesian ``xyz`` (mm) with the firmware's own IK."""
    x, y, z = xyz
    return Command(STATE_MOVE_XYZ, 0.0, x, y, z, r_head, float(suction), mode, gripper, pause)


def jog(axis: int, speed_percent: float = 0.0, linear: bool = False) -> Command:
    """State 2 (joint) or 7 (linear) jog; axis 0 stops, 9 / 10 grab / release the suction."""
    return Command(STATE_LINEAR_JOG if linear else STATE_JOINT_JOG, axis, start_vel=speed_percent)


def configure_playback(
    joint_speed: float,
    joint_accel: float,
    servo_speed: float,
    servo_accel: float,
    linear_speed: float,
    linear_accel: float,
    pause: float = 0.0,
    jump_height: float = 20.0,
) -> Command:
    """State 9 sub-mode 1: playback maxima (deg/s, deg/s^2, mm/s, mm/s^2, s, mm)."""
    return Command(
        STATE_CONFIG,
        CONFIG_PLAYBACK,
        joint_speed,
        joint_accel,
        servo_speed,
        servo_accel,
        linear_speed,
        linear_accel,
        pause,
        jump_height,
    )


def set_speed(velocity_percent: float, accel_percent: float) -> Command:
    """State 10: playback velocity and acceleration ratios, percent (Dobot protocol, state 10)."""
    return Command(STATE_SPEED, 0.0, velocity_percent, accel_percent)
