"""The hostile inputs of issue 17, kept as a fixed corpus so each stays fixed.

Each :class:`Case` is a set of files written to an empty folder and the arguments
of ``armtree check``; ``code`` is the exit code it must give, ``message`` a piece
of the error and ``where`` the start of the error's first line (a ``FILE:LINE:COL``
or the command-line option it is about; ending in ": ", a file without a line). ``tests/test_hostile_corpus.py`` runs
them in the suite; ``benchmarks/bench_hostile.py`` uses them as one family of its
figures.
"""

from __future__ import annotations

import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class Case:
    """One hostile input for ``armtree check`` (or ``command``) and what it must give.

    ``special`` makes paths that are no regular file: ``"folder"``, ``"fifo"``, or
    ``"link:TARGET"`` (a symbolic link to TARGET), written by :func:`write_case`.
    """

    name: str
    argv: tuple[str, ...]
    code: int = 2
    message: str = ""
    where: str = ""
    files: dict[str, str | bytes] = field(default_factory=dict)
    command: tuple[str, ...] = ("check",)
    special: dict[str, str] = field(default_factory=dict)


def write_case(case: Case, folder: Path) -> None:
    """The files and special paths of ``case`` made in ``folder``."""
    for name, content in case.files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    for name, kind in case.special.items():
        path = folder / name
        if kind == "folder":
            path.mkdir(parents=True, exist_ok=True)
        elif kind == "fifo":
            os.mkfifo(path)
        elif kind.startswith("link:"):
            path.symlink_to(kind[5:])
        else:
            raise ValueError(f"unknown special path {kind!r}")


def laughs(prefix: str = "l", levels: int = 10) -> str:
    """The "billion laughs": ten levels of ten aliases each (10**10 values expanded)."""
    lines = [f"{prefix}0: &{prefix}0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for i in range(1, levels):
        refs = ", ".join([f"*{prefix}{i - 1}"] * 10)
        lines.append(f"{prefix}{i}: &{prefix}{i} [{refs}]")
    return "\n".join(lines) + "\n"


def _indented_bomb() -> str:
    """A bomb (anchors b0..b9) indented to sit under a key of a mapping."""
    return "\n".join("  " + line for line in laughs("b").splitlines())


def _nested_inverters(n: int) -> str:
    text = "success: {}"
    for _ in range(n):
        text = f"inverter: {{child: {{{text}}}}}"
    return "root: {" + text + "}\n"


def _include_bomb() -> dict[str, str]:
    """Ten files, each including the next ten times: 10**9 nodes if built."""
    files = {}
    for i in range(9):
        kids = "\n".join([f"      - subtree: {{file: f{i + 1}.yaml}}"] * 10)
        files[f"f{i}.yaml"] = f"root:\n  sequence:\n    children:\n{kids}\n"
    files["f9.yaml"] = "root: {success: {}}\n"
    return files


#: A plugin whose behaviours never return from a tick: they touch a file named "stuck"
#: first, so a test knows the tick has started, then spin or sleep for ever.
STUCK_PLUGIN = '''
import time
import armtree
from py_trees.common import Status


class Spin(armtree.Behaviour):
    """Busy-loops in update."""

    def update(self):
        open("stuck", "w").close()
        while True:
            pass


class Sleep(armtree.Behaviour):
    """Sleeps for ever in update."""

    def update(self):
        open("stuck", "w").close()
        time.sleep(1e6)
        return Status.RUNNING


@armtree.hookimpl
def armtree_behaviours():
    return {"spin_forever": Spin, "sleep_forever": Sleep}
'''

SIMPLE = "rig: sim_dobot\nroot: {move_to: {to: home}}\n"

TREES: list[Case] = [
    Case(
        "bomb in the blackboard",
        ("t.yaml",),
        message="aliases expanded",
        where="t.yaml:6:10",
        files={"t.yaml": laughs() + "blackboard: {x: *l9}\nroot: {success: {}}\n"},
    ),
    Case(
        "bomb in a parameter",
        ("t.yaml",),
        message="aliases expanded",
        where="t.yaml:",
        files={"t.yaml": "anchors:\n" + _indented_bomb() + "\nroot: {success: {name: *b9}}\n"},
    ),
    Case(
        "bomb in a node name",
        ("t.yaml",),
        message="aliases expanded",
        where="t.yaml:",
        files={"t.yaml": "junk:\n" + _indented_bomb() + "\nroot: {success: {name: *b9}}\n"},
    ),
    Case(
        "bomb in a default",
        ("t.yaml",),
        message="aliases expanded",
        where="t.yaml:",
        files={
            "t.yaml": "x:\n" + _indented_bomb() + "\nparams: {p: {default: *b9}}\n"
            "root: {success: {}}\n"
        },
    ),
    Case(
        "bomb in an included file",
        ("t.yaml",),
        message="aliases expanded",
        where="inner.yaml:",
        files={
            "t.yaml": "root: {subtree: {file: inner.yaml}}\n",
            "inner.yaml": laughs() + "root: {success: {}}\n",
        },
    ),
    Case(
        "recursive alias",
        ("t.yaml",),
        message="recursive alias",
        where="t.yaml:1:",
        files={"t.yaml": "blackboard: {x: &a [*a]}\nroot: {success: {}}\n"},
    ),
    Case(
        "498 nested inverters",
        ("t.yaml",),
        message="nesting deeper than",
        where="t.yaml:1:",
        files={"t.yaml": _nested_inverters(498)},
    ),
    Case(
        "a 2,000-deep --set list",
        ("t.yaml", "--set", "x=" + "[" * 2000 + "]" * 2000),
        message="not valid YAML",
        where="--set",
        files={"t.yaml": "root: {success: {}}\n"},
    ),
    Case(
        "a 400-digit tick_hz",
        ("t.yaml",),
        message="tick_hz",
        where="t.yaml:1:10",
        files={"t.yaml": "tick_hz: " + "9" * 400 + "\nroot: {success: {}}\n"},
    ),
    Case(
        "a 4,300-digit tick_hz",
        ("t.yaml",),
        message="tick_hz",
        where="t.yaml:1:10",
        files={"t.yaml": "tick_hz: " + "9" * 4300 + "\nroot: {success: {}}\n"},
    ),
    Case(
        "a 5,000-digit tick_hz",
        ("t.yaml",),
        message="as int",
        where="t.yaml:1:10",
        files={"t.yaml": "tick_hz: " + "9" * 5000 + "\nroot: {success: {}}\n"},
    ),
    Case(
        "!!float abc",
        ("t.yaml",),
        message="cannot read 'abc' as float",
        where="t.yaml:1:10",
        files={"t.yaml": "tick_hz: !!float abc\nroot: {success: {}}\n"},
    ),
    Case(
        "tick_hz 1e-300",
        ("t.yaml", "--set", "tick_hz=1.0e-300"),
        message="expected a rate from 0.1 to 1000 Hz",
        where="--set tick_hz",
        files={"t.yaml": "root: {success: {}}\n"},
    ),
    Case(
        "rig: ''",
        ("t.yaml",),
        message="no hardware profile ''",
        where="t.yaml:1:6",
        files={"t.yaml": "rig: ''\nroot: {success: {}}\n"},
    ),
    Case(
        "a 5,000-character include name",
        ("t.yaml",),
        message="not found",
        where="t.yaml:1:",
        files={"t.yaml": "root: {subtree: {file: " + "a" * 5000 + ".yaml}}\n"},
    ),
    Case(
        "an include bomb",
        ("f0.yaml",),
        message="more than 20,000 nodes",
        where="f",
        files=_include_bomb(),
    ),
    Case(
        "search sweeps 1e9",
        ("t.yaml",),
        message="search.sweeps",
        where="t.yaml:1:",
        files={"t.yaml": "root: {search: {tag: duckybot, sweeps: 1000000000}}\n"},
    ),
    Case(
        "an unknown place",
        ("t.yaml",),
        message="unknown place 'nowhere'",
        where="t.yaml:2:22",
        files={"t.yaml": "rig: sim_dobot\nroot: {move_to: {to: nowhere}}\n"},
    ),
    Case(
        "an unknown tag role",
        ("t.yaml",),
        message="unknown tag role 'duckyboot'",
        where="t.yaml:2:",
        files={"t.yaml": "rig: sim_dobot\nroot: {search: {tag: duckyboot}}\n"},
    ),
    Case(
        'a "{}" binding',
        ("t.yaml",),
        message="names no blackboard key",
        where="t.yaml:2:22",
        files={"t.yaml": 'rig: sim_dobot\nroot: {move_to: {to: "{}"}}\n'},
    ),
    Case(
        "a position out of reach",
        ("t.yaml",),
        message="out of the reach",
        where="t.yaml:2:22",
        files={"t.yaml": "rig: sim_dobot\nroot: {move_to: {to: [900, 0, 0]}}\n"},
    ),
    Case(
        "a place out of reach, at the profile's line",
        ("t.yaml",),
        message="out of the arm's reach",
        where="p.yaml:2:",
        files={
            "p.yaml": "arm: {type: dobot_v1, port: sim}\nplaces: {far: [900, 0, 0]}\n",
            "t.yaml": "rig: p.yaml\nroot: {move_to: {to: far}}\n",
        },
    ),
    Case(
        "a camera the rig lacks",
        ("t.yaml",),
        message="needs a camera",
        where="t.yaml:2:",
        files={
            "p.yaml": "arm: {type: dobot_v1, port: sim}\ntags: {ducky: {id: 0, size_mm: 25}}\n"
            "places: {garbage_bin: [0, 185, 30]}\n",
            "t.yaml": "rig: p.yaml\nroot: {search: {tag: ducky, trash: ducky}}\n",
        },
    ),
    Case(
        "a tool the rig lacks",
        ("t.yaml", "--set", "arm.gripper=null"),
        message="needs a tool",
        where="t.yaml:",
        files={"t.yaml": "rig: sim_dh\nroot: {pick: {tag: ducky}}\n"},
    ),
    Case(
        "undecodable bytes",
        ("t.yaml",),
        message="not UTF-8",
        where="t.yaml:2:22",
        files={"t.yaml": b"root:\n  success: {name: caf\xe9}\n"},
    ),
    Case(
        "a control character",
        ("t.yaml",),
        message="U+0007",
        where="t.yaml:2:20",
        files={"t.yaml": "root:\n  success: {name: a\x07b}\n"},
    ),
    Case(
        "a file above the size limit",
        ("t.yaml",),
        message="larger than 2,000,000 bytes",
        where="t.yaml: ",  # the whole file: no line to point at
        files={"t.yaml": "root: {success: {}}\n" + "# padding\n" * 210_000},
    ),
    Case(
        "a decorator whose child is empty",  # found by the harness: a line deleted
        ("t.yaml",),
        message="child is empty",
        where="t.yaml:5:",
        files={"t.yaml": "rig: sim_dobot\nroot:\n  timeout:\n    duration: 1\n    child:\n"},
    ),
    Case("a valid tree", ("t.yaml",), code=0, files={"t.yaml": SIMPLE}),
]

PROFILES: list[Case] = [
    Case(
        "bomb in world:",
        ("t.yaml", "--rig", "p.yaml"),
        message="aliases expanded",
        where="p.yaml:",
        files={
            "t.yaml": "root: {success: {}}\n",
            "p.yaml": "arm: {type: dobot_v1, port: sim}\nworld:\n" + _indented_bomb() + "\n",
        },
    ),
    Case(
        "recursive alias in world:",
        ("t.yaml", "--rig", "p.yaml"),
        message="recursive alias",
        where="p.yaml:2:",
        files={
            "t.yaml": "root: {success: {}}\n",
            "p.yaml": "arm: {type: dobot_v1, port: sim}\nworld: &w {objects: *w}\n",
        },
    ),
    Case(
        "a bad number in the file",
        ("t.yaml", "--rig", "p.yaml"),
        message="camera.fps",
        where="p.yaml:2:",
        files={
            "t.yaml": "root: {success: {}}\n",
            "p.yaml": "arm: {type: dobot_v1, port: sim}\ncamera: {type: sim, fps: 0}\n",
        },
    ),
    Case(
        "a watchdog limit of 0",
        ("t.yaml", "--rig", "p.yaml"),
        message="watchdog.tick_s",
        where="p.yaml:2:20",
        files={
            "t.yaml": "root: {success: {}}\n",
            "p.yaml": "arm: {type: dobot_v1, port: sim}\nwatchdog: {tick_s: 0}\n",
        },
    ),
    Case(
        "a stall limit that is no number",
        ("t.yaml", "--rig", "p.yaml"),
        message="watchdog.stall_s: expected a number of seconds > 0 and <= 86400, got 'long'",
        where="p.yaml:2:32",
        files={
            "t.yaml": "root: {success: {}}\n",
            "p.yaml": "arm: {type: dobot_v1, port: sim}\nwatchdog: {tick_s: 1, stall_s: long}\n",
        },
    ),
    Case(
        "the planner's cache folder in YAML",
        ("t.yaml", "--rig", "p.yaml"),
        message="no parameter 'cache_dir'",
        where="p.yaml:2:",
        files={
            "t.yaml": "root: {success: {}}\n",
            "p.yaml": "arm: {type: dobot_v1, port: sim}\nplanner: {type: prm, cache_dir: /tmp/x}\n",
        },
    ),
]

#: ``--set`` values on a shipped profile, each with the message it must give.
SETS: list[tuple[str, str, str]] = [
    ("sim_dobot", "camera.fps=0", "camera.fps"),
    ("sim_dobot", "arm.joint_scales=[0,1,1]", "arm.joint_scales"),
    ("sim_dobot", "planner.milestones=0", "planner.milestones"),
    ("sim_dobot", "arm.baud=-1", "arm.baud"),
    ("sim_dobot", "arm.status_period=0", "arm.status_period"),
    ("sim_dobot", "arm.status_period=-1", "arm.status_period"),
    ("sim_dobot", "arm.status_period=1e-9", "arm.status_period"),
    ("sim_dobot", "world.seed=-1", "world.seed"),
    ("sim_dobot", "world.faults={missed_steps: {joint: 99, amount: 5}}", "joint"),
    ("sim_dobot", "world.faults={missed_steps: {joint: 5, amount: 5}}", "does not exist"),
    ("sim_dobot", "world.faults={missed_steps: {joint: 1}}", "needs amount"),
    ("sim_dobot", "planner.cache_dir=5", "cache_dir"),
    ("sim_dobot", "arm.start_pose=[1,2]", "arm.start_pose"),
    ("sim_dobot", "camera.intrinsics={fx: a}", "camera.intrinsics.fx"),
    ("sim_dobot", "camera.width=100000", "camera.width"),
    ("sim_dobot", "camera.blur=1e6", "camera.blur"),
    ("sim_dobot", "tracker.detector={adaptiveThreshWinSizeMin: -5}", "OpenCV refuses"),
    ("sim_vicra", "arm.links_mm=[0,0]", "arm.links_mm"),
    ("sim_dh", "arm.servos=[]", "arm.servos"),
    ("sim_dobot", "workcell.survey={ring: {radius_mm: 185, step_deg: 1.0e-9}}", "step_deg"),
    (
        "sim_dobot",
        "workcell.survey={ring: {radius_mm: 185, range_deg: [-1.0e+300, 1.0e+300]}}",
        "range_deg",
    ),
    # found by the harness: the run's rig builder refused it without a position
    ("sim_magician", "planner.margin_mm=200.0", "planner.margin_mm: 200 mm is too wide"),
]

PROFILES += [
    Case(
        f"--set {value} on {rig}",
        ("t.yaml", "--rig", rig, "--set", value),
        message=message,
        where="--set",
        files={"t.yaml": "root: {success: {}}\n"},
    )
    for rig, value, message in SETS
]

TREE = {"t.yaml": "rig: sim_dobot\nroot: {success: {}}\n"}
RUN = ("run", "--quiet")

#: Output paths (issue 32): every command that writes refuses a bad path, exit 2 naming it.
OUTPUTS: list[Case] = [
    Case(
        "--record onto a file",
        ("t.yaml", "--record", "afile"),
        message="a file, not a folder",
        where="--record afile",
        files={**TREE, "afile": "x"},
        command=RUN,
    ),
    Case(
        "--record under a file",
        ("t.yaml", "--record", "afile/sub"),
        message="afile is a file, not a folder",
        where="--record afile/sub",
        files={**TREE, "afile": "x"},
        command=RUN,
    ),
    Case(
        "--record /dev/null",
        ("t.yaml", "--record", "/dev/null"),
        message="a device, not a folder",
        where="--record /dev/null",
        files=TREE,
        command=RUN,
    ),
    Case(
        "--record under /proc",
        ("t.yaml", "--record", "/proc/armtree-run"),
        message="cannot write there",
        where="--record /proc/armtree-run",
        files=TREE,
        command=RUN,
    ),
    Case(
        "--record ''",
        ("t.yaml", "--record", ""),
        message="an empty folder name",
        where="--record ''",
        files=TREE,
        command=RUN,
    ),
    Case(
        "--record onto an earlier run",
        ("t.yaml", "--record", "old"),
        message="already holds a run (run.jsonl)",
        where="--record old",
        files={**TREE, "old/run.jsonl": "{}\n"},
        command=RUN,
    ),
    Case(
        "--record onto an earlier run with --overwrite",
        ("t.yaml", "--record", "old", "--overwrite"),
        code=0,
        files={**TREE, "old/run.jsonl": "{}\n"},
        command=RUN,
    ),
    Case(
        "--annotate onto a file",
        ("img.png", "--annotate", "afile"),
        message="a file, not a folder",
        where="--annotate afile",
        files={"afile": "x"},
        special={"img.png": "link:/dev/null"},
        command=("detect",),
    ),
    Case(
        "--annotate under /proc",
        ("img.png", "--annotate", "/proc/armtree-annotated"),
        message="cannot write there",
        where="--annotate /proc/armtree-annotated",
        special={"img.png": "link:/dev/null"},
        command=("detect",),
    ),
    Case(
        "markers -o onto a folder",
        ("--family", "aruco", "--id", "1", "-o", "out.png"),
        message="a folder, not a file",
        where="-o out.png",
        special={"out.png": "folder"},
        command=("markers",),
    ),
    Case(
        "markers -o under a file",
        ("--family", "aruco", "--id", "1", "-o", "afile/m.png"),
        message="afile is a file, not a folder",
        where="-o afile/m.png",
        files={"afile": "x"},
        command=("markers",),
    ),
    Case(
        "markers -o /dev/null",
        ("--family", "aruco", "--id", "1", "-o", "/dev/null"),
        message="a device, not a file",
        where="-o /dev/null",
        command=("markers",),
    ),
    Case(
        "markers -o in a missing folder",
        ("--family", "aruco", "--id", "1", "-o", "nowhere/m.png"),
        message="no folder nowhere",
        where="-o nowhere/m.png",
        command=("markers",),
    ),
    Case(
        "show -o onto a folder",
        ("t.yaml", "-o", "out.txt"),
        message="a folder, not a file",
        where="-o out.txt",
        files=TREE,
        special={"out.txt": "folder"},
        command=("show",),
    ),
    Case(
        "show --format png -o under a file",
        ("t.yaml", "--format", "png", "-o", "afile/t.png"),
        message="afile is a file, not a folder",
        where="-o afile/t.png",
        files={**TREE, "afile": "x"},
        command=("show",),
    ),
    Case(
        "show -o ''",
        ("t.yaml", "-o", ""),
        message="an empty file name",
        where="-o ''",
        files=TREE,
        command=("show",),
    ),
]


def _png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims ``width`` x ``height`` px, with no pixels behind it."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b""))
        + chunk(b"IEND", b"")
    )


WAIT = "rig: sim_dobot\nroot:\n  sequence:\n    - move_to: {to: home}\n    - wait: {seconds: %s}\n"
EXPECT = (
    "rig: sim_dobot\nexpect:\n  - {object: ducky, at: ducky_pickup, within_mm: %s}\n"
    "root: {success: {}}\n"
)

#: Numbers (issue 32): NaN, infinities and negatives refused at load or on the command line.
NUMBERS: list[Case] = [
    Case(
        "wait -5 s",
        ("t.yaml",),
        message="expected a number >= 0 s",
        where="t.yaml:5:23",
        files={"t.yaml": WAIT % "-5"},
    ),
    Case(
        "wait .nan s",
        ("t.yaml",),
        message="finite",
        where="t.yaml:5:23",
        files={"t.yaml": WAIT % ".nan"},
    ),
    Case(
        "within_mm .nan",
        ("t.yaml",),
        message="within_mm: expected a finite tolerance",
        where="t.yaml:3:",
        files={"t.yaml": EXPECT % ".nan"},
    ),
    Case(
        "within_mm .inf",
        ("t.yaml",),
        message="within_mm: expected a finite tolerance",
        where="t.yaml:3:",
        files={"t.yaml": EXPECT % ".inf"},
    ),
    Case(
        "sweep --run-timeout nan",
        ("t.yaml", "--seeds", "1-2", "--run-timeout", "nan"),
        message="give a positive number of seconds",
        where="--run-timeout nan",
        files=TREE,
        command=("sweep",),
    ),
    Case(
        "sweep --timeout nan",
        ("t.yaml", "--seeds", "1-2", "--timeout", "nan"),
        message="give a positive number of seconds",
        where="--timeout nan",
        files=TREE,
        command=("sweep",),
    ),
    Case(
        "run-tree --timeout nan",
        ("t.yaml", "--timeout", "nan"),
        message="give a positive number of seconds",
        where="--timeout nan",
        files=TREE,
        command=RUN,
    ),
    Case(
        "run-tree --seed -1",
        ("t.yaml", "--seed", "-1"),
        message="give an integer >= 0",
        where="argument --seed",
        files=TREE,
        command=RUN,
    ),
    Case(
        "replay --port 99999",
        ("rec", "--port", "99999"),
        message="give 1-65535",
        where="argument --port",
        files={"rec/run.jsonl": "{}\n"},
        command=("replay",),
    ),
    Case(
        "markers --dpi 1000000 --size-mm 1000",
        ("--family", "aruco", "--id", "1", "--dpi", "1000000", "--size-mm", "1000", "-o", "m.png"),
        message="over the limit of 50 MP",
        where="--dpi 1e+06 --size-mm 1000",
        command=("markers",),
    ),
    Case(
        "markers --sheet at 2000 dpi",
        ("--family", "aruco", "--sheet", "1-4", "--dpi", "2000", "-o", "m.pdf"),
        message="an A4 page would be",
        where="--dpi 2000",
        command=("markers",),
    ),
    Case(
        "markers --dpi inf",
        ("--family", "aruco", "--id", "1", "--dpi", "inf", "-o", "m.png"),
        message="finite",
        where="--dpi inf",
        command=("markers",),
    ),
    Case(
        "detect --size-mm inf",
        ("img.png", "--size-mm", "inf"),
        message="finite",
        where="--size-mm inf",
        files={"img.png": _png_header(8, 8)},
        command=("detect",),
    ),
]

#: Images and inputs that are no file (issue 32): refused by what they are, before decoding.
INPUTS: list[Case] = [
    Case(
        "a PNG header of 100000 x 100000 px",
        ("huge.png",),
        message="over the limit of 50 MP",
        where="huge.png: ",
        files={"huge.png": _png_header(100_000, 100_000)},
        command=("detect",),
    ),
    Case(
        "a PNG header of 8000 x 7000 px",
        ("big.png",),
        message="8000 x 7000 px (56 MP)",
        where="big.png: ",
        files={"big.png": _png_header(8000, 7000)},
        command=("detect",),
    ),
    Case(
        "an image that is a FIFO",
        ("img.png",),
        message="a FIFO (named pipe), not an image",
        where="img.png: ",
        special={"img.png": "fifo"},
        command=("detect",),
    ),
    Case(
        "an image that is a folder",
        ("img.png",),
        message="a folder, not an image",
        where="img.png: ",
        special={"img.png": "folder"},
        command=("detect",),
    ),
    Case(
        "an image linked to /dev/zero",
        ("img.png",),
        message="a device, not an image",
        where="img.png: ",
        special={"img.png": "link:/dev/zero"},
        command=("detect",),
    ),
    Case(
        "a video linked to /dev/zero",
        ("v.mp4",),
        message="a device, not a video",
        where="v.mp4: ",
        special={"v.mp4": "link:/dev/zero"},
        command=("detect",),
    ),
    Case(
        "a tree that is a FIFO",
        ("t.yaml",),
        message="t.yaml is a FIFO",
        where="t.yaml: ",
        special={"t.yaml": "fifo"},
    ),
    Case(
        "a tree that is a folder",
        ("t.yaml",),
        message="t.yaml is a folder, not a file",
        where="t.yaml: ",
        special={"t.yaml": "folder"},
    ),
    Case(
        "a tree linked to /dev/zero",
        ("t.yaml",),
        message="t.yaml is a device, not a file",
        where="t.yaml: ",
        special={"t.yaml": "link:/dev/zero"},
    ),
    Case(
        "an include that is a FIFO",
        ("t.yaml",),
        message="inner.yaml is a FIFO",
        where="t.yaml:1:",
        files={"t.yaml": "root: {subtree: {file: inner.yaml}}\n"},
        special={"inner.yaml": "fifo"},
    ),
    Case(
        "a profile linked to /dev/zero",
        ("t.yaml", "--rig", "p.yaml"),
        message="p.yaml is a device, not a file",
        where="--rig p.yaml",
        files={"t.yaml": "root: {success: {}}\n"},
        special={"p.yaml": "link:/dev/zero"},
    ),
]

#: Devices (issue 32): a negative camera index segfaulted OpenCV's capture thread.
DEVICES: list[Case] = [
    Case(
        f"camera.device={value}",
        ("t.yaml", "--rig", "dobot_v1", "--set", "arm.port=sim", "--set", f"camera.device={value}"),
        message=message,
        where="--set camera.device",
        files={"t.yaml": "root: {success: {}}\n"},
        command=command,
    )
    for value, message, command in (
        ("-1", "camera.device: expected a number >= 0, got -1", ("check",)),
        ("-1", "camera.device: expected a number >= 0, got -1", RUN),
        (".nan", "camera.device: expected a number >= 0", ("check",)),
    )
] + [
    Case(
        f"--set camera.{key}={value}",
        ("t.yaml", "--rig", "dobot_v1", "--set", "arm.port=sim", "--set", f"camera.{key}={value}"),
        message=f"camera.{key}",
        where=f"--set camera.{key}",
        files={"t.yaml": "root: {success: {}}\n"},
    )
    for key, value in (("width", "-640"), ("fps", "0"), ("stall_timeout_s", "-1"))
]

#: Issue 32's cases, one family of benchmarks/bench_hostile.py.
EDGES: list[Case] = OUTPUTS + NUMBERS + INPUTS + DEVICES

CASES: list[Case] = TREES + PROFILES + EDGES
