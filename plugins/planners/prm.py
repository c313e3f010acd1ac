"""The ``prm`` planner: a probabilistic roadmap over the arm's joint space (Showers 2016).

Showers 2016 (Path Planning, appendix E) samples valid collision-free
configurations, joins each to its five nearest neighbours through a SciPy
KD-tree where the evenly sampled segment is free, keeps them in a NetworkX
graph, and answers a query by connecting start and goal to their nearest nodes
and running Dijkstra. armtree does each step in batches (all samples, all
segments at once), searches with A* (Dijkstra with a distance heuristic),
shortcut-smooths the result, and caches the roadmap on disk keyed by the arm
model, its limits, the scene and the roadmap's parameters.

Distances are Euclidean in joint space (degrees / mm).
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import platformdirs

from armtree.api.rig import Planner
from armtree.config.params import Param
from armtree.errors import ConfigError, PlanningError
from armtree.maths.motion.collision import CollisionChecker
from armtree.maths.motion.kinematics import KinematicModel
from armtree.maths.motion.start_contact import StartContactRecovery
from armtree.maths.motion.validation import check_config
from armtree.maths.motion.workspace import ArmWorkspace
from armtree.plugins.planners.direct import (
    CHECK_PARAMS,
    PlannerFactory,
    planner_checker,
    validate_start,
)

if TYPE_CHECKING:  # networkx and scipy load when a roadmap is built, not with the plugin
    import networkx as nx
    from scipy.spatial import cKDTree

#: Bump when the cache file layout or the construction changes meaning.
CACHE_VERSION = 1


@dataclass
class Roadmap:
    """Milestones ``nodes`` ``(M, n)`` deg / mm and free ``edges`` ``(E, 2)`` with ``weights``."""

    nodes: np.ndarray
    edges: np.ndarray
    weights: np.ndarray
    key: str = ""

    def graph(self) -> nx.Graph:
        """The roadmap as an undirected NetworkX graph weighted by joint-space length."""
        import networkx as nx

        g = nx.Graph()
        g.add_nodes_from(range(len(self.nodes)))
        g.add_weighted_edges_from(
            zip(
                self.edges[:, 0].tolist(),
                self.edges[:, 1].tolist(),
                self.weights.tolist(),
                strict=True,
            )
        )
        return g

    def save(self, path: Path) -> None:
        """Write atomically as ``.npz`` (a crash never leaves a half-written cache)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npz.tmp")
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, nodes=self.nodes, edges=self.edges, weights=self.weights, key=self.key)
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: Path, key: str) -> Roadmap | None:
        """The cached roadmap at ``path`` if it exists, is readable and has ``key``."""
        try:
            with np.load(path) as data:
                if str(data["key"]) != key:
                    return None
                return cls(data["nodes"], data["edges"], data["weights"], key)
        except (OSError, KeyError, ValueError):
            return None


def sample_free(
    checker: CollisionChecker, count: int, rng: np.random.Generator, max_rounds: int = 60
) -> np.ndarray:
    """``count`` valid, collision-free configurations drawn uniformly in the joint limits.

    Draws in batches sized by the acceptance rate seen so far. Raises
    PlanningError (reason ``no_free_space``) if too few are found.
    """
    model = checker.model
    lo, hi = model.lower, model.upper
    found: list[np.ndarray] = []
    have, drawn, accepted = 0, 0, 0
    for _ in range(max_rounds):
        rate = max(accepted / drawn, 0.02) if drawn else 0.5
        batch = int(min(200_000, max(64, 1.2 * (count - have) / rate)))
        q = lo + rng.random((batch, model.dof)) * (hi - lo)
        ok = np.asarray(checker.valid(q))
        drawn, accepted = drawn + batch, accepted + int(ok.sum())
        found.append(q[ok])
        have += int(ok.sum())
        if have >= count:
            return np.concatenate(found)[:count]
    raise PlanningError(
        f"only {have} of {count} random configurations were valid after {drawn} draws: "
        "the free joint space is too small (check the limits and obstacles)",
        reason="no_free_space",
    )


def build_roadmap(
    checker: CollisionChecker,
    milestones: int,
    neighbours: int,
    seed: int,
    resolution: float,
    progress: Callable[[int, int], None] | None = None,
) -> Roadmap:
    """Sample ``milestones`` free configurations and join each to its ``neighbours`` nearest.

    An edge is kept when every sample along it (at most ``resolution`` deg / mm
    apart) is valid. ``progress(done, total)`` is called as edge batches finish.
    """
    rng = np.random.default_rng(seed)
    nodes = sample_free(checker, milestones, rng)
    k = min(neighbours + 1, len(nodes))
    from scipy.spatial import cKDTree

    _, idx = cKDTree(nodes).query(nodes, k=k)
    i = np.repeat(np.arange(len(nodes)), k - 1)
    j = idx[:, 1:].reshape(-1)
    pairs = np.unique(np.sort(np.stack([i, j], axis=1), axis=1), axis=0)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    free = np.zeros(len(pairs), dtype=bool)
    step = 2048
    for s in range(0, len(pairs), step):
        e = min(len(pairs), s + step)
        free[s:e] = checker.segments_free(
            nodes[pairs[s:e, 0]], nodes[pairs[s:e, 1]], resolution, ends=False
        )
        if progress is not None:
            progress(e, len(pairs))
    edges = pairs[free]
    weights = np.linalg.norm(nodes[edges[:, 0]] - nodes[edges[:, 1]], axis=1)
    return Roadmap(nodes, edges, weights)


class PRMPlanner(Planner):
    """Roadmap planner for one arm in one scene; the roadmap is built (or loaded) on first use.

    ``cache_dir`` None disables the disk cache. ``progress`` True/False forces the
    build's progress bar on/off; None shows it when stderr is a terminal.
    """

    def __init__(
        self,
        checker: CollisionChecker,
        milestones: int = 1000,
        neighbours: int = 5,
        seed: int = 0,
        resolution: float = 2.0,
        cache_dir: str | Path | None = None,
        progress: bool | None = None,
        smooth: bool = True,
    ) -> None:
        if milestones < 2 or neighbours < 1 or resolution <= 0:
            raise ConfigError(
                f"prm planner: milestones must be >= 2, neighbours >= 1 and resolution_deg > 0 "
                f"(got {milestones}, {neighbours}, {resolution})"
            )
        self.checker = checker
        self.model = checker.model
        self.milestones = int(milestones)
        self.neighbours = int(neighbours)
        self.seed = int(seed)
        self.resolution = float(resolution)
        self.cache_dir = Path(cache_dir).expanduser() if cache_dir is not None else None
        self.progress = progress
        self.smooth = smooth
        self._roadmap: Roadmap | None = None
        self._lock = threading.RLock()
        self._graph: nx.Graph | None = None
        self._tree: cKDTree | None = None
        #: Roadmap edges checked free in this scene (both directions).
        self._checked_edges: set[tuple[int, int]] = set()
        #: True when the roadmap in use came from the disk cache.
        self.loaded_from_cache = False
        self.workspace = ArmWorkspace(self.model)
        self.start_contact = StartContactRecovery(checker)

    # -- the roadmap -----------------------------------------------------------

    @property
    def key(self) -> str:
        """Cache key: the checker's fingerprint (model, limits, scene) and the roadmap parameters."""
        h = hashlib.sha256()
        h.update(self.checker.fingerprint().encode())
        h.update(
            repr(
                (CACHE_VERSION, self.milestones, self.neighbours, self.seed, self.resolution)
            ).encode()
        )
        return h.hexdigest()

    @property
    def cache_path(self) -> Path | None:
        """Where this roadmap is cached, or None without a cache directory."""
        if self.cache_dir is None:
            return None
        return self.cache_dir / f"prm-{self.model.name}-{self.key[:20]}.npz"

    @property
    def roadmap(self) -> Roadmap:
        """The roadmap, loaded from the cache or built now."""
        with self._lock:
            if self._roadmap is None:
                self.build()
        assert self._roadmap is not None
        return self._roadmap

    def build(self, force: bool = False) -> Roadmap:
        """Load the cached roadmap, or build (and cache) it; ``force`` always rebuilds."""
        key, path = self.key, self.cache_path
        roadmap = None if (force or path is None) else Roadmap.load(path, key)
        if roadmap is not None and not self._plausible(roadmap):
            roadmap = None  # edited or damaged: build it again (and overwrite it)
        self.loaded_from_cache = roadmap is not None
        if roadmap is None:
            roadmap = self._build_with_progress()
            roadmap.key = key
            if path is not None:
                roadmap.save(path)
        self._roadmap = roadmap
        self._graph = roadmap.graph()
        from scipy.spatial import cKDTree

        self._tree = cKDTree(roadmap.nodes)
        self._checked_edges = set()
        return roadmap

    def _plausible(self, roadmap: Roadmap) -> bool:
        """A cached roadmap fits this arm and scene: shapes, finite values, free milestones.

        Its edges are not all checked here (that is the cost of building); every edge a
        path uses is checked when the path is found (:meth:`plan`).
        """
        nodes, edges, weights = roadmap.nodes, roadmap.edges, roadmap.weights
        dof = self.model.dof
        if (
            nodes.ndim != 2
            or nodes.shape[1] != dof
            or edges.ndim != 2
            or edges.shape[1:] != (2,)
            or len(weights) != len(edges)
            or not np.all(np.isfinite(nodes))
            or not np.issubdtype(edges.dtype, np.integer)
        ):
            return False
        if len(edges) and (edges.min() < 0 or edges.max() >= len(nodes)):
            return False
        return bool(np.all(np.asarray(self.checker.valid(nodes))))

    def _build_with_progress(self) -> Roadmap:
        show = self.progress if self.progress is not None else sys.stderr.isatty()
        args = (self.checker, self.milestones, self.neighbours, self.seed, self.resolution)
        if not show:
            return build_roadmap(*args)
        from rich.console import Console
        from rich.progress import Progress

        with Progress(console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task(f"PRM for {self.model.name}: checking edges", total=None)
            return build_roadmap(
                *args, progress=lambda done, total: bar.update(task, completed=done, total=total)
            )

    # -- queries -----------------------------------------------------------------

    def plan(self, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Waypoints ``(N, n)`` from ``start`` to ``goal`` (deg / mm) through the roadmap.

        Raises PlanningError with reason ``not_finite``, ``outside_limits``,
        ``start_in_collision``, ``goal_in_collision`` or ``disconnected``. A start in a
        shallow collision first steps out of it
        (:class:`~armtree.maths.motion.start_contact.StartContactRecovery`).
        """
        start, escape = self.start_contact.check(start)
        if escape is not None:
            return self.start_contact.follow(self, escape, goal)
        goal = check_config(self.checker, goal, "goal")
        if (
            np.allclose(start, goal)
            or self.checker.segments_free(start, goal, self.resolution, ends=False)[0]
        ):
            return np.stack([start, goal])
        rm = self.roadmap
        assert self._graph is not None and self._tree is not None
        s_links = self._links(start)
        if not s_links:
            raise PlanningError(
                "the start cannot be joined to the roadmap: no free segment to any nearby milestone",
                reason="disconnected",
            )
        g_links = self._links(goal)
        if not g_links:
            raise PlanningError(
                "the goal cannot be joined to the roadmap: no free segment to any nearby milestone",
                reason="disconnected",
            )
        graph = self._graph
        s_id, g_id = -1, -2
        nodes = rm.nodes

        def config(n: int) -> np.ndarray:
            return start if n == s_id else goal if n == g_id else nodes[n]

        # The query nodes are added to the shared graph for the search (Showers 2016,
        # appendix E); the lock keeps concurrent queries from seeing each other's.
        import networkx as nx

        with self._lock:
            graph.add_weighted_edges_from((s_id, n, w) for n, w in s_links)
            graph.add_weighted_edges_from((g_id, n, w) for n, w in g_links)
            try:
                while True:
                    ids = nx.astar_path(
                        graph,
                        s_id,
                        g_id,
                        heuristic=lambda a, b: float(np.linalg.norm(config(a) - config(b))),
                        weight="weight",
                    )
                    # Every roadmap edge on the path is checked in this scene before it is
                    # used (lazily, as Lazy PRM does): a cached roadmap is not trusted.
                    blocked = self._blocked_edges(ids, nodes)
                    if not blocked:
                        break
                    graph.remove_edges_from(blocked)
            except nx.NetworkXNoPath:
                raise PlanningError(
                    "no path: start and goal are in different components of the roadmap "
                    f"({self.milestones} milestones); add milestones or move obstacles",
                    reason="disconnected",
                ) from None
            finally:
                graph.remove_nodes_from([s_id, g_id])
        path = np.stack([config(n) for n in ids])
        return self.shortcut(path) if self.smooth else path

    def _blocked_edges(self, ids: list[int], nodes: np.ndarray) -> list[tuple[int, int]]:
        """The roadmap edges along ``ids`` that are not free in the current scene."""
        pairs = [(a, b) for a, b in zip(ids, ids[1:], strict=False) if a >= 0 and b >= 0]
        pairs = [p for p in pairs if p not in self._checked_edges]
        if not pairs:
            return []
        a = nodes[[p[0] for p in pairs]]
        b = nodes[[p[1] for p in pairs]]
        free = np.asarray(self.checker.segments_free(a, b, self.resolution, ends=True))
        for pair, ok in zip(pairs, free, strict=True):
            if ok:
                self._checked_edges.add(pair)
                self._checked_edges.add((pair[1], pair[0]))
        return [pair for pair, ok in zip(pairs, free, strict=True) if not ok]

    def plan_to(self, start: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """Waypoints to a tool position (mm), IK solutions nearest-first (Pozzani 2023).

        A non-finite or unreachable target is refused (:class:`Unreachable`)
        before any inverse kinematics or roadmap search runs.
        """
        return super().plan_to(start, self.workspace.require(xyz))

    def _links(self, q: np.ndarray) -> list[tuple[int, float]]:
        assert self._tree is not None and self._roadmap is not None
        k = min(len(self._roadmap.nodes), 3 * self.neighbours)
        dist, idx = self._tree.query(q, k=k)
        dist, idx = np.atleast_1d(dist), np.atleast_1d(idx)
        free = self.checker.segments_free(
            np.broadcast_to(q, (len(idx), len(q))),
            self._roadmap.nodes[idx],
            self.resolution,
            ends=False,
        )
        return list(zip(idx[free].tolist(), dist[free].tolist(), strict=True))

    def shortcut(self, path: np.ndarray) -> np.ndarray:
        """Greedy shortcut smoothing: from each kept waypoint jump to the farthest one in free sight."""
        out = [path[0]]
        i = 0
        while i < len(path) - 1:
            rest = path[i + 1 :]
            free = self.checker.segments_free(
                np.broadcast_to(path[i], rest.shape), rest, self.resolution, ends=False
            )
            # The next waypoint is always reachable (it was a roadmap edge); take the farthest.
            j = i + 1 + int(np.flatnonzero(free)[-1]) if free.any() else i + 1
            out.append(path[j])
            i = j
        return np.stack(out)


def default_cache_dir() -> Path:
    """The user's cache folder for roadmaps (``~/.cache/armtree/prm`` on Linux).

    Where caches go is the platform's convention (platformdirs), never a path from
    a YAML file: a profile only says whether to cache.
    """
    return platformdirs.user_cache_path("armtree") / "prm"


def prm_factory(
    config: Mapping[str, Any], context: Any, model: KinematicModel, scene: Any
) -> PRMPlanner:
    """Probabilistic roadmap in joint space (KD-tree neighbours, A*, shortcuts), cached on disk."""
    checker = planner_checker(config, context, model, scene)
    cache = default_cache_dir() if config.get("cache", True) else None
    # A fixed default (not the run's seed) so every run finds the same cached roadmap.
    seed = config.get("seed", 0)
    return PRMPlanner(
        checker,
        milestones=int(config.get("milestones", 1000)),
        neighbours=int(config.get("neighbours", 5)),
        seed=0 if seed is None else int(seed),
        resolution=float(config.get("resolution_deg", 2.0)),
        cache_dir=cache,
        progress=config.get("progress"),
        smooth=bool(config.get("smooth", True)),
    )


# mypy types a def as a plain callable, which has no attributes to set: the same function,
# typed as what it is once the members below are set.
prm_factory = cast(PlannerFactory[PRMPlanner], prm_factory)
prm_factory.validate = validate_start
prm_factory.PARAMS = (
    Param(
        "milestones",
        "int",
        1000,
        "",
        "number of collision-free configurations in the roadmap",
        minimum=10,
        maximum=100_000,
    ),
    Param(
        "neighbours",
        "int",
        5,
        "",
        "nearest milestones each one is joined to (Showers 2016: 5)",
        minimum=1,
        maximum=50,
    ),
    Param(
        "seed",
        "int",
        0,
        "",
        "random seed of the roadmap (reproducible; part of the cache key)",
        minimum=0,
        maximum=2**32 - 1,
    ),
    *CHECK_PARAMS,
    Param("cache", "bool", True, "", "keep the roadmap in the user's cache folder for next runs"),
    Param(
        "progress",
        "any",
        None,
        "",
        "progress bar while building: true, false or null (when a terminal)",
    ),
    Param("smooth", "bool", True, "", "shortcut-smooth the path"),
)
