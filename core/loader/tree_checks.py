"""Checks of a tree against the rig it will run on, before anything moves.

The loader calls :class:`RigChecks` for every node it builds when the tree has a
profile: what a run would otherwise fail on after the arm has started moving is
found here, with the tree's (or the profile's) file, line and column:

* a parameter declared ``kind="place"`` names a place the profile has, or is an
  ``[x, y, z]`` position the arm reaches; a place out of reach is reported at the
  profile's line for it;
* ``kind="tag_role"``: a role in the profile's ``tags:``;
* ``kind="position"``: an ``[x, y, z]`` the arm reaches;
* a string that looks like a blackboard binding but names no key (``"{}"``);
* a behaviour's ``NEEDS`` (``"camera"``: a camera and a tracker) and a ``"tool"``
  among its ``RESOURCES`` (an arm that grips with something) are on the rig, and the
  ``workcell:`` keys in its ``WORKCELL`` (a sweep's ``survey``), or those its
  ``workcell_for(params)`` names for the parameters the tree gives it, are in the profile.

Reach is judged with the arm's kinematic model (``factory.model(config)``, which
opens no port): some inverse-kinematics solution within the joint limits.
Units: mm.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from armtree.config.workcell import workcell_of
from armtree.config.yamlio import error_at
from armtree.errors import ConfigError, Mark, did_you_mean, shown

from .profile import Profile, arm_grips

#: A string that is written like a ``{key}`` binding, whatever is between the braces.
LOOKS_BOUND = re.compile(r"^\s*\{.*\}\s*$", re.S)


class RigChecks:
    """Resolves one tree's names and positions against its profile; see the module docstring."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.places: dict[str, list[float]] = profile.places()
        self.tags: set[str] = set(profile.tags())
        self._model: Any = None
        self._model_built = False
        # None caches "no model can judge" too, so the reach is asked once per place.
        self._place_reach: dict[str, bool | None] = {}
        self._workcell = workcell_of(profile)

    # ------------------------------------------------------------------ values

    def value(self, where: str, kind: str, value: Any, mark: Mark | None) -> list[ConfigError]:
        """Errors of one parameter value of ``kind`` (``where`` is ``"pick.from"``)."""
        if kind == "tag_role":
            return self._role(where, value, mark)
        if kind == "place":
            if isinstance(value, str):
                return self._place(where, value, mark)
            if isinstance(value, dict) and "position" in value:
                value = value["position"]
            return self._position(where, value, mark) if _is_xyz(value) else []
        if kind == "position":
            return self._position(where, value, mark) if _is_xyz(value) else []
        return []

    def unbound(self, where: str, value: Any, mark: Mark | None) -> list[ConfigError]:
        """A ``"{...}"`` string that is no binding (``"{}"``, ``"{ key }"``, ``"{1x}"``)."""
        if isinstance(value, str) and LOOKS_BOUND.match(value):
            return [
                error_at(
                    f"{where}: {shown(value)} is written like a blackboard binding but names no "
                    "key; write {key} with a name of letters, digits and _ (e.g. {duckybot_pose})",
                    mark,
                )
            ]
        return []

    def _role(self, where: str, value: Any, mark: Mark | None) -> list[ConfigError]:
        if not isinstance(value, str) or not value or value in self.tags:
            return []
        hint = did_you_mean(value, self.tags) if self.tags else "; it has no tags: section"
        return [
            error_at(
                f"{where}: unknown tag role {shown(value)} in the profile {self.profile.name}"
                f"{hint}",
                mark,
            )
        ]

    def _place(self, where: str, name: str, mark: Mark | None) -> list[ConfigError]:
        if name not in self.places:
            hint = did_you_mean(name, self.places) if self.places else "; it has no places:"
            bound = "; this {...} names no blackboard key" if LOOKS_BOUND.match(name) else ""
            return [
                error_at(
                    f"{where}: unknown place {shown(name)} in the profile {self.profile.name}"
                    f"{hint}{bound} (give a place, [x, y, z] in mm or a {{key}})",
                    mark,
                )
            ]
        if name in self._place_reach:
            return []
        fine = self._reaches(self.places[name])
        self._place_reach[name] = fine
        if fine is not False:
            return []
        used = f" (used by {where} at {mark})" if mark is not None else ""
        return [
            self.profile.error(
                f"places.{name}",
                f"{np.round(self.places[name], 1).tolist()} mm is out of the arm's reach{used}",
            )
        ]

    def _position(self, where: str, xyz: Any, mark: Mark | None) -> list[ConfigError]:
        if self._reaches(xyz) is not False:
            return []
        return [
            error_at(
                f"{where}: {np.round(np.asarray(xyz, dtype=float), 1).tolist()} mm is out of "
                f"the reach of the profile's arm ({self._arm_type()})",
                mark,
            )
        ]

    # ---------------------------------------------------------------- the rig

    def needs(
        self,
        ntype: str,
        needs: Sequence[str],
        resources: Sequence[str],
        mark: Mark | None,
        workcell: Sequence[str] = (),
    ) -> list[ConfigError]:
        """Errors for rig parts a behaviour cannot run without that the profile lacks, and
        for ``workcell:`` keys it needs (its ``WORKCELL``) that the profile leaves out."""
        out = []
        profile = self.profile
        for part in needs:
            if part == "camera" and profile.section("camera") is None:
                out.append(
                    error_at(
                        f"{ntype} needs a camera, but the profile {profile.name} has none "
                        f"(add a camera: section, or use a rig with one)",
                        mark,
                    )
                )
            elif part == "camera" and profile.section("tracker") is None:
                out.append(
                    error_at(
                        f"{ntype} reads markers, but the profile {profile.name} has no tracker "
                        "(add tracker: {type: aruco})",
                        mark,
                    )
                )
            elif part in ("planner", "arm") and profile.section(part) is None:
                out.append(
                    error_at(
                        f"{ntype} needs a {part}, but the profile {profile.name} has none", mark
                    )
                )
        for key in workcell:
            try:
                self._workcell.need(key, ntype)
            except ConfigError as exc:
                out.append(error_at(exc.message, mark))
        if "tool" in resources and self._grips_with() is None:
            out.append(
                error_at(
                    f"{ntype} needs a tool to hold things, but the profile's arm "
                    f"({self._arm_type()}) has no suction cup or gripper configured",
                    mark,
                )
            )
        return out

    def _arm_type(self) -> str:
        return str((self.profile.section("arm") or {}).get("type", "arm"))

    def _factory(self) -> Any:
        arm = self.profile.section("arm")
        manager = self.profile.manager
        if arm is None or manager is None or not manager.registry.has("arm", arm.get("type", "")):
            return None
        return manager.registry.get("arm", arm["type"]).factory

    def _grips_with(self) -> str | bool | None:
        """What the arm holds things with; True when the arm plugin does not say."""
        manager = self.profile.manager
        if manager is None or self.profile.section("arm") is None:
            return True
        return arm_grips(manager.registry, self.profile)

    def _reaches(self, xyz: Any) -> bool | None:
        """True/False when the arm's model says; None when no model can judge."""
        model = self._arm_model()
        if model is None:
            return None
        point = np.asarray(xyz, dtype=float).reshape(1, 3)
        try:
            solutions = model.ik_all(point)
        except (ValueError, ArithmeticError):
            return None
        return bool(np.any(np.all(np.isfinite(solutions), axis=-1)))

    def _arm_model(self) -> Any:
        if not self._model_built:
            self._model_built = True
            make = getattr(self._factory(), "model", None)
            if callable(make):
                try:
                    self._model = make(self.profile.component("arm") or {})
                except (ConfigError, ValueError, TypeError, KeyError):
                    self._model = None  # the profile's checks report why
        return self._model


def _is_xyz(value: Any) -> bool:
    return (
        isinstance(value, (list, tuple))
        and len(value) == 3
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    )
