"""A bus-servo arm's profile section, checked: its servos, their calibration, its URDF model.

``arm: {type: bus_servo, bus, urdf, tool_link, servos, gripper, calibration, ...}``
(:mod:`.plugin` lists every key). :func:`arm_spec` checks the section as a whole
and says what is wrong at the dotted path of the value (the profile places it at
its line and column, in an included calibration file too): a servo model the bus
does not speak, an id given twice, a baud rate a servo does not support, joints
the URDF does not have, a calibration for other ids. :func:`arm_model` builds the
URDF model (kept for the next call with the same file and keys), its joint limits
cut to the ranges the calibration measured, and refuses a home that does not hold the
tool along ``tool_axis``.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from armtree.config.resolve import resolve
from armtree.errors import ConfigError, shown
from armtree.maths.motion.urdf import AXIS_WEIGHT, IK_TOL_MM, UrdfModel, load_urdf

from .bus import MAX_ID
from .calibration import ServoCalibration, parse_calibration
from .tables import MODELS, ServoModel

#: How far (deg) home may hold the tool off ``tool_axis``: as far as inverse kinematics
#: holds it on a position target, so a move to home's position finds home again.
HOME_AXIS_TOL_DEG = float(np.degrees(IK_TOL_MM / AXIS_WEIGHT))


@dataclass(frozen=True)
class ServoLink:
    """The servo that turns one joint: ``id``, ``model`` and its calibration.

    ``calibrated`` says the profile gave the calibration (its homing offset is then
    written into the servo at connect); otherwise the servo's counts are taken as they
    come, 2048 at the joint's zero.
    """

    joint: str
    id: int
    model: ServoModel
    calibration: ServoCalibration
    calibrated: bool = False


@dataclass(frozen=True)
class ArmSpec:
    """Everything the driver and the emulator need besides the kinematic model."""

    name: str
    bus: str
    baud: int
    joints: tuple[ServoLink, ...]
    gripper: ServoLink | None
    grip_closed: float
    grip_open: float

    @property
    def links(self) -> tuple[ServoLink, ...]:
        """The arm's joints' servos, then the gripper's."""
        return self.joints + ((self.gripper,) if self.gripper else ())

    @property
    def ids(self) -> list[int]:
        """Every servo id on the bus, joints first."""
        return [s.id for s in self.links]

    def by_id(self, servo_id: int) -> ServoLink:
        """The servo with ``servo_id``."""
        return next(s for s in self.links if s.id == servo_id)


def urdf_path(config: Mapping[str, Any]) -> Path:
    """The URDF file ``arm.urdf`` names: a path, or the name of a shipped one (so101.urdf)."""
    name = config.get("urdf")
    if not isinstance(name, str) or not name:
        raise ConfigError("arm.urdf: give the arm's URDF file (e.g. so101.urdf, or a path)")
    found = resolve(name, "profile")
    if found is None:
        raise ConfigError(
            f"arm.urdf: no URDF file {shown(name)} in the working directory or among the "
            "shipped ones (so101.urdf, koch.urdf)"
        )
    return found


def arm_spec(config: Mapping[str, Any]) -> ArmSpec:
    """The checked servos of ``config`` (an ``arm:`` section with its defaults)."""
    bus = str(config.get("bus", ""))
    servos = config.get("servos")
    if not isinstance(servos, Mapping) or not servos:
        raise ConfigError("arm.servos: give each joint's servo, {JOINT: {id, model}}")
    calibration = config.get("calibration") or {}
    if not isinstance(calibration, Mapping):
        raise ConfigError(
            f"arm.calibration: expected {{JOINT: {{id, ...}}}}, got {shown(calibration)}"
        )
    joints = tuple(
        _link(str(joint), entry, bus, calibration, f"arm.servos.{joint}")
        for joint, entry in servos.items()
    )
    gripper = None
    grip = config.get("gripper")
    if grip is not None:
        if not isinstance(grip, Mapping):
            raise ConfigError(
                f"arm.gripper: expected {{id, model, closed, open}}, got {shown(grip)}"
            )
        gripper = _link(str(grip.get("joint", "gripper")), grip, bus, calibration, "arm.gripper")
    links = joints + ((gripper,) if gripper else ())
    seen: dict[int, str] = {}
    for link, where in zip(
        links, [f"arm.servos.{j.joint}" for j in joints] + ["arm.gripper"], strict=False
    ):
        if link.id in seen:
            raise ConfigError(
                f"{where}.id: servo id {link.id} is given twice ({seen[link.id]} and "
                f"{link.joint}): each servo on a bus has its own id"
            )
        seen[link.id] = link.joint
    known = {s.joint for s in links}
    for joint in calibration:
        if joint not in known:
            raise ConfigError(
                f"arm.calibration.{joint}: no servo turns a joint {joint!r} "
                f"(the arm's: {', '.join(sorted(known))})"
            )
    baud = config.get("baud", 1_000_000)
    for link in links:
        if baud not in link.model.bauds:
            rates = ", ".join(f"{b:,}" for b in sorted(link.model.bauds))
            raise ConfigError(
                f"arm.baud: {link.model.name} servos (id {link.id}) do not run at {baud:,} baud "
                f"(they take {rates})"
            )
    closed, opened = _grip_angles(grip)
    return ArmSpec(
        str(config.get("name") or config.get("type") or "bus_servo"),
        bus,
        int(baud),
        joints,
        gripper,
        closed,
        opened,
    )


def _link(
    joint: str, entry: Any, bus: str, calibration: Mapping[str, Any], where: str
) -> ServoLink:
    if not isinstance(entry, Mapping):
        raise ConfigError(f"{where}: expected {{id, model}}, got {shown(entry)}")
    allowed = {"id", "model", "direction", "joint", "closed", "open"}
    unknown = sorted(set(entry) - allowed)
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown key (known: id, model, direction)")
    servo_id = entry.get("id")
    if isinstance(servo_id, bool) or not isinstance(servo_id, int) or not 0 <= servo_id <= MAX_ID:
        raise ConfigError(f"{where}.id: expected a servo id 0-{MAX_ID}, got {shown(servo_id)}")
    name = str(entry.get("model", "")).lower()
    model = MODELS.get(name)
    if model is None:
        raise ConfigError(
            f"{where}.model: unknown servo model {shown(name)} (known: {', '.join(MODELS)})"
        )
    if model.protocol != bus:
        raise ConfigError(
            f"{where}.model: {model.name} speaks {model.protocol}, not the bus's {bus}"
        )
    direction = entry.get("direction", 1)
    if direction not in (1, -1):
        raise ConfigError(f"{where}.direction: 1 (the servo turns with the joint) or -1")
    cal = ServoCalibration(servo_id, drive_mode=0 if direction == 1 else 1)
    given = joint in calibration
    if given:
        cal = parse_calibration(calibration[joint], f"arm.calibration.{joint}")
        if cal.id != servo_id:
            raise ConfigError(
                f"arm.calibration.{joint}.id: the calibration is of servo {cal.id}, but "
                f"{joint}'s servo is {servo_id}: calibrate this arm (armtree calibrate servos)"
            )
        reg = model.register("homing_offset")
        limit = (1 << reg.encoding) - 1 if reg.encoding and reg.encoding > 0 else 1 << 20
        if abs(cal.homing_offset) > limit:
            raise ConfigError(
                f"arm.calibration.{joint}.homing_offset: {cal.homing_offset} does not fit the "
                f"{model.name}'s register (at most +-{limit})"
            )
    return ServoLink(joint, servo_id, model, cal, given)


def _grip_angles(grip: Any) -> tuple[float, float]:
    if not isinstance(grip, Mapping):
        return 0.0, 45.0
    out = []
    for key, default in (("closed", 0.0), ("open", 45.0)):
        value = grip.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(
                f"arm.gripper.{key}: expected an angle in degrees, got {shown(value)}"
            )
        out.append(float(value))
    return out[0], out[1]


def arm_model(config: Mapping[str, Any]) -> UrdfModel:
    """The arm's URDF model, joint limits cut to the calibrated ranges; ConfigError when the
    URDF, its joints and the servos do not agree."""
    spec = arm_spec(config)
    path = urdf_path(config)
    stat = path.stat()
    axis = config.get("tool_axis")
    home = config.get("home")
    model = _load(
        str(path),
        stat.st_mtime_ns,
        stat.st_size,
        str(config.get("tool_link", "tcp")),
        config.get("base_link"),
        None if axis is None else tuple(float(v) for v in axis),
        float(config.get("max_accel", 300.0)),
    )
    names = [j.name for j in model.joints]
    wanted = [s.joint for s in spec.joints]
    if sorted(names) != sorted(wanted):
        missing = [n for n in names if n not in wanted]
        extra = [n for n in wanted if n not in names]
        what = (
            f"joint {extra[0]!r} is not on the URDF's chain"
            if extra
            else f"the URDF's joint {missing[0]!r} has no servo"
        )
        raise ConfigError(f"arm.servos: {what} (the chain's joints: {', '.join(names)})")
    by_joint = {s.joint: s for s in spec.joints}
    joints = []
    for joint in model.joints:
        link = by_joint[joint.name]
        lo, hi = joint.lower, joint.upper
        if link.calibrated:
            clo, chi = link.calibration.limits()
            lo, hi = max(lo, clo), min(hi, chi)
            if not lo < hi:
                raise ConfigError(
                    f"arm.calibration.{joint.name}: its range [{clo:.1f}, {chi:.1f}] deg misses "
                    f"the URDF's limits [{joint.lower:.1f}, {joint.upper:.1f}]"
                )
        joints.append(replace(joint, lower=lo, upper=hi))
    if home is None and model.tool_axis is not None:
        # a URDF says nothing of where the arm rests; the zero pose rarely holds the tool
        # along tool_axis, and every run starts and ends at home
        raise ConfigError(
            f"arm.home: give the home pose, {len(joints)} joint angles (deg) with the tool "
            "along tool_axis (where the arm rests, and every run starts and ends)"
        )
    if home is not None and (not isinstance(home, Sequence) or len(home) != len(joints)):
        raise ConfigError(f"arm.home: give {len(joints)} joint angles (deg), got {shown(home)}")
    built = UrdfModel(
        model.chain,
        joints,
        model.boxes,
        name=spec.name,
        base=model.frame_names[0],
        home=None if home is None else np.asarray(home, dtype=float),
        tool_axis=model.tool_axis,
    )
    if home is not None and built.tool_axis is not None:
        _check_home_axis(built, home)
    return built


def _check_home_axis(model: UrdfModel, home: Sequence[Any]) -> None:
    """Home must hold the tool along ``tool_axis``, as every position target does (else
    no move reaches home's position as home, and the plugin checks fail far from here)."""
    tool_axis = model.tool_axis
    if tool_axis is None:  # no axis to hold the tool along
        return
    z = model.link_frames(np.asarray(home, dtype=float))[-1][:3, 2]
    off = float(np.degrees(np.arccos(np.clip(np.dot(z, tool_axis), -1.0, 1.0))))
    if off > HOME_AXIS_TOL_DEG:
        axis = [round(float(v), 3) + 0.0 for v in tool_axis]
        raise ConfigError(
            f"arm.home: {shown(home)} holds the tool {off:.1f} deg off tool_axis {axis} "
            "(every position target keeps the tool along it): give joint angles that point "
            "the tool link's z along tool_axis"
        )


@functools.lru_cache(maxsize=16)
def _load(
    path: str,
    mtime: int,
    size: int,
    tool_link: str,
    base_link: str | None,
    tool_axis: tuple[float, ...] | None,
    max_accel: float,
) -> UrdfModel:
    """A URDF read once per version of the file and set of keys (yourdfpy takes a while)."""
    try:
        return load_urdf(
            path, tool_link, base_link=base_link, tool_axis=tool_axis, max_accel=max_accel
        )
    except ValueError as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"arm.tool_axis: {exc}") from None
