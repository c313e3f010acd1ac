"""Built-in plugin: every py_trees behaviour, composite and decorator under its snake_case name.

Registered through :func:`armtree_behaviours` exactly as an external plugin
registers its own. Each node type is a :class:`NodeType` adapter: a declared
parameter list (validated by the loader before anything is built) and a small
function that builds the py_trees object from the validated values.

Timers follow the run's clock, not wall time: ``timeout``, ``timer`` and ``wait``
read the clock the runtime hands every behaviour in ``setup(clock=...)`` (py_trees'
own use :func:`time.monotonic`), so virtual-time runs are deterministic. Without
a clock (a tree ticked by hand) they fall back to :func:`time.monotonic`.

Composite defaults: ``sequence`` has ``memory: true`` (a finished step is not
re-run while a later one is RUNNING); ``selector`` has ``memory: false`` (it
re-checks higher-priority children every tick, so a reactive branch can preempt
a running one); ``parallel`` has ``policy: success_on_all``. A parallel's
``memory`` is py_trees' ``synchronise``: children that have succeeded are not
ticked again until the policy is met.
"""

from __future__ import annotations

import operator
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import py_trees
from py_trees import behaviours as pb
from py_trees import common
from py_trees import decorators as pd

from armtree.api.behaviour import Behaviour
from armtree.api.factories import COMPOSITE, DECORATOR, LEAF
from armtree.config.params import Param

from .hookspecs import hookimpl

#: Comparison operators a tree may name.
OPERATORS: dict[str, Callable[[Any, Any], bool]] = {
    "eq": operator.eq,
    "ne": operator.ne,
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
}
#: Logical operators combining several checks.
LOGICAL: dict[str, Callable[[bool, bool], bool]] = {
    "and": operator.and_,
    "or": operator.or_,
    "xor": operator.xor,
}
STATUS = {s.name: s for s in common.Status}


@dataclass(frozen=True)
class NodeType:
    """A node type the loader can build: parameters, kind and a builder.

    ``build(name, **params)`` receives validated parameters (plus ``child=`` for
    a decorator, ``children=`` for a composite) and returns a py_trees behaviour;
    it raises ``ValueError`` for a combination of values the declarations cannot
    express, and the loader reports that at the node. ``writes`` names parameters
    whose value is the name of a blackboard key the node writes, ``reads`` those
    naming a key it reads (a list of ``{variable_name: KEY, ...}`` mappings names
    one key per item). These adapters
    take literal values only (``bindable`` is False): py_trees' classes cannot
    read a ``"{key}"`` binding.
    """

    KIND: str
    build: Callable[..., py_trees.behaviour.Behaviour]
    PARAMS: tuple[Param, ...]
    doc: str
    writes: tuple[str, ...] = ()
    bindable: bool = False
    reads: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        # Listings read a factory's docstring; an adapter's is its own description.
        object.__setattr__(self, "__doc__", self.doc)

    def __call__(self, name: str, **params: Any) -> py_trees.behaviour.Behaviour:
        """Build the py_trees behaviour called ``name``."""
        return self.build(name, **params)


class _ClockMixin:
    """Reads the run's clock handed over in ``setup(clock=...)``; wall time without one."""

    clock: Any = None

    def setup(self, **kwargs: Any) -> None:
        self.clock = kwargs.get("clock", self.clock)
        super().setup(**kwargs)  # type: ignore[misc]

    def _now(self) -> float:
        return self.clock.now() if self.clock is not None else time.monotonic()


class Timeout(_ClockMixin, pd.Decorator):
    """Fail and halt the child if it is still RUNNING ``duration`` seconds (run's clock) after it started."""

    PARAMS = (Param("duration", "float", 5.0, unit="s", doc="time allowed to the child"),)

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, duration: float = 5.0):
        super().__init__(name=name, child=child)
        self.duration = float(duration)
        self.finish_time = 0.0

    def initialise(self) -> None:
        """Start the countdown on entering RUNNING."""
        self.finish_time = self._now() + self.duration
        self.feedback_message = ""

    def update(self) -> common.Status:
        """Reflect the child, or halt it and fail once the time is up."""
        now = self._now()
        if self.decorated.status == common.Status.RUNNING and now >= self.finish_time:
            self.feedback_message = f"timed out after {self.duration:g} s"
            self.decorated.stop(common.Status.INVALID)
            return common.Status.FAILURE
        if self.decorated.status == common.Status.RUNNING:
            self.feedback_message = f"{self.finish_time - now:.2f} s left"
        return self.decorated.status


class Wait(_ClockMixin, Behaviour):
    """RUNNING until ``seconds`` have passed on the run's clock since it started, then SUCCESS."""

    PARAMS = (Param("seconds", "float", unit="s", doc="how long to wait", minimum=0.0),)
    _param_name = "seconds"

    def __init__(self, name: str, **params: Any) -> None:
        super().__init__(name, **params)
        self.finish_time = 0.0

    def initialise(self) -> None:
        """Start the countdown; a bound duration is read from the blackboard now."""
        duration = float(self.param(self._param_name))
        if duration < 0:
            raise ValueError(f"{self.name}: cannot wait {duration:g} s")
        self.finish_time = self._now() + duration

    def update(self) -> common.Status:
        """SUCCESS once the time is up, else RUNNING."""
        if self._now() >= self.finish_time:
            return common.Status.SUCCESS
        return common.Status.RUNNING


class Timer(Wait):
    """py_trees' Timer on the run's clock: RUNNING for ``duration`` seconds, then SUCCESS."""

    PARAMS = (Param("duration", "float", 5.0, unit="s", doc="how long to run", minimum=0.0),)
    _param_name = "duration"


# ---------------------------------------------------------------------------
# Builders for the py_trees classes whose arguments are not plain values.
# ---------------------------------------------------------------------------


def _status(value: Any, what: str) -> common.Status:
    if value not in STATUS:
        raise ValueError(f"{what}: expected one of {', '.join(STATUS)}, got {value!r}")
    return STATUS[value]


def _comparison(variable_name: str, value: Any, op: str) -> common.ComparisonExpression:
    return common.ComparisonExpression(variable=variable_name, value=value, operator=OPERATORS[op])


def _status_queue(name: str, queue: list, eventually: Any) -> py_trees.behaviour.Behaviour:
    statuses = [_status(v, "queue") for v in queue]
    final = None if eventually is None else _status(eventually, "eventually")
    return pb.StatusQueue(name=name, queue=statuses, eventually=final)


def _check_values(
    name: str, checks: list, logical_operator: str, namespace: str | None
) -> py_trees.behaviour.Behaviour:
    if len(checks) < 2:
        raise ValueError(f"checks: give at least two, got {len(checks)}")
    return pb.CheckBlackboardVariableValues(
        name=name,
        checks=_checks(checks, "checks"),
        operator=LOGICAL[logical_operator],
        namespace=namespace,
    )


def _probabilistic(name: str, weights: list[float] | None) -> py_trees.behaviour.Behaviour:
    if weights is not None and (len(weights) != 3 or min(weights) < 0 or sum(weights) <= 0):
        raise ValueError(
            "weights: give three non-negative numbers for SUCCESS, FAILURE, RUNNING, "
            f"not all zero; got {weights!r}"
        )
    return pb.ProbabilisticBehaviour(name=name, weights=list(weights) if weights else None)


def _eternal_guard(
    name: str, child: py_trees.behaviour.Behaviour, variable_name: str, value: Any, operator: str
) -> py_trees.behaviour.Behaviour:
    compare = OPERATORS[operator]
    key = variable_name.lstrip("/").split(".")[0]

    def condition(blackboard: Any) -> bool:
        try:
            return bool(compare(blackboard.get(variable_name), value))
        except KeyError:
            return False

    return pd.EternalGuard(name=name, child=child, condition=condition, blackboard_keys=[key])


def _parallel(
    name: str,
    children: list,
    policy: str,
    synchronise: bool | None,
    memory: bool | None,
    selected: list[str] | None,
) -> py_trees.behaviour.Behaviour:
    if synchronise is not None and memory is not None:
        raise ValueError("give memory or synchronise, not both (they mean the same for a parallel)")
    sync = synchronise if synchronise is not None else memory
    if policy == "success_on_one":
        if sync:
            raise ValueError("policy success_on_one cannot synchronise (memory)")
        if selected is not None:
            raise ValueError("selected is only for policy success_on_selected")
        pol: common.ParallelPolicy.Base = common.ParallelPolicy.SuccessOnOne()
    elif policy == "success_on_all":
        if selected is not None:
            raise ValueError("selected is only for policy success_on_selected")
        pol = common.ParallelPolicy.SuccessOnAll(synchronise=True if sync is None else sync)
    else:
        if not selected:
            raise ValueError("policy success_on_selected needs selected: [child names]")
        by_name = {c.name: c for c in children}
        missing = [s for s in selected if s not in by_name]
        if missing:
            raise ValueError(
                f"selected: no child named {', '.join(map(repr, missing))}; "
                f"children are {', '.join(map(repr, by_name))}"
            )
        pol = common.ParallelPolicy.SuccessOnSelected(
            children=[by_name[s] for s in selected], synchronise=True if sync is None else sync
        )
    return py_trees.composites.Parallel(name=name, policy=pol, children=children)


def _checks(checks: list, what: str) -> list[common.ComparisonExpression]:
    """``[{variable_name, value, operator}, ...]`` as py_trees comparison expressions."""
    expressions = []
    for i, check in enumerate(checks):
        if not isinstance(check, dict) or "variable_name" not in check or "value" not in check:
            raise ValueError(
                f"{what}[{i}]: expected {{variable_name: KEY, value: V, operator: eq}}, got {check!r}"
            )
        unknown = set(check) - {"variable_name", "value", "operator"}
        if unknown:
            raise ValueError(f"{what}[{i}]: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
        op = check.get("operator", "eq")
        if op not in OPERATORS:
            raise ValueError(f"{what}[{i}]: operator must be one of {', '.join(OPERATORS)}")
        expressions.append(_comparison(check["variable_name"], check["value"], op))
    return expressions


def _either_or(
    name: str, children: list, conditions: list, namespace: str | None
) -> py_trees.behaviour.Behaviour:
    if len(conditions) != len(children):
        raise ValueError(
            f"conditions: give one per child ({len(children)} children, {len(conditions)} conditions)"
        )
    return py_trees.idioms.either_or(
        conditions=_checks(conditions, "conditions"),
        subtrees=children,
        name=name,
        namespace=namespace,
    )


def _simple(cls: type, doc: str) -> NodeType:
    return NodeType(LEAF, lambda name: cls(name=name), (), doc)


def _flip(cls: type, doc: str) -> NodeType:
    return NodeType(DECORATOR, lambda name, child: cls(name=name, child=child), (), doc)


_VAR = Param("variable_name", "str", doc="blackboard key, may be nested (a.b)")
_OP = Param("operator", "str", "eq", choices=tuple(OPERATORS), doc="comparison")
_VALUE = Param("value", "any", doc="value to compare with")


def node_types() -> dict[str, NodeType | type]:
    """Every built-in node type by its snake_case name."""
    return {
        # Composites
        "sequence": NodeType(
            COMPOSITE,
            lambda name, children, memory: py_trees.composites.Sequence(
                name=name, memory=memory, children=children
            ),
            (Param("memory", "bool", True, doc="skip children that already succeeded"),),
            "Tick children in order until one fails or is RUNNING; SUCCESS when all succeed.",
        ),
        "selector": NodeType(
            COMPOSITE,
            lambda name, children, memory: py_trees.composites.Selector(
                name=name, memory=memory, children=children
            ),
            (
                Param(
                    "memory", "bool", False, doc="resume the RUNNING child instead of re-checking"
                ),
            ),
            "Tick children in priority order until one succeeds or is RUNNING.",
        ),
        "parallel": NodeType(
            COMPOSITE,
            _parallel,
            (
                Param(
                    "policy",
                    "str",
                    "success_on_all",
                    choices=("success_on_all", "success_on_one", "success_on_selected"),
                    doc="when the parallel succeeds",
                ),
                Param("synchronise", "bool", None, doc="do not re-tick children that succeeded"),
                Param("memory", "bool", None, doc="same as synchronise"),
                Param("selected", "str_list", None, doc="child names for success_on_selected"),
            ),
            "Tick every child every tick; FAILURE as soon as one fails.",
        ),
        # py_trees' idioms that take children
        "pick_up_where_you_left_off": NodeType(
            COMPOSITE,
            lambda name, children: py_trees.idioms.pick_up_where_you_left_off(
                name=name, tasks=children
            ),
            (),
            "Run tasks in order; after a higher-priority interruption, resume at the one not done.",
        ),
        "either_or": NodeType(
            COMPOSITE,
            _either_or,
            (
                Param(
                    "conditions", "list", doc="[{variable_name, value, operator}], one per child"
                ),
                Param("namespace", "str", None, doc="blackboard namespace for the choice"),
            ),
            "Run the child of the first condition that holds, first come first served.",
            reads=("conditions",),
        ),
        # Leaves
        "success": _simple(pb.Success, "Always SUCCESS."),
        "failure": _simple(pb.Failure, "Always FAILURE."),
        "running": _simple(pb.Running, "Always RUNNING."),
        "dummy": _simple(pb.Dummy, "Crash-test dummy: always RUNNING."),
        "periodic": NodeType(
            LEAF,
            lambda name, n: pb.Periodic(name=name, n=n),
            (Param("n", "int", unit="ticks", doc="ticks per status"),),
            "Cycle RUNNING, SUCCESS, FAILURE, n ticks each.",
        ),
        "success_every_n": NodeType(
            LEAF,
            lambda name, n: pb.SuccessEveryN(name=name, n=n),
            (Param("n", "int", unit="ticks", doc="period"),),
            "SUCCESS every n-th tick, FAILURE otherwise.",
        ),
        "status_queue": NodeType(
            LEAF,
            _status_queue,
            (
                Param("queue", "str_list", doc="statuses to return in turn"),
                Param("eventually", "status", None, doc="status once the queue is empty"),
            ),
            "Return the queued statuses in turn, then `eventually` (or cycle).",
        ),
        "tick_counter": NodeType(
            LEAF,
            lambda name, duration, completion_status: pb.TickCounter(
                name=name, duration=duration, completion_status=STATUS[completion_status]
            ),
            (
                Param("duration", "int", unit="ticks", doc="ticks to stay RUNNING"),
                Param("completion_status", "status", "SUCCESS", doc="status afterwards"),
            ),
            "RUNNING for `duration` ticks, then `completion_status`.",
        ),
        "blackboard_to_status": NodeType(
            LEAF,
            lambda name, variable_name: pb.BlackboardToStatus(
                name=name, variable_name=variable_name
            ),
            (_VAR,),
            "Return the status stored in a blackboard variable.",
            reads=("variable_name",),
        ),
        "check_blackboard_variable_exists": NodeType(
            LEAF,
            lambda name, variable_name: pb.CheckBlackboardVariableExists(
                name=name, variable_name=variable_name
            ),
            (_VAR,),
            "SUCCESS if the blackboard variable exists, else FAILURE.",
            reads=("variable_name",),
        ),
        "wait_for_blackboard_variable": NodeType(
            LEAF,
            lambda name, variable_name: pb.WaitForBlackboardVariable(
                name=name, variable_name=variable_name
            ),
            (_VAR,),
            "RUNNING until the blackboard variable exists, then SUCCESS.",
            reads=("variable_name",),
        ),
        "unset_blackboard_variable": NodeType(
            LEAF,
            lambda name, key: pb.UnsetBlackboardVariable(name=name, key=key),
            (Param("key", "str", doc="blackboard key to remove"),),
            "Remove a blackboard variable; always SUCCESS.",
        ),
        "set_blackboard_variable": NodeType(
            LEAF,
            lambda name, variable_name, variable_value, overwrite: pb.SetBlackboardVariable(
                name=name,
                variable_name=variable_name,
                variable_value=variable_value,
                overwrite=overwrite,
            ),
            (
                _VAR,
                Param("variable_value", "any", doc="value to write"),
                Param("overwrite", "bool", True, doc="replace an existing value"),
            ),
            "Write a value to the blackboard.",
            writes=("variable_name",),
        ),
        "check_blackboard_variable_value": NodeType(
            LEAF,
            lambda name, variable_name, value, operator: pb.CheckBlackboardVariableValue(
                name=name, check=_comparison(variable_name, value, operator)
            ),
            (_VAR, _VALUE, _OP),
            "SUCCESS if `variable operator value` holds, else FAILURE.",
            reads=("variable_name",),
        ),
        "wait_for_blackboard_variable_value": NodeType(
            LEAF,
            lambda name, variable_name, value, operator: pb.WaitForBlackboardVariableValue(
                name=name, check=_comparison(variable_name, value, operator)
            ),
            (_VAR, _VALUE, _OP),
            "RUNNING until `variable operator value` holds, then SUCCESS.",
            reads=("variable_name",),
        ),
        "compare_blackboard_variables": NodeType(
            LEAF,
            lambda name, var1_key, var2_key, operator: pb.CompareBlackboardVariables(
                name=name, var1_key=var1_key, var2_key=var2_key, operator=OPERATORS[operator]
            ),
            (
                Param("var1_key", "str", doc="left-hand blackboard key"),
                Param("var2_key", "str", doc="right-hand blackboard key"),
                _OP,
            ),
            "SUCCESS if `var1 operator var2` holds, else FAILURE.",
            reads=("var1_key", "var2_key"),
        ),
        "check_blackboard_variable_values": NodeType(
            LEAF,
            _check_values,
            (
                Param("checks", "list", doc="[{variable_name, value, operator}, ...]"),
                Param("logical_operator", "str", "and", choices=tuple(LOGICAL), doc="combine"),
                Param("namespace", "str", None, doc="store each check's result under it"),
            ),
            "Combine several blackboard comparisons with and/or/xor.",
            reads=("checks",),
        ),
        "probabilistic_behaviour": NodeType(
            LEAF,
            _probabilistic,
            (Param("weights", "vector", None, doc="weights of SUCCESS, FAILURE, RUNNING"),),
            "A random status (uniform unless weighted).",
        ),
        "timer": Timer,
        "wait": Wait,
        # Decorators
        "inverter": _flip(pd.Inverter, "Swap the child's SUCCESS and FAILURE."),
        "pass_through": _flip(pd.PassThrough, "Reflect the child's status unchanged."),
        "count": _flip(pd.Count, "Reflect the child, counting its statuses."),
        "running_is_failure": _flip(pd.RunningIsFailure, "RUNNING becomes FAILURE."),
        "running_is_success": _flip(pd.RunningIsSuccess, "RUNNING becomes SUCCESS."),
        "failure_is_success": _flip(pd.FailureIsSuccess, "FAILURE becomes SUCCESS."),
        "failure_is_running": _flip(pd.FailureIsRunning, "FAILURE becomes RUNNING."),
        "success_is_failure": _flip(pd.SuccessIsFailure, "SUCCESS becomes FAILURE."),
        "success_is_running": _flip(pd.SuccessIsRunning, "SUCCESS becomes RUNNING."),
        "repeat": NodeType(
            DECORATOR,
            lambda name, child, num_success: pd.Repeat(
                name=name, child=child, num_success=num_success
            ),
            (Param("num_success", "int", doc="successes needed; -1 repeats for ever"),),
            "Re-run the child until it has succeeded num_success times; FAILURE on a failure.",
        ),
        "retry": NodeType(
            DECORATOR,
            lambda name, child, num_failures: pd.Retry(
                name=name, child=child, num_failures=num_failures
            ),
            (Param("num_failures", "int", doc="failures allowed before failing"),),
            "Re-run a failing child up to num_failures times.",
        ),
        "status_to_blackboard": NodeType(
            DECORATOR,
            lambda name, child, variable_name: pd.StatusToBlackboard(
                name=name, child=child, variable_name=variable_name
            ),
            (_VAR,),
            "Reflect the child and write its status to the blackboard.",
            writes=("variable_name",),
        ),
        "eternal_guard": NodeType(
            DECORATOR,
            _eternal_guard,
            (_VAR, Param("value", "any", True, doc="value to compare with"), _OP),
            "Tick the child only while `variable operator value` holds; halt it and fail otherwise.",
            reads=("variable_name",),
        ),
        "timeout": Timeout,
        "one_shot": NodeType(
            DECORATOR,
            lambda name, child, policy: pd.OneShot(
                name=name, child=child, policy=common.OneShotPolicy[policy.upper()]
            ),
            (
                Param(
                    "policy",
                    "str",
                    "on_completion",
                    choices=("on_completion", "on_successful_completion"),
                    doc="when the result is latched",
                ),
            ),
            "Run the child to completion once, then keep returning its result.",
        ),
        "condition": NodeType(
            DECORATOR,
            lambda name, child, status: pd.Condition(name=name, child=child, status=STATUS[status]),
            (Param("status", "status", doc="child status that means SUCCESS"),),
            "RUNNING until the child returns `status`, then SUCCESS.",
        ),
        "for_each": NodeType(
            DECORATOR,
            lambda name, child, source_key, target_key: pd.ForEach(
                name=name, child=child, source_key=source_key, target_key=target_key
            ),
            (
                Param("source_key", "str", doc="blackboard key holding a list"),
                Param("target_key", "str", doc="blackboard key set to each item in turn"),
            ),
            "Run the child once per item of a blackboard list.",
            writes=("target_key",),
            reads=("source_key",),
        ),
    }


@hookimpl
def armtree_behaviours() -> dict[str, Any]:
    """Register the py_trees built-ins and armtree's clock-following timers."""
    return node_types()
