"""Every command block of the README works as written.

A ``bash`` block runs line by line in one scratch folder shared by the whole
README, in order, so a later block may use what an earlier one wrote (``out/``);
each command must exit 0. A comment line ``<!-- readme-test: KIND ... -->`` right
before a block says how to test it instead:

* ``install``: the install has been done (this suite runs in it); the commands
  that follow the ``pip install`` run;
* ``interrupt after N s``: commands that serve or run on the wall clock get
  Ctrl-C after N seconds and must stop cleanly (exit 0 or 130, no traceback);
* ``hardware``: they need a device; every ``run-tree`` line is checked with
  ``armtree check`` (same tree, profile and ``--set``), which must pass;
* ``skip (why)``: not run, and the reason is required.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BIN = Path(sys.executable).parent
MARK = re.compile(r"<!--\s*readme-test:\s*(\w+)(.*?)-->")
KINDS = ("run", "install", "interrupt", "hardware", "skip")


@dataclass
class Block:
    """One ``bash`` block of the README: its first line number, how to test it, its commands."""

    line: int
    kind: str
    detail: str
    commands: list[str]


def readme_blocks(text: str) -> list[Block]:
    """The README's ``bash`` blocks in order, with the mark before each (default ``run``)."""
    blocks: list[Block] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].strip() != "```bash":
            i += 1
            continue
        mark = MARK.search(lines[i - 1]) if i else None
        body = []
        j = i + 1
        while lines[j].strip() != "```":
            body.append(lines[j])
            j += 1
        commands = [_strip_comment(line) for line in body]
        blocks.append(
            Block(
                i + 1,
                mark.group(1) if mark else "run",
                mark.group(2).strip() if mark else "",
                [c for c in commands if c],
            )
        )
        i = j + 1
    return blocks


def _strip_comment(line: str) -> str:
    """The command without its trailing ``# comment`` (the README's commands quote no ``#``)."""
    return re.sub(r"(^|\s)#.*$", "", line).strip()


def _env() -> dict[str, str]:
    env = dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}")
    env.pop("ARMTREE_DISABLE_PLUGIN_AUTOLOAD", None)
    return env


def _run(command: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        command, shell=True, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=300
    )


def _interrupted(command: str, cwd: Path, seconds: float) -> tuple[int, str]:
    proc = subprocess.Popen(
        shlex.split(command),
        cwd=cwd,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        proc.wait(timeout=seconds)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, out


def _after_install(command: str) -> list[str]:
    """The commands of an install line after its ``pip install ...`` step."""
    steps = [s.strip() for s in command.split("&&")]
    last = max((i for i, s in enumerate(steps) if s.startswith("pip install")), default=-1)
    return steps[last + 1 :]


def test_the_readme_marks_are_known_and_explained():
    blocks = readme_blocks(README.read_text())
    assert len(blocks) >= 4
    for block in blocks:
        assert block.kind in KINDS, f"README line {block.line}: unknown readme-test {block.kind!r}"
        if block.kind == "skip":
            assert block.detail, f"README line {block.line}: say why the block is skipped"
        if block.kind == "interrupt":
            assert re.search(r"\d+\s*s", block.detail), f"README line {block.line}: after N s"


def test_block_parsing(tmp_path):
    text = (
        "x\n```bash\nrun-tree a.yaml   # note\n\narmtree check a.yaml\n```\n"
        "<!-- readme-test: hardware (a Dobot) -->\n```bash\nrun-tree b.yaml --set x=1\n```\n"
        "```python\nprint(1)\n```\n"
    )
    blocks = readme_blocks(text)
    assert [(b.kind, b.commands) for b in blocks] == [
        ("run", ["run-tree a.yaml", "armtree check a.yaml"]),
        ("hardware", ["run-tree b.yaml --set x=1"]),
    ]
    assert _after_install("python3.11 -m venv .venv && pip install . && run-tree x") == [
        "run-tree x"
    ]


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_every_readme_command_block_works_as_written(tmp_path):
    failures = []
    blocks = readme_blocks(README.read_text())
    plain = {c for b in blocks if b.kind == "run" for c in b.commands}
    for block in blocks:
        if block.kind == "skip":
            continue
        for command in block.commands:
            where = f"README line {block.line}: {command}"
            if block.kind == "install":
                for step in _after_install(command):
                    if step in plain:
                        continue  # run below as written, once
                    done = _run(step, tmp_path)
                    if done.returncode != 0:
                        failures.append(f"{where}: exit {done.returncode}\n{done.stderr[-800:]}")
            elif block.kind == "interrupt":
                seconds = float(re.search(r"(\d+)\s*s", block.detail).group(1))
                started = time.monotonic()
                code, out = _interrupted(command, tmp_path, seconds)
                if code not in (0, 130) or "Traceback" in out:
                    failures.append(
                        f"{where}: exit {code} after {time.monotonic() - started:.0f} s\n{out[-800:]}"
                    )
            elif block.kind == "hardware":
                words = shlex.split(command)
                if words[0] != "run-tree":
                    continue
                done = _run(shlex.join(["armtree", "check", *words[1:]]), tmp_path)
                if done.returncode != 0:
                    failures.append(f"{where}: armtree check says\n{done.stderr[-800:]}")
            else:
                done = _run(command, tmp_path)
                if done.returncode != 0:
                    failures.append(f"{where}: exit {done.returncode}\n{done.stderr[-800:]}")
    assert failures == [], "\n\n".join(failures)
