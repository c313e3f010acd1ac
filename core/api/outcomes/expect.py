"""A tree's ``expect:`` list: read and checked at load time, judged at the end of a run.

::

    expect:
      - {object: ducky, on: duckybot}          # at least one body named / of role ducky
      - {objects: trash, in: garbage_bin}      # every trash body
      - {object: ducky, at: ducky_spot, within_mm: 20}
      - {held: nothing}
      - {collisions: 0}

Each entry names exactly one predicate (see :mod:`.predicates`); names are
checked against the profile's world while the tree loads (an unknown body or
place is a :class:`ConfigError` at its line and column). At the end of a run
every expectation is judged on the world's ground truth, or reported as not
checked when there is none (real hardware), and the run gets a verdict:
``success``, ``failure``, ``false success`` (the tree said SUCCESS, the world
disagrees) or ``false failure`` (the tree said FAILURE, every expectation holds).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from armtree.config.yamlio import MarkedDict, MarkedList, error_at
from armtree.errors import ConfigError, Mark, did_you_mean

from ..views import ComponentLookup
from .predicates import BUILTIN_PREDICATES, Expectation, Predicate
from .truth import WorldObject, WorldTruth

#: Keys that name what an entry is about: at least one of, or every one of.
SUBJECT_KEYS = ("object", "objects")

PASS, FAIL, NOT_CHECKED = "pass", "fail", "not checked"


@dataclass(frozen=True)
class ExpectationResult:
    """How one expectation came out: ``status`` is ``pass``, ``fail`` or ``not checked``;
    ``measured`` the value found (JSON-safe); ``detail`` a few words about it."""

    expect: str
    status: str
    measured: Any = None
    detail: str = ""
    entry: Mapping[str, Any] = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        """True when the world disagrees with the expectation."""
        return self.status == FAIL

    def to_dict(self) -> dict[str, Any]:
        """The record written to the run log and sweep reports."""
        return {
            "expect": self.expect,
            "status": self.status,
            "measured": self.measured,
            "detail": self.detail,
            "entry": dict(self.entry),
        }


def predicates_for(registry: ComponentLookup | None) -> dict[str, Predicate]:
    """The built-in predicates and those the plugins of ``registry`` register
    (``armtree_predicates``); only the built-in ones without it.

    A plugin may not take a built-in predicate's name.
    """
    found: dict[str, Predicate] = dict(BUILTIN_PREDICATES)
    if registry is not None:
        found.update(registry.instances("predicate", (*BUILTIN_PREDICATES, *SUBJECT_KEYS)))
    return found


def parse_expectations(
    value: Any,
    mark: Mark | None,
    file: str | None,
    world: WorldTruth | None,
    predicates: Mapping[str, Predicate],
) -> tuple[list[Expectation], list[ConfigError]]:
    """Read an ``expect:`` list; every problem is a ConfigError at its position.

    ``world`` is the nominal world (or an inventory of names) the names are
    checked against; None skips name checks (a tree without a rig).
    """
    errors: list[ConfigError] = []
    if value is None:
        return [], errors
    if not isinstance(value, MarkedList):
        errors.append(
            error_at(
                "expect: expected a list of expectations, e.g. - {object: ducky, on: duckybot}",
                mark,
                file,
            )
        )
        return [], errors
    out = []
    for i, entry in enumerate(value):
        expectation = _parse_entry(
            entry, value.item_mark(i) or mark, file, world, predicates, errors
        )
        if expectation is not None:
            out.append(expectation)
    return out, errors


def _parse_entry(
    entry: Any,
    mark: Mark | None,
    file: str | None,
    world: WorldTruth | None,
    predicates: Mapping[str, Predicate],
    errors: list[ConfigError],
) -> Expectation | None:
    names = ", ".join(sorted(predicates))
    if isinstance(entry, MarkedDict) and True in entry:
        entry = _on_as_text(entry)
    if not isinstance(entry, MarkedDict):
        errors.append(
            error_at(
                f"an expectation is a mapping such as {{object: ducky, on: duckybot}} naming "
                f"one of: {names}; got {entry!r}",
                getattr(entry, "mark", None) or mark,
                file,
            )
        )
        return None
    keys = [k for k in entry if k in predicates]
    if len(keys) != 1:
        what = "names no predicate" if not keys else f"names {len(keys)} predicates ({keys})"
        errors.append(
            error_at(f"this expectation {what}; write exactly one of: {names}", entry.mark, file)
        )
        return None
    key = keys[0]
    predicate = predicates[key]
    before = len(errors)
    subjects = [k for k in SUBJECT_KEYS if k in entry]
    if len(subjects) > 1:
        errors.append(
            error_at(
                "write object: (at least one) or objects: (every one), not both",
                entry.key_mark("objects"),
                file,
            )
        )
    if predicate.SUBJECT == "required" and not subjects:
        errors.append(
            error_at(
                f"{key}: say what it is about with object: NAME or objects: NAME", entry.mark, file
            )
        )
    if predicate.SUBJECT == "none" and subjects:
        errors.append(
            error_at(
                f"{key} is about the whole run; it takes no {subjects[0]}:",
                entry.key_mark(subjects[0]),
                file,
            )
        )
    allowed = (key, *SUBJECT_KEYS, *predicate.OPTIONS)
    for k in entry:
        if k not in allowed:
            errors.append(
                error_at(
                    f"{key} has no option {k!r}{did_you_mean(str(k), allowed)}",
                    entry.key_mark(k),
                    file,
                )
            )
    subject: tuple[str, ...] = ()
    if subjects:
        raw = entry[subjects[0]]
        refs = list(raw) if isinstance(raw, list) else [raw]
        if not refs or not all(isinstance(r, str) and r for r in refs):
            errors.append(
                error_at(
                    f"{subjects[0]}: expected a body's name or a tag role (or a list of them), got {raw!r}",
                    entry.value_mark(subjects[0]),
                    file,
                )
            )
        else:
            subject = tuple(refs)
            if world is not None:
                for ref in subject:
                    if not world.knows(ref):
                        errors.append(
                            error_at(
                                f"no body or tag role {ref!r} in this world"
                                f"{did_you_mean(ref, world.names())}",
                                entry.value_mark(subjects[0]),
                                file,
                            )
                        )
    options = {**predicate.DEFAULTS, **{k: entry[k] for k in predicate.OPTIONS if k in entry}}
    expectation = Expectation(
        predicate=key,
        value=entry[key],
        subject=subject,
        every=subjects[:1] == ["objects"],
        options=options,
        written=_plain(entry),
        mark=entry.mark or mark,
    )
    if world is not None and len(errors) == before:
        for problem_key, message in predicate.check(expectation, world):
            where = entry.value_mark(problem_key) if problem_key in entry else entry.mark
            errors.append(error_at(message, where, file))
    return expectation if len(errors) == before else None


def judge(
    expectations: Sequence[Expectation],
    world: WorldTruth | None,
    predicates: Mapping[str, Predicate],
) -> list[ExpectationResult]:
    """Judge every expectation on ``world`` (None: every one is not checked)."""
    results = []
    for expectation in expectations:
        text = expectation.text(predicates)
        entry = expectation.written
        predicate = predicates.get(expectation.predicate)
        if world is None or predicate is None:
            why = "no ground truth on this rig" if world is None else "no such predicate"
            results.append(ExpectationResult(text, NOT_CHECKED, None, why, entry))
            continue
        try:
            results.append(_judge_one(expectation, predicate, world, text))
        except Exception as exc:  # noqa: BLE001 - a broken predicate reports itself, the run goes on
            results.append(
                ExpectationResult(
                    text, NOT_CHECKED, None, f"predicate raised {type(exc).__name__}: {exc}", entry
                )
            )
    return results


def _judge_one(
    expectation: Expectation, predicate: Predicate, world: WorldTruth, text: str
) -> ExpectationResult:
    entry = expectation.written
    if not expectation.subject:
        j = predicate.judge(expectation, None, world)
        return ExpectationResult(text, PASS if j.passed else FAIL, j.measured, j.detail, entry)
    objects: list[WorldObject] = []
    for ref in expectation.subject:
        objects += [o for o in world.select(ref) if o not in objects]
    if not objects:
        if expectation.every:
            return ExpectationResult(text, PASS, [], "none in this world", entry)
        return ExpectationResult(text, FAIL, None, "none in this world", entry)
    judged = [(o, predicate.judge(expectation, o, world)) for o in objects]
    passed = [j for _, j in judged if j.passed]
    if expectation.every:
        ok = len(passed) == len(judged)
        bad = [j.detail for _, j in judged if not j.passed]
        detail = f"{len(passed)} of {len(judged)}" + (f": {'; '.join(bad)}" if bad else "")
        measured = {o.name: j.measured for o, j in judged}
        return ExpectationResult(text, PASS if ok else FAIL, measured, detail, entry)
    best = passed[0] if passed else judged[0][1]
    detail = best.detail
    if not passed and len(judged) > 1:
        detail = "; ".join(j.detail for _, j in judged)
    return ExpectationResult(text, PASS if passed else FAIL, best.measured, detail, entry)


def verdict(status: str, results: Sequence[ExpectationResult]) -> str:
    """``success``, ``failure``, ``false success``, ``false failure`` or ``interrupted``.

    A false failure needs at least one checked expectation: with none, a
    FAILURE is just a failure.
    """
    failed = any(r.failed for r in results)
    checked = any(r.status != NOT_CHECKED for r in results)
    if status == "SUCCESS":
        return "false success" if failed else "success"
    if status == "FAILURE":
        return "false failure" if checked and not failed else "failure"
    return "interrupted"


def _on_as_text(entry: MarkedDict) -> MarkedDict:
    """The entry with the key ``on`` as text: YAML 1.1 reads a bare ``on`` as True."""
    out = MarkedDict(mark=entry.mark)
    for key, value in entry.items():
        name = "on" if key is True else key
        out[name] = value
        if key in entry.key_marks:
            out.key_marks[name] = entry.key_marks[key]
        if key in entry.value_marks:
            out.value_marks[name] = entry.value_marks[key]
    return out


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value
