"""The ``calibration:`` profile section and the calibration files ``armtree calibrate`` writes.

A calibration file is a layer a profile includes (``include: FILE``,
:mod:`armtree.config.profile_include`): the sections a calibration measured, laid over
the profile's nominal values, plus the ``calibration:`` section::

    camera: {extrinsics: [[...], ...]}          # hand-eye, camera offset: the camera's pose
    arm: {tool_offset_mm: 53.4, ...}            # kinematics: the arm's own keys
    calibration:
      vision_correction: {ax: 1.003, bx: -0.4, ay: 0.998, by: 0.7}   # Durovic 2017, eq. 8
      arm_correction: {ax: 0.995, bx: 0.9, ay: 1.001, by: -0.3}
      records:                                  # what each calibration measured (free form)
        hand_eye: {method: ..., residual_rms_mm: ..., poses: 15, date: ...}

``vision_correction`` maps a position measured by vision to where the thing
really is; ``arm_correction`` maps a commanded tool position to where the tool
really goes (x' = a_x x + b_x, y' = a_y y + b_y, z unchanged; mm). The skills
apply both when present (:func:`calibration_of`). Each ``armtree calibrate``
updates the file in place (:func:`update_calibration_file`), keeping what
other calibrations wrote.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from armtree.errors import ConfigError
from armtree.maths.perception.frames import LinearCorrection

from .profile_access import AnyProfile, profile_section
from .spec import Anything, MapOf, Number, Record

#: The coefficients of a linear correction (Durovic 2017, eq. 8).
CORRECTION_KEYS = ("ax", "bx", "ay", "by")
#: A correction's scale must be near 1 and its shift within this (mm): anything else
#: is not a correction of a calibrated rig but a different rig.
MAX_SHIFT_MM = 500.0
SCALE_RANGE = (0.5, 2.0)


@dataclass(frozen=True)
class Calibration:
    """The corrections a profile's ``calibration:`` section holds (None when absent)."""

    vision: LinearCorrection | None = None
    arm: LinearCorrection | None = None

    def seen(self, xyz: Any) -> Any:
        """A vision-measured position (mm) corrected to where the thing is."""
        return xyz if self.vision is None else self.vision.apply(xyz)

    def command_for(self, xyz: Any) -> Any:
        """The tool position (mm) to command so the tool really reaches ``xyz``."""
        return xyz if self.arm is None else self.arm.inverse(xyz)


def _correction_spec(doc: str) -> Record:
    scale = Number(
        minimum=SCALE_RANGE[0],
        maximum=SCALE_RANGE[1],
        wanted=f"a scale within {SCALE_RANGE[0]:g} to {SCALE_RANGE[1]:g}",
    )
    shift = Number(unit="mm", bound=MAX_SHIFT_MM, wanted=f"a shift within +/-{MAX_SHIFT_MM:g} mm")
    return Record(
        {"ax": scale, "bx": shift, "ay": scale, "by": shift},
        required=CORRECTION_KEYS,
        doc=f"{doc} (Durovic 2017, eq. 8: x' = ax x + bx, y' = ay y + by, mm)",
        wanted="{ax: A, bx: B, ay: A, by: B}: x' = ax x + bx, y' = ay y + by (mm)",
    )


#: The ``calibration:`` section, declared once: the loader checks it and the schema shows it.
CALIBRATION = Record(
    {
        "vision_correction": _correction_spec("vision-measured -> true position"),
        "arm_correction": _correction_spec("commanded -> reached tool position"),
        "records": MapOf(Anything(), doc="what each calibration measured", wanted="a mapping"),
    },
    doc="what calibration measured (armtree calibrate writes it into a file a profile includes)",
    wanted="a mapping (vision_correction, arm_correction, records)",
)


def _correction(value: Any) -> LinearCorrection | None:
    if not isinstance(value, Mapping):
        return None
    return LinearCorrection(*(float(value[k]) for k in CORRECTION_KEYS))


def calibration_of(profile: AnyProfile | None) -> Calibration:
    """The :class:`Calibration` of a profile (a :class:`~armtree.loader.profile.Profile` or mapping)."""
    section = profile_section(profile, "calibration") or {}
    if not isinstance(section, Mapping):
        return Calibration()
    return Calibration(
        _correction(section.get("vision_correction")), _correction(section.get("arm_correction"))
    )


def correction_mapping(correction: LinearCorrection) -> dict[str, float]:
    """The ``{ax, bx, ay, by}`` mapping a calibration file holds for ``correction``."""
    return {
        "ax": round(correction.ax, 6),
        "bx": round(correction.bx, 4),
        "ay": round(correction.ay, 6),
        "by": round(correction.by, 4),
    }


def update_calibration_file(
    path: str | Path,
    sections: Mapping[str, Any],
    record: tuple[str, Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """Merge ``sections`` (profile sections, mapping by mapping) and the named ``record``
    into the calibration file at ``path`` (created if absent); return what it now holds.

    What other calibrations wrote stays. A file that is not a calibration file (not a
    mapping of profile sections) is a :class:`ConfigError` naming it.
    """
    path = Path(path)
    data: dict[str, Any] = {}
    if path.exists():
        try:
            data = yaml.safe_load(path.read_text()) or {}
        except (OSError, yaml.YAMLError) as exc:
            raise ConfigError(f"cannot read the calibration file: {exc}", file=str(path)) from None
        if not isinstance(data, dict):
            raise ConfigError("not a calibration file (a mapping of sections)", file=str(path))
    _merge(data, _plain(sections))
    if record is not None:
        name, values = record
        cal = data.setdefault("calibration", {})
        cal.setdefault("records", {})[name] = {
            **_plain(dict(values)),
            "date": _dt.datetime.now().isoformat(timespec="seconds"),
        }
    header = (
        "# Calibration written by 'armtree calibrate': a profile includes it with\n"
        f"#   include: {path.name}\n"
        "# (or run-tree ... --set include=FILE). Its sections are laid over the profile's.\n"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(header + yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
    return data


def _plain(value: Any) -> Any:
    """``value`` with numpy numbers and arrays as plain Python ones (YAML writes those)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist"):
        return _plain(value.tolist())
    return value


def _merge(base: dict[str, Any], layer: Mapping[str, Any]) -> None:
    for key, value in layer.items():
        if isinstance(value, Mapping) and isinstance(base.get(key), dict):
            _merge(base[key], value)
        else:
            base[key] = value


__all__ = [
    "Calibration",
    "CALIBRATION",
    "calibration_of",
    "correction_mapping",
    "update_calibration_file",
]
