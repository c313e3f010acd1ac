"""Peer measurements for bench_planning.py (python-fcl, OMPL), run in a subprocess.

``python planning_peers.py fcl|ompl ARGS.npz`` prints one JSON line of figures.
python-fcl and OMPL come with ``pip install -e '.[bench]'``; the subprocess keeps
their libraries out of the process that times armtree.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np


def fcl_task(args: dict) -> dict:
    """python-fcl: one box-box query, and bench_planning's whole-arm check through its broad phase."""
    import fcl

    poses, sizes = args["poses"], args["sizes"]
    obs_pose, obs_size, pairs = args["obs_pose"], args["obs_size"], args["pairs"]
    req = fcl.CollisionRequest()
    rng = np.random.default_rng(0)
    a = fcl.CollisionObject(fcl.Box(1.0, 1.0, 1.0), fcl.Transform())
    b = fcl.CollisionObject(
        fcl.Box(1.0, 1.0, 1.0), fcl.Transform(np.eye(3), np.array([0.8, 0.3, 0.0]))
    )
    n = 200_000
    t = time.process_time()
    for _ in range(n):
        fcl.collide(a, b, req, fcl.CollisionResult())
    pair_rate = n / (time.process_time() - t)
    links = [fcl.CollisionObject(fcl.Box(*s), fcl.Transform()) for s in sizes]
    obstacles = [
        fcl.CollisionObject(fcl.Box(*s), fcl.Transform(p[:3, :3], p[:3, 3]))
        for p, s in zip(obs_pose, obs_size, strict=True)
    ]
    mesh = args.get("mesh")
    if mesh is not None and len(mesh):
        # a triangle mesh obstacle, as fcl takes one: a BVH model built once
        model = fcl.BVHModel()
        model.beginModel(3 * len(mesh), len(mesh))
        model.addSubModel(mesh.reshape(-1, 3), np.arange(3 * len(mesh)).reshape(-1, 3))
        model.endModel()
        obstacles.append(fcl.CollisionObject(model, fcl.Transform()))
    # As fcl's users check a whole arm: a broad-phase manager (dynamic AABB tree) for the
    # static scene and one for the links, updated after each pose; the self pairs that
    # may collide (non-adjacent links) by narrow phase, as an allowed-pairs list is used.
    scene = fcl.DynamicAABBTreeCollisionManager()
    scene.registerObjects(obstacles)
    scene.setup()
    arm = fcl.DynamicAABBTreeCollisionManager()
    arm.registerObjects(links)
    arm.setup()
    self_pairs = [(links[i], links[j]) for i, j in pairs]
    verdict = []
    t = time.process_time()
    for cfg in poses:
        for k, link in enumerate(links):
            link.setTransform(fcl.Transform(cfg[k, :3, :3], cfg[k, :3, 3]))
        arm.update()
        data = fcl.CollisionData()
        arm.collide(scene, data, fcl.defaultCollisionCallback)
        hit = data.result.is_collision or any(
            fcl.collide(a, b, req, fcl.CollisionResult()) for a, b in self_pairs
        )
        verdict.append(hit)
    arm_us = (time.process_time() - t) / len(poses) * 1e6
    agree = int(np.sum(np.array(verdict) == args["ours"]))
    del rng
    return {"pair_rate": pair_rate, "arm_us": arm_us, "agree": agree}


def ompl_task(args: dict) -> dict:
    """OMPL's PRM (k = 5): 1,000 milestones with a trivial check and with armtree's checker."""
    from ompl import base as ob
    from ompl import geometric as og

    lo, hi = args["lower"], args["upper"]
    out: dict = {}

    def make(valid):
        space = ob.RealVectorStateSpace(len(lo))
        bounds = ob.RealVectorBounds(len(lo))
        for k in range(len(lo)):
            bounds.setLow(k, float(lo[k]))
            bounds.setHigh(k, float(hi[k]))
        space.setBounds(bounds)
        ss = og.SimpleSetup(space)
        ss.setStateValidityChecker(valid)
        si = ss.getSpaceInformation()
        # The same 2-degree edge resolution as armtree's roadmap.
        si.setStateValidityCheckingResolution(2.0 / space.getMaximumExtent())
        planner = og.PRM(si)
        planner.setMaxNearestNeighbors(5)
        ss.setPlanner(planner)
        return space, ss, planner

    def build(planner, target=1000):
        t = time.process_time()
        while planner.milestoneCount() < target:
            planner.growRoadmap(0.0005)
        return (time.process_time() - t) * 1e3, planner.milestoneCount()

    def trivial(state):
        return True

    space, ss, planner = make(trivial)
    ss.setup()
    out["trivial_build_ms"], out["trivial_milestones"] = build(planner)
    times, ok = [], 0
    for s, g in zip(args["starts"], args["goals"], strict=True):
        start, goal = space.allocState(), space.allocState()
        for k in range(len(lo)):
            start[k], goal[k] = float(s[k]), float(g[k])
        ss.setStartAndGoalStates(start, goal)
        planner.clearQuery()
        t = time.process_time()
        solved = ss.solve(0.05)
        times.append(time.process_time() - t)
        ok += bool(solved)
    out["trivial_query_ms"] = float(np.median(times) * 1e3)
    out["trivial_solved"] = f"{ok}/{len(times)}"

    from armtree.maths.motion.collision import CollisionChecker
    from armtree.maths.motion.scene import Scene
    from armtree.plugins.arms.dobot_v1.kinematics import DobotV1Model

    scene = Scene.from_profile(
        {
            "obstacles": [
                {"box": {"center": [0, 0, -105], "size": [800, 800, 10]}},
                {"box": {"center": [0, 170, 0], "size": [400, 20, 200]}},
            ]
        }
    )
    checker = CollisionChecker(DobotV1Model(), scene)

    def real(state):
        return bool(checker.valid(np.array([state[0], state[1], state[2]])))

    space, ss, planner = make(real)
    ss.setup()
    out["real_build_ms"], out["real_milestones"] = build(planner)
    return out


def main() -> None:
    """Dispatch to the task named on the command line."""
    task, path = sys.argv[1], sys.argv[2]
    with np.load(path) as data:
        args = {k: data[k] for k in data.files}
    result = {"fcl": fcl_task, "ompl": ompl_task}[task](args)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
