"""armtree's node types and BehaviorTree.CPP's built-in nodes, where their semantics match.

| armtree | BT.CPP |
| --- | --- |
| ``sequence`` (memory: true, the default) | ``Sequence``: a RUNNING child is ticked again, a failure restarts |
| ``sequence`` memory: false | ``ReactiveSequence``: every tick from the first child |
| ``selector`` (memory: false, the default) | ``ReactiveFallback`` |
| ``selector`` memory: true | ``Fallback`` |
| ``parallel`` success_on_all (synchronised) | ``Parallel`` success_count -1, failure_count 1 |
| ``parallel`` success_on_one | ``Parallel`` success_count 1, failure_count 1 |
| ``inverter`` | ``Inverter`` |
| ``failure_is_success`` / ``success_is_failure`` | ``ForceSuccess`` / ``ForceFailure`` |
| ``retry`` num_failures N (N >= 1) | ``RetryUntilSuccessful`` num_attempts N |
| ``repeat`` num_success N | ``Repeat`` num_cycles N |
| ``timeout`` duration S | ``Timeout`` msec 1000 S |
| ``one_shot`` on_completion | ``RunOnce`` then_skip false |
| ``success`` / ``failure`` | ``AlwaysSuccess`` / ``AlwaysFailure`` |
| ``wait`` seconds S | ``Sleep`` msec 1000 S |

py_trees' memory sequence is BT.CPP's ``Sequence``, not ``SequenceWithMemory``
(which, after a failure, ticks the failed child again instead of restarting): the
names differ, the behaviour is what is matched. Options that have no BT.CPP
counterpart (a parallel that re-ticks children that succeeded, a timeout given as a
blackboard key) keep the node under its armtree name, as a custom node.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .values import REFERENCE

#: BehaviorTree.CPP's model kinds, by armtree node kind.
MODEL_KINDS = {"composite": "Control", "decorator": "Decorator", "leaf": "Action"}

#: BT.CPP built-ins with no armtree counterpart, and why.
UNMATCHED: dict[str, str] = {
    "SequenceWithMemory": "it ticks a failed child again where armtree's sequences restart",
    "ParallelAll": "armtree's parallel fails as soon as one child fails",
    "IfThenElse": "armtree has no if-then-else; use a selector over a sequence",
    "WhileDoElse": "armtree has no while-do-else; use a reactive selector",
    "ManualSelector": "armtree chooses no child by hand",
    "Delay": "armtree has no delaying decorator; put a wait before the child",
    "KeepRunningUntilFailure": "armtree has no such decorator; use repeat num_success -1",
    "Precondition": "BT.CPP scripts are not run by armtree",
    "Script": "BT.CPP scripts are not run by armtree",
    "ScriptCondition": "BT.CPP scripts are not run by armtree",
    "SetBlackboard": "use set_blackboard_variable",
    "UnsetBlackboard": "use unset_blackboard_variable",
    "SubTreePlus": "BT.CPP 3's SubTreePlus is SubTree in BT.CPP 4",
    "LoopInt": "armtree has no loop over a queue; use for_each",
    "LoopDouble": "armtree has no loop over a queue; use for_each",
    "LoopString": "armtree has no loop over a queue; use for_each",
    "LoopBool": "armtree has no loop over a queue; use for_each",
    "SkipUnlessUpdated": "armtree does not track blackboard updates",
    "WaitValueUpdate": "armtree does not track blackboard updates",
    "WasEntryUpdated": "armtree does not track blackboard updates",
    "AlwaysRunning": "use running",
    **{f"Switch{n}": "armtree has no switch; use either_or" for n in range(2, 7)},
}

#: BT.CPP's pre- and post-condition scripts (attributes), which armtree does not run.
SCRIPT_ATTRIBUTES = frozenset(
    {
        "_skipIf",
        "_failureIf",
        "_successIf",
        "_while",
        "_onSuccess",
        "_onFailure",
        "_post",
        "_onHalted",
    }
)

#: armtree's built-in leaves that only check (BT.CPP ``Condition`` nodes).
CONDITIONS = frozenset(
    {
        "check_blackboard_variable_exists",
        "check_blackboard_variable_value",
        "check_blackboard_variable_values",
        "compare_blackboard_variables",
    }
)


@dataclass(frozen=True)
class Builtin:
    """One armtree node type matched to one BehaviorTree.CPP built-in.

    ``export(options)`` gives the BT.CPP ports for armtree ``options`` (values as a
    tree file gives them), or None when the options have no BT.CPP counterpart;
    ``read(ports)`` gives armtree options for BT.CPP ports (strings) and raises
    ``ValueError`` saying why when they have none. ``ports`` are the BT.CPP ports
    the node takes.
    """

    armtree: str
    btcpp: str
    kind: str
    export: Callable[[dict[str, Any]], dict[str, str] | None]
    read: Callable[[dict[str, str]], dict[str, Any]]
    ports: tuple[str, ...] = ()
    #: BT.CPP's model kind (Action, Condition, Control, Decorator).
    model: str = ""


def _flag(options: dict[str, Any], key: str, default: bool) -> bool | None:
    """The boolean option ``key`` (``default`` when absent); None when not a literal bool."""
    value = options.get(key, default)
    return value if isinstance(value, bool) else None


def _only(options: dict[str, Any], *keys: str) -> bool:
    return set(options) <= set(keys)


def _counted(
    option: str, port: str, forever: bool
) -> Callable[[dict[str, Any]], dict[str, str] | None]:
    """armtree's count ``option`` as BT.CPP's ``port``: 1 or more, a ``{param}``
    reference, or -1 (for ever) where both read it so (``forever``)."""

    def export(options: dict[str, Any]) -> dict[str, str] | None:
        value = options.get(option)
        if not _only(options, option):
            return None
        if isinstance(value, str) and REFERENCE.match(value):
            return {port: value}
        # the test written out, not through a variable: mypy narrows only a test it sees
        if (
            isinstance(value, int)
            and not isinstance(value, bool)
            and (value >= 1 or (forever and value == -1))
        ):
            return {port: str(value)}
        return None

    return export


def _msec(value: Any) -> str | None:
    """Seconds as whole milliseconds, None when not a literal number of whole ms."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
        return None
    msec = round(value * 1000)
    return str(msec) if abs(msec - value * 1000) < 1e-6 else None


def _int(ports: dict[str, str], key: str, default: str) -> int | str:
    text = ports.get(key, default).strip()
    if REFERENCE.match(text):
        return text
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"{key}: expected a whole number, got {text!r}") from None


def _sequence(memory: bool) -> Callable[[dict[str, Any]], dict[str, str] | None]:
    return lambda o: {} if _only(o, "memory") and _flag(o, "memory", True) is memory else None


def _selector(memory: bool) -> Callable[[dict[str, Any]], dict[str, str] | None]:
    return lambda o: {} if _only(o, "memory") and _flag(o, "memory", False) is memory else None


def _parallel_export(options: dict[str, Any]) -> dict[str, str] | None:
    if not _only(options, "policy", "synchronise", "memory") or options.get("selected"):
        return None
    sync = [options[k] for k in ("synchronise", "memory") if options.get(k) is not None]
    policy = options.get("policy", "success_on_all")
    if policy == "success_on_all" and all(s is True for s in sync):
        return {"success_count": "-1", "failure_count": "1"}
    if policy == "success_on_one" and all(s is False for s in sync):
        return {"success_count": "1", "failure_count": "1"}
    return None


def _parallel_read(ports: dict[str, str]) -> dict[str, Any]:
    success, failure = _int(ports, "success_count", "-1"), _int(ports, "failure_count", "1")
    if (success, failure) == (-1, 1):
        return {}
    if (success, failure) == (1, 1):
        return {"policy": "success_on_one"}
    raise ValueError(
        f"Parallel success_count={success}, failure_count={failure} has no armtree "
        "counterpart: armtree's parallel fails when one child fails (failure_count 1) "
        "and succeeds when all (-1) or one (1) succeed"
    )


def _retry_read(ports: dict[str, str]) -> dict[str, Any]:
    attempts = _int(ports, "num_attempts", "")
    if isinstance(attempts, int) and attempts < 1:
        raise ValueError(
            f"num_attempts={attempts}: armtree's retry fails after num_failures failures; "
            "give 1 or more attempts"
        )
    return {"num_failures": attempts}


def _msec_read(key: str) -> Callable[[dict[str, str]], dict[str, Any]]:
    def read(ports: dict[str, str]) -> dict[str, Any]:
        msec = _int(ports, "msec", "")
        if isinstance(msec, str):
            raise ValueError(f"msec={msec}: armtree needs the time itself, not a blackboard key")
        return {key: msec / 1000}

    return read


def _run_once_read(ports: dict[str, str]) -> dict[str, Any]:
    if ports.get("then_skip", "true").strip().lower() != "false":
        raise ValueError(
            "RunOnce then_skip=true (the default) returns SKIPPED after the first run, "
            'which armtree has no status for; write then_skip="false" (one_shot)'
        )
    return {}


def _plain(armtree: str, btcpp: str, kind: str, model: str) -> Builtin:
    return Builtin(armtree, btcpp, kind, lambda o: {} if not o else None, lambda p: {}, (), model)


BUILTINS: tuple[Builtin, ...] = (
    Builtin("sequence", "Sequence", "composite", _sequence(True), lambda p: {}, (), "Control"),
    Builtin(
        "sequence",
        "ReactiveSequence",
        "composite",
        _sequence(False),
        lambda p: {"memory": False},
        (),
        "Control",
    ),
    Builtin(
        "selector", "ReactiveFallback", "composite", _selector(False), lambda p: {}, (), "Control"
    ),
    Builtin(
        "selector",
        "Fallback",
        "composite",
        _selector(True),
        lambda p: {"memory": True},
        (),
        "Control",
    ),
    Builtin(
        "parallel",
        "Parallel",
        "composite",
        _parallel_export,
        _parallel_read,
        ("success_count", "failure_count"),
        "Control",
    ),
    _plain("inverter", "Inverter", "decorator", "Decorator"),
    _plain("failure_is_success", "ForceSuccess", "decorator", "Decorator"),
    _plain("success_is_failure", "ForceFailure", "decorator", "Decorator"),
    Builtin(
        "retry",
        "RetryUntilSuccessful",
        "decorator",
        _counted("num_failures", "num_attempts", forever=False),
        _retry_read,
        ("num_attempts",),
        "Decorator",
    ),
    Builtin(
        "repeat",
        "Repeat",
        "decorator",
        _counted("num_success", "num_cycles", forever=True),
        lambda p: {"num_success": _int(p, "num_cycles", "")},
        ("num_cycles",),
        "Decorator",
    ),
    Builtin(
        "timeout",
        "Timeout",
        "decorator",
        lambda o: (
            {"msec": m}
            if _only(o, "duration") and (m := _msec(o.get("duration", 5.0))) is not None
            else None
        ),
        _msec_read("duration"),
        ("msec",),
        "Decorator",
    ),
    Builtin(
        "one_shot",
        "RunOnce",
        "decorator",
        lambda o: (
            {"then_skip": "false"}
            if _only(o, "policy") and o.get("policy", "on_completion") == "on_completion"
            else None
        ),
        _run_once_read,
        ("then_skip",),
        "Decorator",
    ),
    _plain("success", "AlwaysSuccess", "leaf", "Action"),
    _plain("failure", "AlwaysFailure", "leaf", "Action"),
    Builtin(
        "wait",
        "Sleep",
        "leaf",
        lambda o: (
            {"msec": m}
            if _only(o, "seconds") and (m := _msec(o.get("seconds"))) is not None
            else None
        ),
        _msec_read("seconds"),
        ("msec",),
        "Action",
    ),
)

#: BT.CPP's built-in by ID.
BY_BTCPP: dict[str, Builtin] = {b.btcpp: b for b in BUILTINS}

#: The IDs of BT.CPP's own nodes, which a ``<BehaviorTree ID>`` may not take (BT.CPP
#: refuses a tree named like a registered node).
BTCPP_NODE_IDS = frozenset(BY_BTCPP) | frozenset(UNMATCHED) | {"SubTree"}


def exported(ntype: str, options: dict[str, Any]) -> tuple[str, dict[str, str]] | None:
    """The BT.CPP built-in and its ports for an armtree node, or None (a custom node)."""
    for builtin in BUILTINS:
        if builtin.armtree == ntype:
            ports = builtin.export(options)
            if ports is not None:
                return builtin.btcpp, ports
    return None
