"""Hostile-input figures (issue 17): how often armtree answers bad input cleanly.

Seven families, each a few hundred cases generated from the shipped trees and
profiles with a fixed seed, plus the fixed corpus of tests/hostile_corpus.py:

* ``trees-check``: mutated trees through ``armtree check``;
* ``trees-run``: trees that pass check, with edge values, through ``run-tree``;
* ``profiles-check``: hostile ``--set`` values for every component parameter;
* ``profiles-run``: valid edge values (each range's ends, each choice) through a run;
* ``edges``: issue 32's corpus (tests/hostile_corpus.py ``EDGES``): output paths of every
  command that writes, numbers on the command line, images too large, inputs that
  are a FIFO, a folder or a device;
* ``serial``: five arm variants under seventeen link faults, driver against emulator;
* ``interrupts``: SIGINT / SIGTERM / SIGHUP / SIGQUIT (and SIGSTOP / SIGCONT first) into real ``run-tree`` processes at random
  moments, stuck ticks included.

A case is *clean* when the exit code is the right one, an input error names its
FILE:LINE:COL (or the option), no traceback or raw exception type is printed, it
ends within its time limit (no hang) and within 4 GB; for serial faults, when no
implausible joint reading is believed and the link either works or is declared
lost. Checks and runs go to a few long-lived worker processes (each case killed
and counted as a hang if it overruns). Run::

    python benchmarks/bench_hostile.py [--families trees-check,serial] [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import selectors
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from hostile_corpus import EDGES, PROFILES, STUCK_PLUGIN, TREES, write_case  # noqa: E402

RAW = re.compile(r"Traceback|^error: [A-Za-z]+(Error|Exception)\b|^\w+Error: ", re.M)
#: Where an input error points: FILE:LINE:COL, an option, or a whole file (a file name with
#: its suffix: the file is too large, a FIFO, an image over the pixel limit).
POSITION = re.compile(r"^(?:[^\s:]+:\d+:\d+: |--?\S*|[^\s:]+\.[A-Za-z0-9]+: )")
SHIPPED_TREES = ("load_ducky", "search", "clean_up", "pick_and_place", "touch_tag", "track", "sort")
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)
SIM_RIGS = ("sim_dobot", "sim_vicra", "sim_magician", "sim_dh")


@dataclass
class Result:
    """One case's outcome."""

    family: str
    name: str
    clean: bool
    code: int | None
    seconds: float
    why: str = ""
    detail: dict[str, Any] = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Workers: one armtree command at a time in a long-lived, memory-capped process
# ---------------------------------------------------------------------------

WORKER = r"""
import contextlib, io, json, os, resource, sys, time, traceback
resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
from armtree.cli import commandline as cli
print("ready", flush=True)
for line in sys.stdin:
    req = json.loads(line)
    os.chdir(req["cwd"])
    out, err = io.StringIO(), io.StringIO()
    t = time.monotonic()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main(req["argv"])
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        except BaseException:
            traceback.print_exc()
            code = -1
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    text = err.getvalue()
    text = text if len(text) <= 8000 else text[:4000] + "\n...\n" + text[-4000:]
    print(json.dumps({"code": code, "err": text, "out": out.getvalue()[-2000:],
                      "seconds": time.monotonic() - t, "rss_mb": rss}), flush=True)
"""


class Worker:
    """A Python process that runs ``armtree`` commands in-process, one per request."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen[str] | None = None

    def _start(self) -> subprocess.Popen[str]:
        proc = subprocess.Popen(
            [sys.executable, "-c", WORKER],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            start_new_session=True,
        )
        assert proc.stdout is not None
        proc.stdout.readline()
        return proc

    def run(self, argv: list[str], cwd: Path, timeout: float) -> dict[str, Any] | None:
        """The command's result, or None when it overran ``timeout`` (the worker is killed)."""
        if self.proc is None or self.proc.poll() is not None:
            self.proc = self._start()
        proc = self.proc
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write(json.dumps({"argv": argv, "cwd": str(cwd)}) + "\n")
        proc.stdin.flush()
        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ)
        if not sel.select(timeout):
            self.kill()
            return None
        line = proc.stdout.readline()
        if not line:  # died (killed by the memory cap, a crash)
            code = proc.wait()
            self.proc = None
            return {"code": code, "err": f"worker died ({code})", "seconds": timeout, "rss_mb": 0}
        return json.loads(line)

    def kill(self) -> None:
        if self.proc is not None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            self.proc = None


def command_result(
    family: str, name: str, res: dict[str, Any] | None, allowed: Iterable[int], limit: float
) -> Result:
    """A :class:`Result` for one command judged by :func:`judge_command`."""
    clean, why = judge_command(res, allowed)
    code = res["code"] if res else None
    return Result(family, name, clean, code, res["seconds"] if res else limit, why)


def judge_command(res: dict[str, Any] | None, allowed: Iterable[int]) -> tuple[bool, str]:
    """Clean or not, and why, for a command whose exit code must be one of ``allowed``."""
    if res is None:
        return False, "hang"
    err, code = res["err"], res["code"]
    if RAW.search(err):
        return False, "raw exception or traceback"
    if code not in allowed:
        return False, f"exit {code}"
    lines = err.strip().splitlines() or [""]
    first = lines[0]
    if first.startswith("usage:"):  # argparse: the usage, then "PROG: error: argument --X: ..."
        first = lines[-1].partition(": error: argument ")[2]
    if code == 2 and not POSITION.match(first):
        return False, "no FILE:LINE:COL"
    return True, ""


# ---------------------------------------------------------------------------
# Mutations of trees and profiles
# ---------------------------------------------------------------------------

HOSTILE_VALUES = [
    "-1",
    "0",
    "1.0e-300",
    "1.0e+300",
    "9" * 400,
    "9" * 4300,
    "9" * 5000,
    ".nan",
    ".inf",
    "-.inf",
    "''",
    '"{}"',
    '"{ key }"',
    "nowhere",
    "[]",
    "{}",
    "[" * 300 + "]" * 300,
    "x" * 10000,
    "true",
    "null",
    '"a\\x07b"',
    "../../../etc/passwd",
    "/tmp/hostile-abs",
    "!!float abc",
    "!!python/object:os.system ls",
    "&a [*a]",
    "[1, 2]",
    "[1.0e+300, -1.0e+300, 0]",
    "{fx: a}",
    "1000000000",
]


def shipped(kind: str, name: str) -> str:
    folder = "trees" if kind == "tree" else "hardware"
    return (ROOT / folder / f"{name}.yaml").read_text()


def mutate(text: str, rng: random.Random) -> tuple[str, str]:
    """One random hostile edit of a YAML text, and its description."""
    lines = text.splitlines()
    op = rng.choice(
        [
            "value",
            "value",
            "value",
            "delete",
            "duplicate",
            "unknown",
            "bomb",
            "truncate",
            "flip",
            "deep",
            "type",
        ]
    )
    values = [
        i
        for i, ln in enumerate(lines)
        if re.search(r":\s*\S", ln) and not ln.lstrip().startswith("#")
    ]
    i = rng.choice(values) if values else 0
    if op == "value" and values:
        key, _, _ = lines[i].partition(":")
        value = rng.choice(HOSTILE_VALUES)
        lines[i] = f"{key}: {value}"
        return "\n".join(lines) + "\n", f"value {value[:20]!r} at line {i + 1}"
    if op == "delete" and values:
        del lines[i]
        return "\n".join(lines) + "\n", f"delete line {i + 1}"
    if op == "duplicate" and values:
        lines.insert(i, lines[i])
        return "\n".join(lines) + "\n", f"duplicate line {i + 1}"
    if op == "unknown" and values:
        indent = re.match(r"\s*", lines[i]).group(0)
        lines.insert(i, f"{indent}nonsense_{rng.randint(0, 99)}: 1")
        return "\n".join(lines) + "\n", f"unknown key at line {i + 1}"
    if op == "bomb":
        bomb = "\n".join(
            [f"z0: &z0 [{', '.join(['lol'] * 10)}]"]
            + [f"z{k}: &z{k} [{', '.join([f'*z{k - 1}'] * 10)}]" for k in range(1, 9)]
        )
        return bomb + "\n" + text, "alias bomb"
    if op == "truncate":
        cut = rng.randrange(1, max(2, len(text)))
        return text[:cut], f"truncated at {cut}"
    if op == "flip":
        data = bytearray(text.encode())
        for _ in range(rng.randint(1, 5)):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        return data.decode("utf-8", "surrogateescape"), "bit flips"
    if op == "deep":
        return text + "deep: " + "[" * 400 + "]" * 400 + "\n", "deep nesting"
    if op == "type" and values:
        lines[i] = re.sub(r"^(\s*-?\s*)([a-z_]+):", r"\1no_such_node:", lines[i], count=1)
        return "\n".join(lines) + "\n", f"unknown type at line {i + 1}"
    return text, "unchanged"


def write(path: Path, text: str) -> None:
    path.write_bytes(text.encode("utf-8", "surrogateescape"))


# ---------------------------------------------------------------------------
# The families
# ---------------------------------------------------------------------------


def family_trees_check(work: Path, pool: list[Worker], n: int, rng: random.Random) -> list[Result]:
    results = [*corpus_results("trees-check", TREES, work, pool[0])]
    for k in range(n - len(results)):
        name = SHIPPED_TREES[k % len(SHIPPED_TREES)]
        text, what = mutate(shipped("tree", name), rng)
        folder = work / f"tc{k}"
        folder.mkdir()
        write(folder / f"{name}.yaml", text)
        argv = ["check", f"{name}.yaml", "--rig", SIM_RIGS[k % len(SIM_RIGS)]]
        if name in ("search", "track", "touch_tag"):
            argv += ["--set", "tag=duckybot"]
        res = pool[k % len(pool)].run(argv, folder, 60)
        results.append(command_result("trees-check", f"{name}: {what}", res, (0, 2), 60))
    return results


def corpus_results(family: str, cases: Iterable[Any], work: Path, worker: Worker) -> list[Result]:
    out = []
    for k, case in enumerate(cases):
        folder = work / f"corpus-{family}-{k}"
        folder.mkdir()
        write_case(case, folder)
        res = worker.run([*case.command, *case.argv], folder, 60)
        out.append(command_result(family, f"corpus: {case.name}", res, (case.code,), 60))
    return out


def family_edges(work: Path, pool: list[Worker], n: int, rng: random.Random) -> list[Result]:
    """Issue 32's corpus: output paths, numbers, images and inputs that are no file."""
    return corpus_results("edges", EDGES, work, pool[0])


def component_params() -> list[tuple[str, str, Any]]:
    """(section, type, Param) of every parameter of every shipped component type."""
    from armtree.hooks.plugin_manager import get_plugin_manager

    registry = get_plugin_manager().registry
    out = []
    for section, kind in (
        ("arm", "arm"),
        ("camera", "camera"),
        ("tracker", "tracker"),
        ("planner", "planner"),
    ):
        for ctype in registry.names(kind):
            for p in registry.get(kind, ctype).params:
                out.append((section, ctype, p))
    return out


RIG_OF = {
    "dobot_v1": "sim_dobot",
    "vicra": "sim_vicra",
    "dobot_magician": "sim_magician",
    "dh": "sim_dh",
}


def family_profiles_check(
    work: Path, pool: list[Worker], n: int, rng: random.Random
) -> list[Result]:
    results = [*corpus_results("profiles-check", PROFILES, work, pool[0])]
    params = [p for p in component_params() if p[0] != "arm" or p[1] in RIG_OF]
    k = 0
    while len(results) < n:
        section, ctype, param = params[k % len(params)]
        value = HOSTILE_VALUES[(k // len(params) * 7 + k) % len(HOSTILE_VALUES)]
        rig = RIG_OF.get(ctype, SIM_RIGS[k % len(SIM_RIGS)])
        sets = ["--set", f"{section}.{param.name}={value}"]
        if section != "arm" and rng.random() < 0.5:
            sets = ["--set", f"{section}.type={ctype}", *sets]
        folder = work / f"pc{k}"
        folder.mkdir()
        write(folder / "t.yaml", "root: {success: {}}\n")
        res = pool[k % len(pool)].run(["check", "t.yaml", "--rig", rig, *sets], folder, 60)
        results.append(
            command_result("profiles-check", f"{rig} {' '.join(sets[1::2])[:80]}", res, (0, 2), 60)
        )
        k += 1
    return results


def edge_values(param: Any) -> list[str]:
    """Valid values at the edges of a parameter's declared range, and its choices."""
    if param.choices:
        return [json.dumps(c) for c in param.choices]
    if param.type == "bool":
        return ["true", "false"]
    out = []
    for bound in (param.minimum, param.maximum):
        if bound is None or param.type not in ("int", "float"):
            continue
        out.append(str(int(bound)) if param.type == "int" else repr(float(bound)))
    if param.exclusive_minimum is not None and param.type == "float":
        out.append(repr(param.exclusive_minimum + 1e-3))
    if param.type in ("int", "float") and param.minimum is not None and param.maximum is not None:
        middle = (param.minimum + param.maximum) / 2  # inside the range, away from both ends
        out.append(str(int(middle)) if param.type == "int" else repr(float(middle)))
    return out


RUN_TREE = "rig: {rig}\nroot:\n  sequence:\n    - move_to: {{to: home}}\n    - move_to: {{to: home, offset: [0, 0, 10]}}\n"


def family_profiles_run(work: Path, pool: list[Worker], n: int, rng: random.Random) -> list[Result]:
    cases = []
    skip = {"port", "device", "path", "calibration", "progress", "dictionary"}
    for section, ctype, param in component_params():
        if param.name in skip or (section == "arm" and ctype not in RIG_OF):
            continue
        if section in ("camera", "tracker") and ctype not in ("sim", "aruco", "hamming"):
            continue
        if section == "planner" and ctype not in ("prm", "direct"):
            continue
        for value in edge_values(param):
            cases.append((section, ctype, param.name, value))
    rng.shuffle(cases)
    results = []
    for k, (section, ctype, name, value) in enumerate(cases[:n]):
        rig = RIG_OF.get(ctype, SIM_RIGS[k % len(SIM_RIGS)])
        folder = work / f"pr{k}"
        folder.mkdir()
        write(folder / "t.yaml", RUN_TREE.format(rig=rig))
        sets = [f"{section}.{name}={value}"]
        if section != "arm":
            sets.insert(0, f"{section}.type={ctype}")
        argv = ["run", "t.yaml", "--quiet", "--timeout", "30", "--record", "rec"]
        for s in sets:
            argv += ["--set", s]
        res = pool[k % len(pool)].run(argv, folder, 180)
        results.append(
            command_result("profiles-run", f"{rig} {' '.join(sets)}", res, (0, 1, 2, 3), 180)
        )
    return results


RUN_TREES = [
    ("touch_tag.yaml", ["--set", "tag=duckybot"]),
    ("pick_and_place.yaml", []),
    ("clean_up.yaml", []),
    ("search.yaml", ["--set", "tag=duckybot"]),
]
EDGE_TREES = [
    "rig: {rig}\ntick_hz: 1000\nroot: {{move_to: {{to: home}}}}\n",
    "rig: {rig}\ntick_hz: 0.1\nroot: {{move_to: {{to: home}}}}\n",
    "rig: {rig}\nroot: {{retry: {{num_failures: 1000000, child: {{failure: {{}}}}}}}}\n",
    "rig: {rig}\nroot: {{timeout: {{duration: 0.0001, child: {{move_to: {{to: home}}}}}}}}\n",
    "rig: {rig}\nroot: {{search: {{tag: duckybot, sweeps: 100, frames: 100}}}}\n",
    "rig: {rig}\nroot: {{move_to: {{to: home, offset: [0, 0, 5000]}}}}\n",
    "rig: {rig}\nroot: {{track: {{tag: duckybot, lost_frames: 1, period_s: 0.01, still_s: 0}}}}\n",
    'rig: {rig}\nblackboard: {{p: [1, 2, 3]}}\nroot: {{move_to: {{to: "{{p}}"}}}}\n',
]


def family_trees_run(work: Path, pool: list[Worker], n: int, rng: random.Random) -> list[Result]:
    results = []
    for k in range(n):
        rig = SIM_RIGS[k % len(SIM_RIGS)]
        folder = work / f"tr{k}"
        folder.mkdir()
        if k % 3 == 0:
            name, extra = RUN_TREES[(k // 3) % len(RUN_TREES)]
            argv = ["run", name, "--rig", rig, *extra]
            what = name
        else:
            write(folder / "t.yaml", EDGE_TREES[k % len(EDGE_TREES)].format(rig=rig))
            argv = ["run", "t.yaml"]
            what = EDGE_TREES[k % len(EDGE_TREES)].splitlines()[-1][:60]
        argv += [
            "--quiet",
            "--timeout",
            "120",
            "--max-ticks",
            "20000",
            "--record",
            "rec",
            "--seed",
            str(k),
        ]
        res = pool[k % len(pool)].run(argv, folder, 300)
        results.append(command_result("trees-run", f"{rig} {what}", res, (0, 1, 2, 3), 300))
    return results


# -- serial faults: driver against emulator in-process, one case per worker call ----------

SERIAL = r"""
import json, math, sys, time, threading
import numpy as np
from armtree.api.clock import VirtualClock
from armtree.api.emulation import SHARED_KEY
from armtree.errors import HardwareFault
from armtree.api.rig import RigContext
from armtree.loader.profile import load_profile
from armtree.hooks.plugin_manager import get_plugin_manager
from armtree.plugins.arms.common.plausibility import LIMIT_MARGIN

variant, mode, seed = sys.argv[1], sys.argv[2], int(sys.argv[3])
rig = {"dobot_v1": "sim_dobot", "dobot_v1_opendobot": "sim_dobot", "vicra": "sim_vicra",
       "dobot_magician": "sim_magician", "dh": "sim_dh"}[variant]
profile = load_profile(rig)
config = dict(profile.component("arm"))
if variant == "dobot_v1_opendobot":
    config["firmware"] = "open-dobot"
factory = get_plugin_manager().registry.get("arm", config["type"]).factory
clock = VirtualClock()
faults = []
ctx = RigContext(profile=profile, clock=clock, seed=seed,
                 interrupt=lambda reason, fault=None: faults.append(str(fault)))
arm = factory(config, ctx)
emu = ctx.shared[SHARED_KEY]
rng = np.random.default_rng(seed)
model = arm.model
lo, hi = np.asarray(model.lower) - LIMIT_MARGIN - 1e-6, np.asarray(model.upper) + LIMIT_MARGIN + 1e-6
bad_believed = []

def step(dt=0.05):
    now = clock.advance(dt)
    for s in ctx.steppers:
        s(now)

def noise(n):
    import os
    try:
        os.write(emu._master, rng.integers(0, 256, n, dtype=np.uint8).tobytes())
    except OSError:
        pass

def inject():
    m = mode
    if m == "corrupt-burst": emu.inject("corrupt", count=200)
    elif m == "drop-burst": emu.inject("drop", count=200)
    elif m.startswith("corrupt") or m.startswith("drop"):
        kind, rate = m.split("-")
        emu.inject(kind, rate=float(rate))
    elif m == "cut": emu.inject("cut")
    elif m == "cut-silent": emu.inject("cut", silent=1)
    elif m == "missed-steps": emu.inject("missed_steps", joint=0, amount=5.0)

outcome = {"connected": False, "lost": False, "moves_done": 0, "moves_failed": 0, "error": ""}
t0 = time.monotonic()
try:
    if mode == "noise-only":
        emu.inject("cut", silent=1)
        threading.Thread(target=lambda: [noise(300) or time.sleep(0.01) for _ in range(100)], daemon=True).start()
    arm.connect()
    outcome["connected"] = True
    for _ in range(4): step()
    if mode not in ("noise-only",):
        inject()
    home = np.asarray(model.home, dtype=float)
    targets = []
    for scale in (0.0, 0.15, -0.15, 0.0):
        span = (np.asarray(model.upper) - np.asarray(model.lower)) * scale
        targets.append(np.clip(home + span, model.lower, model.upper))
    for k, q in enumerate(targets):
        h = arm.move_joints(q, 0.5)
        for _ in range(400):
            if mode in ("noise-flood", "ok-noise", "noise-only") and k >= 0:
                if mode == "ok-noise":
                    import os
                    try: os.write(emu._master, b"ok\nok T:0\n")
                    except OSError: pass
                else:
                    noise(64)
                time.sleep(0.002)
            if mode in ("cut", "cut-silent", "noise-flood", "ok-noise"):
                time.sleep(0.002)
            step()
            try:
                q_now = np.asarray(arm._believed() if hasattr(arm, "_believed") else arm.joints(), dtype=float)
            except HardwareFault:
                q_now = None
            if q_now is not None and (not np.all(np.isfinite(q_now)) or np.any(q_now < lo) or np.any(q_now > hi)):
                bad_believed.append(q_now.tolist())
            if h.done or faults:
                break
        if h.status.name == "DONE": outcome["moves_done"] += 1
        else: outcome["moves_failed"] += 1
        if faults: break
except HardwareFault as exc:
    outcome["error"] = f"HardwareFault: {exc}"
except Exception as exc:
    outcome["error"] = f"RAW {type(exc).__name__}: {exc}"
finally:
    outcome["lost"] = bool(faults) or outcome["error"].startswith("HardwareFault")
    outcome["faults"] = faults[:1]
    outcome["bad_believed"] = bad_believed[:3]
    outcome["seconds"] = time.monotonic() - t0
    try:
        arm.close()
    except Exception as exc:
        outcome["error"] += f" close: RAW {type(exc).__name__}"
    for c in reversed(ctx.closers):
        try: c()
        except Exception: pass
print("RESULT " + json.dumps(outcome))
"""

VARIANTS = ("dobot_v1", "dobot_v1_opendobot", "dobot_magician", "vicra", "dh")
MODES = (
    "none",
    "corrupt-0.001",
    "corrupt-0.01",
    "corrupt-0.05",
    "corrupt-0.2",
    "corrupt-1.0",
    "drop-0.01",
    "drop-0.05",
    "drop-0.2",
    "corrupt-burst",
    "drop-burst",
    "cut",
    "cut-silent",
    "noise-flood",
    "ok-noise",
    "noise-only",
    "missed-steps",
)


def family_serial(work: Path, pool: list[Worker], n: int, rng: random.Random) -> list[Result]:
    script = work / "serial_case.py"
    script.write_text(SERIAL)
    cases = [(variant, k, mode) for variant in VARIANTS for k, mode in enumerate(MODES)]
    # One case per process, as many at once as there are workers: most of a case is waiting.
    with ThreadPoolExecutor(max_workers=max(1, len(pool))) as threads:
        return list(threads.map(lambda case: serial_case(script, *case), cases))


def serial_case(script: Path, variant: str, k: int, mode: str) -> Result:
    """One arm variant under one link fault, driver against emulator in a fresh process."""
    t = time.monotonic()
    try:
        done = subprocess.run(
            [sys.executable, str(script), variant, mode, str(k)],
            capture_output=True,
            text=True,
            timeout=240,
        )
    except subprocess.TimeoutExpired:
        return Result("serial", f"{variant} {mode}", False, None, 240, "hang")
    line = next((ln for ln in done.stdout.splitlines() if ln.startswith("RESULT ")), None)
    if line is None:
        return Result(
            "serial",
            f"{variant} {mode}",
            False,
            done.returncode,
            time.monotonic() - t,
            "crashed: " + done.stderr[-300:],
        )
    out = json.loads(line[7:])
    why = ""
    if out["bad_believed"]:
        why = f"believed {out['bad_believed'][0]}"
    elif "RAW" in out["error"]:
        why = out["error"][:120]
    elif not (out["lost"] or out["moves_done"] + out["moves_failed"] > 0):
        why = "neither worked nor lost the link"
    elif out["moves_failed"] and not out["lost"] and mode in ("none",):
        why = "a move failed on a clean link"
    print(f"  {variant} {mode}: {why or 'clean'}", flush=True)
    return Result(
        "serial", f"{variant} {mode}", not why, done.returncode, time.monotonic() - t, why, out
    )


# -- interrupts: real signals into real processes ------------------------------------------


def family_interrupts(work: Path, pool: list[Worker], n: int, rng: random.Random) -> list[Result]:
    run_tree = Path(sys.executable).with_name("run-tree")
    results = []
    kinds = [
        "startup",
        "loading",
        "running",
        "running-realtime",
        "paused-realtime",
        "stuck-spin",
        "stuck-sleep",
        "double",
        "watchdog",
    ]
    for k in range(n):
        kind = kinds[k % len(kinds)]
        # SIGHUP (a closed terminal) and SIGQUIT (Ctrl-\) stop a run as SIGTERM does
        sig = STOP_SIGNALS[(k + k // len(kinds)) % len(STOP_SIGNALS)]
        folder = work / f"int{k}"
        folder.mkdir()
        (folder / "stuck.py").write_text(STUCK_PLUGIN)
        expect = 130
        args = [str(run_tree)]
        wait_for: Callable[[], bool] = lambda: True  # noqa: E731
        delay = 0.0
        if kind == "startup":
            args += ["touch_tag.yaml", "--set", "tag=duckybot"]
            delay = rng.uniform(0.3, 1.5)
        elif kind == "loading":
            args += ["load_ducky.yaml"]
            delay = rng.uniform(1.0, 3.0)
        elif kind in ("running", "running-realtime", "paused-realtime", "double"):
            args += ["load_ducky.yaml", "--record", "rec", "--seed", str(k)]
            if kind in ("running-realtime", "paused-realtime"):
                args.append("--realtime")
            wait_for = lambda f=folder: (f / "rec" / "run.jsonl").exists()  # noqa: E731
            delay = rng.uniform(0.2, 4.0)
        else:
            node = "spin_forever" if kind in ("stuck-spin", "watchdog") else "sleep_forever"
            rig = "rig: sim_dobot\n" if kind == "watchdog" else ""
            write(
                folder / "t.yaml",
                f"{rig}plugins: [./stuck.py]\nroot:\n  sequence:\n    - tick_counter: {{duration: 3, completion_status: SUCCESS}}\n    - {node}: {{}}\n",
            )
            args += ["t.yaml", "--record", "rec"]
            if kind == "watchdog":
                args += ["--set", "watchdog.tick_s=1"]
                expect = 3
            wait_for = lambda f=folder: (f / "stuck").exists()  # noqa: E731
            delay = rng.uniform(0.0, 1.0)
        args.append("--quiet")
        t0 = time.monotonic()
        printed = folder / "stdout.txt"
        proc = subprocess.Popen(
            args,
            cwd=folder,
            stdout=printed.open("w"),
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        deadline = time.monotonic() + 120
        while not wait_for() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(delay)
        if kind == "paused-realtime" and proc.poll() is None:
            # Ctrl-Z and fg: a pause of the process is no link fault (issue 32)
            proc.send_signal(signal.SIGSTOP)
            time.sleep(rng.uniform(1.0, 3.0))
            proc.send_signal(signal.SIGCONT)
            time.sleep(1.0)
        sent = time.monotonic()
        # A run that ended before the signal went out is no interrupt case: judged by its code.
        # So is one whose summary is out: the signal lands while the process leaves,
        # and the command keeps its code.
        ended_first = kind != "watchdog" and (
            proc.poll() is not None or "result:" in printed.read_text()
        )
        if kind != "watchdog" and proc.poll() is None:
            proc.send_signal(sig)
            if kind == "double":
                time.sleep(0.05)
                proc.send_signal(sig)
        try:
            code = proc.wait(timeout=20 if kind != "watchdog" else 30)
            err = proc.stderr.read() if proc.stderr else ""
        except subprocess.TimeoutExpired:
            proc.kill()
            results.append(
                Result(
                    "interrupts", f"{kind} {sig.name}", False, None, time.monotonic() - t0, "hang"
                )
            )
            continue
        stop_s = time.monotonic() - sent
        why = ""
        if code == -sig and kind == "startup":
            why = ""  # killed by the signal before Python handed over: nothing started
        elif ended_first and code == 0:
            why = ""
        elif code != expect and not (kind == "startup" and code == 0 and stop_s > 5):
            why = f"exit {code}"
        if RAW.search(err):
            why = "traceback"
        if kind == "paused-realtime" and "link lost" in err:
            why = "a pause read as a lost link"
        log = folder / "rec" / "run.jsonl"
        if not why and log.exists() and kind not in ("startup", "loading"):
            last = log.read_text().strip().splitlines()[-1]
            if json.loads(last).get("kind") != "result" and kind != "double":
                why = "log not flushed with its result"
        results.append(Result("interrupts", f"{kind} {sig.name}", not why, code, stop_s, why))
        print(f"  {k + 1:3d} {results[-1].name}: exit {code}, {why or 'clean'}", flush=True)
    return results


FAMILIES: dict[str, tuple[Callable[..., list[Result]], int, int]] = {
    # name: (function, full count, quick count)
    "trees-check": (family_trees_check, 420, 60),
    "profiles-check": (family_profiles_check, 320, 60),
    "trees-run": (family_trees_run, 64, 8),
    "profiles-run": (family_profiles_run, 136, 12),
    "edges": (family_edges, 0, 0),
    "serial": (family_serial, 85, 85),
    "interrupts": (family_interrupts, 63, 18),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--families", default=",".join(FAMILIES))
    parser.add_argument("--quick", action="store_true", help="fewer cases per family")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=17)
    parser.add_argument("--out", type=Path, default=None, help="write results.json here")
    args = parser.parse_args(argv)
    rng = random.Random(args.seed)
    pool = [Worker() for _ in range(args.workers)]
    summary = {}
    all_results: list[Result] = []
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        for name in args.families.split(","):
            fn, full, quick = FAMILIES[name]
            work = Path(tmp) / name
            work.mkdir()
            t = time.monotonic()
            results = fn(work, pool, quick if args.quick else full, rng)
            all_results += results
            clean = sum(r.clean for r in results)
            why = Counter(r.why for r in results if not r.clean)
            summary[name] = {
                "cases": len(results),
                "clean": clean,
                "percent": round(100.0 * clean / max(1, len(results)), 1),
                "seconds": round(time.monotonic() - t, 1),
                "unclean": dict(why.most_common(6)),
            }
            print(
                f"{name:15} {clean:4d} / {len(results):4d} clean ({summary[name]['percent']:5.1f} %) "
                f"in {summary[name]['seconds']:.0f} s  {dict(why.most_common(3)) if why else ''}",
                flush=True,
            )
            for r in results:
                if not r.clean:
                    print(f"    unclean: {r.name[:90]}: {r.why[:140]}", flush=True)
    for w in pool:
        w.kill()
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "results.json").write_text(
            json.dumps({"summary": summary, "cases": [asdict(r) for r in all_results]}, indent=1)
        )
    return 0 if all(s["clean"] == s["cases"] for s in summary.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
