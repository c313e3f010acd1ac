"""What a sweep found: success rate with its Wilson interval, failures grouped by reason,
per-expectation pass rates, run-time histograms, and how to replay each failed seed.

:func:`summarise` turns the runs' outcomes into the data of ``sweep.json``;
:func:`write_report` writes ``sweep.json``, ``report.md`` and the PNG histograms.
"""

from __future__ import annotations

import json
import math
import shlex
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from armtree.api.outcomes.failures import reason_key

from .task import DIED, ERROR, TIMEOUT, Outcome

#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: Example seeds listed per failure reason, and failed seeds given a replay command.
EXAMPLES = 5
REPLAYS = 50


def wilson(successes: int, runs: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a success rate (default 95 %); (0, 1) for no runs."""
    if runs == 0:
        return (0.0, 1.0)
    p = successes / runs
    denominator = 1 + z * z / runs
    centre = (p + z * z / (2 * runs)) / denominator
    half = z * math.sqrt(p * (1 - p) / runs + z * z / (4 * runs * runs)) / denominator
    return (max(0.0, centre - half), min(1.0, centre + half))


def replay_command(sweep: Mapping[str, Any], seed: int) -> str:
    """The ``run-tree`` line that runs one seed of the sweep again, recording it."""
    words = ["run-tree", sweep["tree"]]
    if sweep.get("rig"):
        words += ["--rig", sweep["rig"]]
    for override in sweep.get("overrides") or ():
        words += ["--set", override]
    for plugin in sweep.get("plugins") or ():
        words += ["--plugin", plugin]
    if sweep.get("timeout") is not None:
        words += ["--timeout", f"{sweep['timeout']:g}"]
    words += ["--seed", str(seed), "--record", f"replay-{seed}"]
    return shlex.join(words)


def _stats(values: Sequence[float]) -> dict[str, float | None]:
    if not values:
        return {"median": None, "p90": None, "max": None}
    ordered = sorted(values)
    pick = lambda q: ordered[min(len(ordered) - 1, int(q * len(ordered)))]  # noqa: E731
    return {"median": pick(0.5), "p90": pick(0.9), "max": ordered[-1]}


def summarise(sweep: Mapping[str, Any], outcomes: Sequence[Outcome]) -> dict[str, Any]:
    """The whole report as data: the sweep's settings, the summary, reasons, expectations."""
    runs = sorted(outcomes, key=lambda o: o["seed"])
    n = len(runs)
    successes = sum(o["verdict"] == "success" for o in runs)
    count = lambda pred: sum(1 for o in runs if pred(o))  # noqa: E731
    groups: dict[str, list[Outcome]] = defaultdict(list)
    for o in runs:
        if o["verdict"] != "success":
            groups[reason_key(o["reason"] or o["status"])].append(o)
    reasons = [
        {
            "reason": key,
            "runs": len(members),
            "share": len(members) / n,
            "example": members[0]["reason"],
            "seeds": [o["seed"] for o in members[:EXAMPLES]],
        }
        for key, members in sorted(groups.items(), key=lambda kv: (-len(kv[1]), kv[0]))
    ]
    tallies: dict[str, dict[str, int]] = {}
    for o in runs:
        for e in o["expectations"]:
            tally = tallies.setdefault(e["expect"], {"pass": 0, "fail": 0, "not checked": 0})
            tally[e["status"]] = tally.get(e["status"], 0) + 1
    expectations = [
        {
            "expect": text,
            "pass": t["pass"],
            "fail": t["fail"],
            "not_checked": t["not checked"],
            "pass_rate": t["pass"] / (t["pass"] + t["fail"]) if t["pass"] + t["fail"] else None,
        }
        for text, t in tallies.items()
    ]
    failed = [o["seed"] for o in runs if o["verdict"] != "success"]
    low, high = wilson(successes, n)
    return {
        "sweep": dict(sweep),
        "summary": {
            "runs": n,
            "successes": successes,
            "success_rate": successes / n if n else None,
            "wilson95": [low, high],
            "false_successes": count(lambda o: o["verdict"] == "false success"),
            "false_failures": count(lambda o: o["verdict"] == "false failure"),
            "failures": count(lambda o: o["verdict"] == "failure"),
            "timeouts": count(lambda o: o["status"] == TIMEOUT),
            "died": count(lambda o: o["status"] == DIED),
            "errors": count(lambda o: o["status"] == ERROR),
            "retried": count(lambda o: o.get("attempt", 1) > 1),
        },
        "reasons": reasons,
        "expectations": expectations,
        "times": {
            "sim_seconds": _stats([o["seconds"] for o in runs if o["seconds"] is not None]),
            "wall_seconds": _stats(
                [o["wall_seconds"] for o in runs if o["wall_seconds"] is not None]
            ),
        },
        "replay": [{"seed": s, "command": replay_command(sweep, s)} for s in failed[:REPLAYS]],
        "runs": runs,
    }


def _histogram(path: Path, runs: Sequence[Outcome], key: str, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    good = [o[key] for o in runs if o[key] is not None and o["verdict"] == "success"]
    bad = [o[key] for o in runs if o[key] is not None and o["verdict"] != "success"]
    fig, ax = plt.subplots(figsize=(6.4, 3.6), dpi=100)
    if good or bad:
        ax.hist(
            [good, bad],
            bins=30,
            stacked=True,
            label=["succeeded", "did not"],
            color=["#3a7d44", "#c0392b"],
        )
        ax.legend()
    ax.set_xlabel("seconds")
    ax.set_ylabel("runs")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f} %"


def _secs(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f} s"


def markdown(report: Mapping[str, Any]) -> str:
    """``report.md``: what a reader needs first, then the details."""
    sweep, s = report["sweep"], report["summary"]
    seeds = sweep["seeds"]
    where = sweep["scheduler"] or f"{sweep['workers']} local worker(s)"
    if sweep.get("in_progress"):
        status = "still running: a report of what has finished so far"
    elif sweep.get("interrupted"):
        status = "interrupted: partial report"
    else:
        status = "complete"
    lines = [
        f"# Sweep of {sweep.get('tree_name') or sweep['tree']} on {sweep.get('rig') or 'no rig'}, seeds {seeds[0]}-{seeds[1]}",
        "",
        f"`{sweep['command']}`",
        "",
        f"- runs finished: {s['runs']} of {sweep['requested']} ({status}), "
        f"{_secs(sweep.get('wall_seconds'))} of wall time on {where}",
        f"- **success rate: {_pct(s['success_rate'])}** ({s['successes']} of {s['runs']}), "
        f"95 % Wilson interval {_pct(s['wilson95'][0])} to {_pct(s['wilson95'][1])}",
        f"- **false successes: {s['false_successes']}** (the tree said SUCCESS, the world disagreed)",
        f"- false failures: {s['false_failures']} (the tree said FAILURE, every expectation held)",
        f"- failures: {s['failures']}, of which {s['timeouts']} run timeouts, {s['died']} died, "
        f"{s['errors']} errors; {s['retried']} runs retried after their process died",
        "",
        "## Why runs did not succeed (most common first)",
        "",
    ]
    if report["reasons"]:
        lines += ["| runs | share | reason | example seeds |", "| ---: | ---: | --- | --- |"]
        for r in report["reasons"]:
            text = r["example"].replace("|", "\\|")
            seeds_text = ", ".join(str(x) for x in r["seeds"])
            lines.append(f"| {r['runs']} | {_pct(r['share'])} | {text} | {seeds_text} |")
    else:
        lines.append("Every run succeeded.")
    lines += ["", "## Expectations", ""]
    if report["expectations"]:
        lines += [
            "| expectation | pass | fail | not checked | pass rate |",
            "| --- | ---: | ---: | ---: | ---: |",
        ]
        for e in report["expectations"]:
            lines.append(
                f"| {e['expect']} | {e['pass']} | {e['fail']} | {e['not_checked']} | {_pct(e['pass_rate'])} |"
            )
    else:
        lines.append("The tree declares no `expect:`.")
    t = report["times"]
    lines += [
        "",
        "## Run time",
        "",
        f"Simulated: median {_secs(t['sim_seconds']['median'])}, 90th percentile "
        f"{_secs(t['sim_seconds']['p90'])}, longest {_secs(t['sim_seconds']['max'])}. "
        f"Wall: median {_secs(t['wall_seconds']['median'])}, 90th percentile "
        f"{_secs(t['wall_seconds']['p90'])}, longest {_secs(t['wall_seconds']['max'])}.",
        "",
        "![simulated time per run](sim_time.png)",
        "![wall time per run](wall_time.png)",
        "",
        "## Replay a failed seed",
        "",
    ]
    if report["replay"]:
        lines += ["```sh"] + [r["command"] for r in report["replay"]] + ["```"]
        more = s["runs"] - s["successes"] - len(report["replay"])
        if more > 0:
            lines.append(f"... and {more} more in sweep.json (`runs`).")
    else:
        lines.append("Nothing failed.")
    return "\n".join(lines) + "\n"


def write_report(out: Path, report: Mapping[str, Any]) -> None:
    """``sweep.json``, ``report.md``, ``sim_time.png`` and ``wall_time.png`` in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    runs = report["runs"]
    _histogram(out / "sim_time.png", runs, "seconds", "simulated time per run")
    _histogram(out / "wall_time.png", runs, "wall_seconds", "wall time per run")
    (out / "report.md").write_text(markdown(report))
    tmp = out / "sweep.json.tmp"
    tmp.write_text(json.dumps(report, indent=1))
    tmp.replace(out / "sweep.json")
