"""Timing calls that use OpenCV's worker threads, fairly between contenders.

OpenCV's workers spin for about 0.2 ms after each parallel call before they
sleep. Timed back to back with ``process_time``, that spinning is charged to
whatever runs next: another contender, or the caller's own serial work after
the call. ``timed_call`` charges each call the spinning its own parallel
calls cause and nothing else, as in a camera loop where a frame's detection
is followed by idle time until the next frame; ``time_contenders`` also times
every contender with OpenCV on one thread (the work itself, no spinning) and
the wall time of each call, so all three can be printed side by side.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import cv2
import numpy as np
from rich.console import Console
from rich.progress import track

#: Busy time around each timed call (s): longer than OpenCV's workers spin after a call.
SETTLE_S = 0.001
MEASURES = ("cpu", "wall", "one")


def _settle() -> None:
    """Keep the main thread busy for SETTLE_S: OpenCV's idle workers stop spinning
    meanwhile and, unlike in a sleep, the core does not idle and its caches stay warm."""
    end = time.perf_counter() + SETTLE_S
    while time.perf_counter() < end:
        pass


def timed_call(fn: Callable[..., Any], *args: Any) -> tuple[float, float, Any]:
    """``(cpu_s, wall_s, result)`` of one call.

    CPU is the whole process's (OpenCV's workers included) from the call's
    start until its workers have stopped spinning, minus the main thread's own
    busy wait after the call.
    """
    _settle()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    result = fn(*args)
    wall1, main1 = time.perf_counter(), time.thread_time()
    _settle()
    cpu2, main2 = time.process_time(), time.thread_time()
    return (cpu2 - cpu0) - (main2 - main1), wall1 - wall0, result


def time_contenders(
    contenders: dict[str, tuple[Callable[[Any], Any], Sequence[Any]]],
    rounds: int,
    console: Console | None = None,
) -> tuple[dict[tuple[str, str], float], dict[str, list[Any]]]:
    """Mean over inputs of the best of ``rounds`` per input, in milliseconds, for each
    contender ``name: (fn, inputs)`` and measure: ``"cpu"`` (OpenCV's threads as
    configured), ``"wall"`` (the same calls) and ``"one"`` (CPU with OpenCV on one
    thread). Contenders alternate input by input, each given a fresh copy of the
    input (not timed). Also returns each contender's results of its first
    threaded round.
    """
    threads = cv2.getNumThreads()
    n = min(len(inputs) for _, inputs in contenders.values())
    best = {(k, m): np.full(n, np.inf) for k in contenders for m in MEASURES}
    results: dict[str, list[Any]] = {k: [] for k in contenders}
    try:
        for r in track(range(2 * rounds), "timing", console=console, transient=True):
            one_thread = r % 2 == 1
            cv2.setNumThreads(1 if one_thread else threads)
            for i in range(n):
                for name, (fn, inputs) in contenders.items():
                    # a fresh copy, as a camera delivers a frame: no contender reads a
                    # frame that the one before it has just pulled into the cache
                    cpu, wall, result = timed_call(fn, np.copy(inputs[i]))
                    if one_thread:
                        best[name, "one"][i] = min(best[name, "one"][i], cpu)
                        continue
                    best[name, "cpu"][i] = min(best[name, "cpu"][i], cpu)
                    best[name, "wall"][i] = min(best[name, "wall"][i], wall)
                    if r == 0:
                        results[name].append(result)
    finally:
        cv2.setNumThreads(threads)
    return {key: 1000.0 * float(np.mean(v)) for key, v in best.items()}, results


def ratios(ms: dict[tuple[str, str], float], slower: str, faster: str) -> str:
    """``"a.aax | b.bbx | c.ccx"``: slower / faster for CPU, wall and one thread."""
    return " | ".join(f"{ms[slower, m] / ms[faster, m]:.2f}x" for m in MEASURES)
