"""Loader benchmark: validate and build a generated 500-node tree file (goal: < 100 ms).

Run with ``python benchmarks/bench_loader.py``. Baselines measured in the same run:
parsing the file with PyYAML's C loader alone (no marks), and building the same
behaviours directly in Python with py_trees (no file, no checks). Figures are
medians of repeated runs; the machine is shared, so the ratios are what count.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import py_trees
import yaml

import armtree
from armtree.config.yamlio import load_yaml
from armtree.hooks.plugin_manager import get_plugin_manager

GROUPS = 25  # each group is 20 nodes: 25 * 20 = 500, plus the root


def tree_text(groups: int = GROUPS) -> str:
    """A tree of ``20 * groups + 1`` nodes mixing composites, decorators, leaves and bindings."""
    lines = [
        "tree: bench",
        "tick_hz: 50",
        "blackboard: {delay: 0.5, target: [1, 2, 3]}",
        "root:",
        "  sequence:",
        "    name: Bench",
        "    children:",
    ]
    for g in range(groups):
        lines += [
            "      - selector:",
            f"          name: Group {g}",
            "          children:",
            "            - retry:",
            "                num_failures: 2",
            "                child:",
            "                  sequence:",
            "                    - tick_counter: {duration: 3, completion_status: SUCCESS}",
            '                    - wait: {seconds: "{delay}"}',
            "                    - timeout: {duration: 2.5, child: {running: {}}}",
            f"                    - set_blackboard_variable: {{variable_name: v{g}, variable_value: {g}}}",
            f"                    - check_blackboard_variable_value: {{variable_name: v{g}, value: {g}}}",
            "            - parallel:",
            "                policy: success_on_one",
            "                children:",
            "                  - inverter: {child: {failure: {}}}",
            "                  - status_queue: {queue: [RUNNING, SUCCESS], eventually: SUCCESS}",
            "                  - success_every_n: {n: 2}",
            "                  - one_shot: {child: {periodic: {n: 2}}}",
            "            - pass_through: {child: {success: {name: fallback}}}",
            "            - failure_is_success: {child: {dummy: {}}}",
        ]
    return "\n".join(lines) + "\n"


def build_directly(groups: int = GROUPS) -> py_trees.behaviour.Behaviour:
    """The same tree built in Python with py_trees' own classes (the baseline)."""
    pb, pd, common = py_trees.behaviours, py_trees.decorators, py_trees.common
    children = []
    for g in range(groups):
        inner = py_trees.composites.Sequence(
            "sequence",
            memory=True,
            children=[
                pb.TickCounter("tick_counter", 3, common.Status.SUCCESS),
                py_trees.timers.Timer("wait", 0.5),
                pd.Timeout("timeout", pb.Running("running"), 2.5),
                pb.SetBlackboardVariable("set", f"v{g}", g, True),
                pb.CheckBlackboardVariableValue(
                    "check", common.ComparisonExpression(f"v{g}", g, lambda a, b: a == b)
                ),
            ],
        )
        parallel = py_trees.composites.Parallel(
            "parallel",
            policy=common.ParallelPolicy.SuccessOnOne(),
            children=[
                pd.Inverter("inverter", pb.Failure("failure")),
                pb.StatusQueue(
                    "q", [common.Status.RUNNING, common.Status.SUCCESS], common.Status.SUCCESS
                ),
                pb.SuccessEveryN("n", 2),
                pd.OneShot(
                    "one_shot", pb.Periodic("periodic", 2), common.OneShotPolicy.ON_COMPLETION
                ),
            ],
        )
        children.append(
            py_trees.composites.Selector(
                f"Group {g}",
                memory=False,
                children=[
                    pd.Retry("retry", inner, 2),
                    parallel,
                    pd.PassThrough("pass_through", pb.Success("fallback")),
                    pd.FailureIsSuccess("failure_is_success", pb.Dummy("dummy")),
                ],
            )
        )
    return py_trees.composites.Sequence("Bench", memory=True, children=children)


def median_ms(action, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        action()
        times.append((time.perf_counter() - t0) * 1000.0)
    return statistics.median(times)


def main() -> int:
    repeat = int(sys.argv[1]) if len(sys.argv) > 1 else 15
    t0 = time.perf_counter()
    manager = get_plugin_manager()
    _ = manager.registry
    startup_ms = (time.perf_counter() - t0) * 1000.0
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.yaml"
        text = tree_text()
        path.write_text(text)
        tree = armtree.load_tree(path, manager=manager)
        nodes = len(tree.nodes)
        assert nodes == len(list(build_directly().iterate()))
        plain = median_ms(lambda: yaml.load(text, Loader=yaml.CSafeLoader), repeat)
        marked = median_ms(lambda: load_yaml(text, str(path)), repeat)
        direct = median_ms(build_directly, repeat)
        full = median_ms(lambda: armtree.load_tree(path, manager=manager), repeat)
    print(f"tree file: {nodes} nodes, {len(text.splitlines())} lines; median of {repeat} runs")
    print(f"plugin manager start-up (entry points, registry), once:  {startup_ms:8.1f} ms")
    print(f"baseline: PyYAML C loader, plain data:                   {plain:8.1f} ms")
    print(f"armtree.config.yamlio.load_yaml, with marks:                    {marked:8.1f} ms")
    print(f"baseline: same behaviours built directly with py_trees:  {direct:8.1f} ms")
    print(f"armtree.load_tree (parse, validate, build):              {full:8.1f} ms")
    print(f"load_tree / (plain parse + direct build): {full / (plain + direct):.2f}x")
    print(
        f"per node: {1000.0 * full / nodes:.1f} us; goal < 100 ms: {'met' if full < 100 else 'MISSED'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
