"""Motion-planning benchmarks (issue 6), each against a baseline measured in the same run.

Run: ``python benchmarks/bench_planning.py [--quick]``.

* Triangle-triangle tests per second: the batched Moller test (pairs, and the
  arm-against-scene matrix layout). No peer tests triangle pairs one by one
  (python-fcl refuses TriangleP against TriangleP; its meshes are checked in the
  whole-arm rows); a plain-Python transcription of the test checks that every
  decision agrees, and is not a peer.
* Whole-arm collision check per configuration in batches of 1,000 (the Dobot
  V1.0 model's link boxes against a table and a wall, then also a 1,000-triangle
  tray mesh) against python-fcl doing the same check as its users would: a
  DynamicAABBTreeCollisionManager broad phase for arm against scene, the mesh
  as a BVH model, the self pairs by narrow phase.
* PRM with 1,000 milestones and the real collision check, and queries, against
  a plain networkx + cKDTree PRM with a trivial check, and OMPL's PRM through its
  Python bindings (trivial check, and our own checker as its validity function).
* Workspace covering of Rybak 2016's planar robot at delta 0.5 / 0.25 / 0.07
  against a naive generic interval class and a specialised plain-Python
  recursion; the Dobot V1.0's 3-D workspace to 1 mm.
* Batched analytic inverse kinematics for the planners.

python-fcl and OMPL come with ``pip install -e '.[bench]'`` and run in a
subprocess of this interpreter (``planning_peers.py``); without them those rows
say "not available".
Times are CPU seconds of the measuring process (``time.process_time``) with
BLAS held to one thread, so other work on the machine skews them less.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from armtree.maths.motion.collision import CollisionChecker  # noqa: E402
from armtree.maths.motion.meshio import write_stl_binary  # noqa: E402
from armtree.maths.motion.scene import Scene  # noqa: E402
from armtree.maths.motion.tritri import intersect_matrix, intersect_pairs, triangles_intersect  # noqa: E402
from armtree.maths.motion.workspace import ArmWorkspace, cover  # noqa: E402
from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model  # noqa: E402
from armtree.plugins.arms.vicra.kinematics import VicraModel  # noqa: E402
from armtree.plugins.planners.prm import PRMPlanner  # noqa: E402

BENCH_PYTHON = Path(os.environ.get("ARMTREE_BENCH_PYTHON", sys.executable))
#: The module each peer task imports.
PEER_MODULES = {"fcl": "fcl", "ompl": "ompl"}
ROWS: list[tuple[str, str, str]] = []


def row(name: str, value: str, note: str = "") -> None:
    """Record and print one figure."""
    ROWS.append((name, value, note))
    print(f"  {name:<58} {value:>22}  {note}", flush=True)


def cpu(fn, repeat: int = 3) -> float:
    """Best CPU time of ``repeat`` calls, seconds."""
    best = np.inf
    for _ in range(repeat):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return max(best, 1e-9)


#: The Dobot's table (a slab under the base) and a wall beside it.
SCENE_OBSTACLES = [
    {"box": {"center": [0, 0, -105], "size": [800, 800, 10], "name": "table"}},
    {"box": {"center": [0, 170, 0], "size": [400, 20, 200], "name": "wall"}},
]


def scene() -> Scene:
    """The Dobot's table and the wall beside it as a planning scene."""
    return Scene.from_profile({"obstacles": SCENE_OBSTACLES})


def peer(task: str, payload: dict) -> dict | None:
    """Run ``task`` of benchmarks/planning_peers.py in a subprocess; None if unavailable."""
    if not BENCH_PYTHON.exists():
        return None
    if (
        Path(sys.executable) == BENCH_PYTHON
        and importlib.util.find_spec(PEER_MODULES[task]) is None
    ):
        return None
    with tempfile.TemporaryDirectory() as tmp:
        args = Path(tmp) / "args.npz"
        np.savez(args, **{k: np.asarray(v) for k, v in payload.items()})
        done = subprocess.run(
            [
                str(BENCH_PYTHON),
                str(Path(__file__).with_name("planning_peers.py")),
                task,
                str(args),
            ],
            capture_output=True,
            text=True,
            timeout=900,
            env={**os.environ, "OMP_NUM_THREADS": "1"},
        )
    if done.returncode != 0:
        print(f"    ({task}: peer failed: {done.stderr.strip().splitlines()[-1:]})")
        return None
    return json.loads(done.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------------------


def bench_tritri(quick: bool) -> None:
    print("Triangle-triangle tests (Moller 1997), one core")
    rng = np.random.default_rng(0)
    n_ref = 20_000 if quick else 60_000
    n = 1_000_000 if quick else 4_000_000
    a = rng.uniform(0, 1, (n, 3, 3))
    b = rng.uniform(0, 1, (n, 3, 3)) + 0.3
    t = time.process_time()
    ref = [triangles_intersect(x, y) for x, y in zip(a[:n_ref], b[:n_ref], strict=True)]
    ref_rate = n_ref / (time.process_time() - t)
    fast = intersect_pairs(a[:n_ref], b[:n_ref])
    agree = int(np.sum(fast == np.array(ref)))
    row(
        "plain-Python transcription (correctness check, not a peer)",
        f"{ref_rate:,.0f} /s",
        f"random pairs, {np.mean(ref):.1%} hit",
    )
    pairs_rate = n / cpu(lambda: intersect_pairs(a, b), 2)
    row(
        "batched pairs, random (unit cubes)",
        f"{pairs_rate:,.0f} /s",
        "no per-pair peer: see the whole-arm rows",
    )
    row("  agreement with the reference", f"{agree}/{n_ref}", "bit-for-bit decisions")
    # The same random triangles, every pair of two sets: plane tests as matrix products.
    na = 1000 if quick else 2000
    secs = cpu(lambda: intersect_matrix(a[:na], b[:na]), 2)
    row(
        "batched all-pairs (matrix), random",
        f"{na * na / secs:,.0f} /s",
        f"{na * na:,} tests",
    )
    m = intersect_matrix(a[:150], b[:150])
    chk = np.array([[triangles_intersect(x, y) for y in b[:150]] for x in a[:150]])
    row("  all-pairs vs reference (150 x 150)", f"{int(np.sum(m == chk))}/{chk.size}")
    # The planner's layout: every link-box triangle of 1,000 configurations against the scene.
    model = DobotV1Model()
    q = model.lower + rng.random((1000, 3)) * (model.upper - model.lower)
    from armtree.maths.motion.geometry import box_triangles

    arm = box_triangles(model.box_poses(q), model.box_sizes()).reshape(-1, 3, 3)
    tris = scene().triangles()
    mesh = _bumpy_mesh(rng)
    for label, other in (
        ("table + wall (24 triangles)", tris),
        (f"table + wall + mesh ({len(mesh) + len(tris)} tris)", np.concatenate([tris, mesh])),
    ):
        tests = len(arm) * len(other)
        secs = cpu(lambda other=other: intersect_matrix(arm, other), 2)
        row(
            f"matrix layout: arm x {label}",
            f"{tests / secs:,.0f} /s",
            f"{tests:,} tests",
        )
    sub = rng.integers(0, len(arm), 300)
    m = intersect_matrix(arm[sub], np.concatenate([tris, mesh]))
    chk = np.array(
        [[triangles_intersect(x, y) for y in np.concatenate([tris, mesh])] for x in arm[sub[:40]]]
    )
    row(
        "  matrix vs reference (40 x all)",
        f"{int(np.sum(m[:40] == chk))}/{chk.size}",
        f"{m.mean():.2%} of pairs touch",
    )
    row("anchor: Showers 2016 Python (Dobot report)", "17,220 /s", "quoted")


def _bumpy_mesh(rng: np.random.Generator) -> np.ndarray:
    """A 1,000-triangle height field in front of the arm (an uneven tray)."""
    g = 16
    xs, ys = np.meshgrid(np.linspace(120, 260, g + 1), np.linspace(-120, 120, g + 1), indexing="ij")
    zs = -60 + 15 * rng.random(xs.shape)
    v = np.stack([xs, ys, zs], -1)
    tris = []
    for i in range(g):
        for j in range(g):
            tris.append([v[i, j], v[i + 1, j], v[i + 1, j + 1]])
            tris.append([v[i, j], v[i + 1, j + 1], v[i, j + 1]])
    return np.array(tris)[:1000]


def bench_whole_arm(quick: bool) -> None:
    print("Whole-arm collision check (Dobot V1.0 link boxes and self pairs), batches of 1,000")
    rng = np.random.default_rng(1)
    mesh = _bumpy_mesh(rng)
    with tempfile.TemporaryDirectory() as tmp:
        stl = Path(tmp) / "tray.stl"
        write_stl_binary(stl, mesh)
        tray = Scene.from_profile(
            {"obstacles": [*SCENE_OBSTACLES, {"mesh": {"file": str(stl), "name": "tray"}}]}
        )
    for label, sc, tris in (
        ("table + wall", scene(), None),
        (f"table + wall + tray mesh ({len(mesh)} triangles)", tray, mesh),
    ):
        _whole_arm_case(label, sc, tris, rng)


def _whole_arm_case(
    label: str, sc: Scene, mesh: np.ndarray | None, rng: np.random.Generator
) -> None:
    """armtree's batched check against python-fcl's broad phase on the same configurations."""
    model = DobotV1Model()
    checker = CollisionChecker(model, sc)
    q = model.lower + rng.random((1000, 3)) * (model.upper - model.lower)
    per = cpu(lambda: checker.collides(q), 5) / len(q)
    hits = checker.collides(q)
    row(
        f"armtree collides(batch of 1,000), {label}",
        f"{per * 1e6:.2f} us/config",
        f"{hits.mean():.1%} collide; {len(checker.moving)} boxes + {len(checker.pairs)} self pairs",
    )
    single = cpu(lambda: [checker.collides(x) for x in q[:200]], 2) / 200
    row("  armtree collides(one config)", f"{single * 1e6:.1f} us/config")
    payload = {
        "poses": model.box_poses(q),
        "sizes": model.box_sizes(),
        "obs_pose": np.stack([b.pose() for b in sc.boxes]),
        "obs_size": np.stack([b.size for b in sc.boxes]),
        "pairs": checker.pairs,
        "ours": hits,
        "mesh": np.zeros((0, 3, 3)) if mesh is None else mesh,
    }
    got = peer("fcl", payload)
    if got is None:
        row("  python-fcl", "not available", "pip install -e '.[bench]'")
        return
    row(
        "  peer: python-fcl, DynamicAABBTree broad phase",
        f"{got['arm_us']:.2f} us/config",
        f"agrees on {got['agree']}/1000 configs; one box-box query {1e6 / got['pair_rate']:.2f} us",
    )
    row("  fcl / armtree batch", f"x{got['arm_us'] / (per * 1e6):.1f}")


def plain_prm(
    lo: np.ndarray, hi: np.ndarray, n: int, k: int, res: float, seed: int, valid
) -> nx.Graph:
    """The straightforward PRM: sample, KD-tree, check each edge's samples one by one."""
    rng = np.random.default_rng(seed)
    nodes = []
    while len(nodes) < n:
        x = lo + rng.random(len(lo)) * (hi - lo)
        if valid(x):
            nodes.append(x)
    nodes = np.array(nodes)
    _, idx = cKDTree(nodes).query(nodes, k=k + 1)
    g = nx.Graph()
    g.add_nodes_from(range(n))
    for i in range(n):
        for j in idx[i, 1:]:
            if g.has_edge(i, j):
                continue
            steps = max(1, int(np.ceil(np.abs(nodes[j] - nodes[i]).max() / res)))
            if all(valid(nodes[i] + (nodes[j] - nodes[i]) * s / steps) for s in range(1, steps)):
                g.add_edge(i, int(j), weight=float(np.linalg.norm(nodes[j] - nodes[i])))
    return g


def bench_prm(quick: bool) -> None:
    print("PRM on the Dobot V1.0 with a table and a wall: 1,000 milestones, 5 neighbours, 2 deg")
    model = DobotV1Model()
    checker = CollisionChecker(model, scene())
    planner = PRMPlanner(
        checker, milestones=1000, neighbours=5, seed=3, resolution=2.0, cache_dir=None
    )
    build = cpu(lambda: planner.build(force=True), 3)
    rm = planner.roadmap
    row(
        "armtree PRM build, real collision check", f"{build * 1e3:.1f} ms", f"{len(rm.edges)} edges"
    )
    rng = np.random.default_rng(4)
    pts = rm.nodes[rng.integers(0, len(rm.nodes), (60, 2))] + rng.normal(0, 0.5, (60, 2, 3))
    ok = checker.valid(pts.reshape(-1, 3)).reshape(60, 2).all(axis=1)
    pts = pts[ok]
    planner.plan(pts[0, 0], pts[0, 1])
    solved = 0

    def queries() -> None:
        nonlocal solved
        solved = 0
        for s, g in pts:
            try:
                planner.plan(s, g)
                solved += 1
            except Exception:  # noqa: BLE001 - a disconnected pair still counts as a query
                pass

    q_time = cpu(queries, 2) / len(pts)
    row(
        "armtree PRM query (connect, A*, shortcut)",
        f"{q_time * 1e3:.2f} ms",
        f"{solved}/{len(pts)} solved",
    )
    lo, hi = model.lower, model.upper
    t = time.process_time()
    plain_prm(lo, hi, 1000, 5, 2.0, 3, lambda x: True)
    row(
        "plain networkx + cKDTree PRM, trivial check (baseline, not a peer)",
        f"{(time.process_time() - t) * 1e3:.1f} ms",
    )
    t = time.process_time()
    plain_prm(lo, hi, 200, 5, 2.0, 3, lambda x: bool(checker.valid(x)))
    per_node = (time.process_time() - t) / 200
    row(
        "plain PRM, real check per call (200 milestones)",
        f"{per_node * 1e3 * 1000:.0f} ms per 1,000 (est.)",
    )
    got = peer("ompl", {"lower": lo, "upper": hi, "starts": pts[:, 0], "goals": pts[:, 1]})
    if got is None:
        row("OMPL PRM", "not available", "pip install -e '.[bench]'")
        return
    row(
        "OMPL PRM build, trivial check (peer)",
        f"{got['trivial_build_ms']:.1f} ms",
        f"{got['trivial_milestones']} milestones",
    )
    row(
        "OMPL PRM query, trivial check (peer)",
        f"{got['trivial_query_ms']:.2f} ms",
        f"{got['trivial_solved']} solved",
    )
    row(
        "OMPL PRM build, armtree checker as validity fn (peer)",
        f"{got['real_build_ms']:.1f} ms",
        f"{got['real_milestones']} milestones",
    )
    row(
        "  armtree build vs OMPL, same validity function",
        f"x{got['real_build_ms'] / (build * 1e3):.1f}",
    )
    row(
        "  armtree build (real check) vs OMPL trivial",
        f"x{got['trivial_build_ms'] / (build * 1e3):.2f}",
    )


# -- workspace -------------------------------------------------------------------------

L_MIN, L_MAX, L0 = 8.0, 12.0, 5.0


def _robot(x):
    x1, x2 = x[..., 0], x[..., 1]
    return [
        x1**2 + x2**2 - L_MAX**2,
        L_MIN**2 - x1**2 - x2**2,
        (x1 - L0) ** 2 + x2**2 - L_MAX**2,
        L_MIN**2 - (x1 - L0) ** 2 - x2**2,
    ]


class NaiveInterval:
    """A generic scalar interval class: what a first implementation of Rybak 2016 looks like."""

    def __init__(self, lo, hi):
        self.lo, self.hi = lo, hi

    def __add__(self, o):
        o = o if isinstance(o, NaiveInterval) else NaiveInterval(o, o)
        return NaiveInterval(self.lo + o.lo, self.hi + o.hi)

    __radd__ = __add__

    def __sub__(self, o):
        o = o if isinstance(o, NaiveInterval) else NaiveInterval(o, o)
        return NaiveInterval(self.lo - o.hi, self.hi - o.lo)

    def __rsub__(self, o):
        return NaiveInterval(o, o) - self

    def __pow__(self, n):
        a, b = self.lo**n, self.hi**n
        if self.lo <= 0 <= self.hi:
            return NaiveInterval(0.0, max(a, b))
        return NaiveInterval(min(a, b), max(a, b))


class _NaiveBox:
    """Coordinates as ``box[..., k]`` for the shared constraint function."""

    def __init__(self, items):
        self.items = items

    def __getitem__(self, key):
        return self.items[key[-1]]


def naive_cover(delta: float) -> tuple[float, float]:
    stack = [(-L_MAX, 0.0, L_MAX + L0, L_MAX)]
    inner = bnd = 0.0
    while stack:
        x0, y0, x1, y1 = stack.pop()
        gs = _robot(_NaiveBox([NaiveInterval(x0, x1), NaiveInterval(y0, y1)]))
        if any(g.lo > 0 for g in gs):
            continue
        if all(g.hi <= 0 for g in gs):
            inner += (x1 - x0) * (y1 - y0)
            continue
        if (x1 - x0) ** 2 + (y1 - y0) ** 2 <= delta**2:
            bnd += (x1 - x0) * (y1 - y0)
            continue
        if x1 - x0 >= y1 - y0:
            m = 0.5 * (x0 + x1)
            stack += [(x0, y0, m, y1), (m, y0, x1, y1)]
        else:
            m = 0.5 * (y0 + y1)
            stack += [(x0, y0, x1, m), (x0, m, x1, y1)]
    return inner, bnd


def special_cover(delta: float) -> tuple[float, float]:
    """Specialised plain-Python recursion: the disc tests done by hand per box."""

    def rng2(a, b, c):
        lo = 0.0 if a - c <= 0 <= b - c else min((a - c) ** 2, (b - c) ** 2)
        return lo, max((a - c) ** 2, (b - c) ** 2)

    inner = bnd = 0.0
    stack = [(-L_MAX, 0.0, L_MAX + L0, L_MAX)]
    while stack:
        x0, y0, x1, y1 = stack.pop()
        ylo, yhi = rng2(y0, y1, 0.0)
        ok_in = ok_out = True
        for cx in (0.0, L0):
            xlo, xhi = rng2(x0, x1, cx)
            lo, hi = xlo + ylo, xhi + yhi
            if lo > L_MAX**2 or hi < L_MIN**2:
                ok_out = False
            if not (hi <= L_MAX**2 and lo >= L_MIN**2):
                ok_in = False
        if not ok_out:
            continue
        if ok_in:
            inner += (x1 - x0) * (y1 - y0)
            continue
        if (x1 - x0) ** 2 + (y1 - y0) ** 2 <= delta**2:
            bnd += (x1 - x0) * (y1 - y0)
            continue
        if x1 - x0 >= y1 - y0:
            m = 0.5 * (x0 + x1)
            stack += [(x0, y0, m, y1), (m, y0, x1, y1)]
        else:
            m = 0.5 * (y0 + y1)
            stack += [(x0, y0, x1, m), (x0, m, x1, y1)]
    return inner, bnd


def bench_workspace(quick: bool) -> None:
    print("Workspace covering (Rybak 2016): planar parallel robot, general constraint interface")
    paper = {0.5: 0.9, 0.25: 2.4, 0.07: 6.6}
    for delta in (0.5, 0.25, 0.07):
        ours = cpu(lambda d=delta: cover(_robot, [-L_MAX, 0.0], [L_MAX + L0, L_MAX], d), 5)
        c = cover(_robot, [-L_MAX, 0.0], [L_MAX + L0, L_MAX], delta)
        naive = cpu(lambda d=delta: naive_cover(d), 1)
        special = cpu(lambda d=delta: special_cover(d), 2)
        row(
            f"delta {delta}: armtree cover()",
            f"{ours * 1e3:.2f} ms",
            f"naive class {naive * 1e3:.0f} ms (x{naive / ours:.0f}), specialised {special * 1e3:.1f} ms "
            f"(x{special / ours:.1f}), paper {paper[delta]} s (x{paper[delta] / ours:,.0f}); "
            f"{c.counts['inner']} inner / {c.counts['boundary']} boundary",
        )
    print("Dobot V1.0 reachable workspace, 3-D")
    ws = ArmWorkspace(DobotV1Model())
    for delta in (5.0, 2.0) if quick else (5.0, 2.0, 1.0):
        t = time.process_time()
        c = ws.cover(delta)
        secs = time.process_time() - t
        row(
            f"Dobot 3-D covering to {delta:g} mm",
            f"{secs:.2f} s",
            f"{c.counts['inner']:,} inner, {c.counts['boundary']:,} boundary, {c.counts['outer']:,} outer; "
            f"{c.inner_measure / 1e3:.0f}-{(c.inner_measure + c.boundary_measure) / 1e3:.0f} cm^3",
        )
    x = np.random.default_rng(2).uniform(ws.bounds[0], ws.bounds[1], (100_000, 3))
    secs = cpu(lambda: ws.reachable(x), 3)
    row("reachable(xyz), 100,000 points", f"{x.shape[0] / secs:,.0f} /s")


def bench_ik(quick: bool) -> None:
    print("Batched analytic inverse kinematics for the planners")
    rng = np.random.default_rng(5)
    n = 200_000 if quick else 1_000_000
    for model in (DobotV1Model(), VicraModel()):
        q = model.lower + rng.random((n, model.dof)) * (model.upper - model.lower)
        q = q[model.within_limits(q)]
        x = model.position(q)
        secs = cpu(lambda x=x, model=model: model.ik_all(x), 3)
        sols = model.ik_all(x[:1000])
        loop = cpu(lambda model=model, x=x: [model.ik_all(p) for p in x[:2000]], 1) / 2000
        row(
            f"{model.name} ik_all batched",
            f"{len(x) / secs:,.0f} targets/s",
            f"{sols.shape[-2]} branches each; one-at-a-time {1 / loop:,.0f}/s (x{loop * len(x) / secs:.0f})",
        )


def main() -> None:
    """Run every section and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes")
    parser.add_argument(
        "--only", choices=("tritri", "arm", "prm", "workspace", "ik"), action="append"
    )
    args = parser.parse_args()
    sections = {
        "tritri": bench_tritri,
        "arm": bench_whole_arm,
        "prm": bench_prm,
        "workspace": bench_workspace,
        "ik": bench_ik,
    }
    for name, fn in sections.items():
        if not args.only or name in args.only:
            fn(args.quick)
            print()


if __name__ == "__main__":
    sys.exit(main())
