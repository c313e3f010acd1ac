"""The profile's ``tags:`` against the marker families: ``armtree check`` and every load.

armtree's own profile check sees the shape of ``tags:`` (ids, sizes,
``family_ids``); what only the trackers know is checked here, each problem at
its file, line and column:

* every ``family_ids`` key names a family (``hamming`` or an ArUco dictionary);
* every id is valid in its family: in range, and for ``hamming`` one whose
  orientation is unique (:func:`.hamming_code.id_problem`, with the hamming
  tracker's ``max_corrected_bits``);
* the ids the profile's tracker will read (a role's ``family_ids`` entry for the
  tracker's family, else its ``id`` / ``ids``) are valid in that family, and an
  error names valid ids near the one given;
* no id is two roles' in one family.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from armtree.errors import ConfigError
from armtree.loader.profile import Profile

from .families import (
    HAMMING,
    MarkerFamily,
    family_named,
    max_corrected_bits,
    tracker_family,
)


@dataclass(frozen=True)
class _Id:
    """One id as a role gives it, and the dotted path it was written at."""

    role: str
    value: int
    path: str


def _listed(role: str, value: Any, path: str) -> list[_Id]:
    if isinstance(value, list):
        return [_Id(role, v, f"{path}.{i}") for i, v in enumerate(value) if _is_id(v)]
    return [_Id(role, value, path)] if _is_id(value) else []


def _is_id(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def tag_problems(profile: Profile) -> list[ConfigError]:
    """Every problem of the profile's ``tags:`` against the marker families (see the module)."""
    if "tags" in profile.invalid:
        return []
    tags = profile.section("tags") or {}
    tracker = profile.section("tracker") if "tracker" not in profile.invalid else None
    reads = tracker_family(tracker)
    corrections = max_corrected_bits(tracker)
    errors: list[ConfigError] = []
    generic: dict[str, list[_Id]] = {}
    per_family: dict[str, dict[str, list[_Id]]] = {}
    families: dict[str, MarkerFamily] = {} if reads is None else {reads.name: reads}
    for role, spec in tags.items():
        if not isinstance(spec, Mapping):
            continue
        role = str(role)
        base = f"tags.{role}"
        generic[role] = (
            _listed(role, spec["id"], f"{base}.id")
            if "id" in spec
            else _listed(role, spec.get("ids"), f"{base}.ids")
        )
        for name, value in (spec.get("family_ids") or {}).items():
            path = f"{base}.family_ids.{name}"
            try:
                family = family_named(str(name))
            except ConfigError as exc:
                errors.append(profile.error(path, str(exc)))
                continue
            if family.name != name:
                errors.append(profile.error(path, f"write the family as {family.name!r}"))
                continue
            families[family.name] = family
            per_family.setdefault(family.name, {})[role] = _listed(role, value, path)
    for family in families.values():
        allowed = corrections if family.name == HAMMING else 0
        read = {
            role: per_family.get(family.name, {}).get(role, ids) for role, ids in generic.items()
        }
        errors += _invalid(profile, family, read, allowed, family == reads)
        errors += _shared(profile, family, read, per_family.get(family.name, {}))
    return errors


def _invalid(
    profile: Profile,
    family: MarkerFamily,
    read: dict[str, list[_Id]],
    corrections: int,
    is_trackers: bool,
) -> list[ConfigError]:
    """Ids of ``family`` it cannot carry: those written for it, and (``is_trackers``) the
    ``id`` / ``ids`` the profile's tracker would read in it."""
    errors = []
    every = {i.value for ids in read.values() for i in ids}
    for ids in read.values():
        for given in ids:
            written_for_it = ".family_ids." in given.path
            if not (written_for_it or is_trackers):
                continue
            message = family.id_error(given.value, corrections, frozenset(every - {given.value}))
            if message is None:
                continue
            if not written_for_it:
                message += (
                    f"; the tracker reads {family.name} markers: give this role its "
                    f"{family.name} ids with tags.{given.role}.family_ids: "
                    + (
                        f"{{{family.name}: [...]}}"
                        if ".ids." in given.path
                        else f"{{{family.name}: N}}"
                    )
                )
            errors.append(profile.error(given.path, message))
    return errors


def _shared(
    profile: Profile,
    family: MarkerFamily,
    read: dict[str, list[_Id]],
    written: dict[str, list[_Id]],
) -> list[ConfigError]:
    """An id two roles have in ``family`` where at least one wrote it for the family (two
    roles sharing a plain ``id`` are armtree's own profile check's to report)."""
    errors = []
    owner: dict[int, _Id] = {}
    for role, ids in read.items():
        for given in ids:
            first = owner.setdefault(given.value, given)
            if first.role == role or not (role in written or first.role in written):
                continue
            errors.append(
                profile.error(
                    given.path,
                    f"{family.name} id {given.value} is both {first.role!r} ({first.path}) and "
                    f"{role!r}: in one family every id has one role",
                )
            )
    return errors


__all__ = ["tag_problems"]
