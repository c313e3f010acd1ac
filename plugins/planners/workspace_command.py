"""``armtree workspace --rig PROFILE [--delta MM] [--plot FILE.png]``: an arm's reachable workspace.

Covers the arm's reachable tool positions with boxes (Rybak 2016) to diameter
``--delta`` mm, prints the box counts and volumes, and with ``--plot`` draws a
PNG: the top view, a vertical slice through the base axis and a horizontal
slice, with inner and boundary boxes, the arm's base and the profile's places.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from armtree.config.profile_access import profile_source
from armtree.errors import ConfigError
from armtree.hooks.plugin_manager import PluginManager
from armtree.loader.profile import Profile
from armtree.maths.motion.scene import Scene
from armtree.maths.motion.workspace import ArmWorkspace, Covering


def arm_model(profile: Profile | dict[str, Any], manager: PluginManager | None = None) -> Any:
    """The profile's arm model, built without opening a port (the arm factory's ``model``)."""
    from armtree.hooks.plugin_manager import get_plugin_manager

    manager = manager or getattr(profile, "manager", None) or get_plugin_manager()
    config = profile.component("arm") if hasattr(profile, "component") else profile["arm"]
    if config is None:
        raise ConfigError("the profile has no arm to cover", file=profile_source(profile))
    factory = manager.registry.get("arm", config["type"]).factory
    make = getattr(factory, "model", None)
    if make is None:
        raise ConfigError(
            f"arm type {config['type']!r} offers no kinematic model (factory.model) to cover",
            file=profile_source(profile),
        )
    return make(config)


class WorkspaceCommand:
    """Cover an arm's reachable workspace with boxes (Rybak 2016) and plot it (armtree workspace)."""

    help = "cover the arm's reachable workspace with boxes (Rybak 2016); --plot FILE.png draws it"

    def configure(self, parser: argparse.ArgumentParser) -> None:
        """Add --rig, --delta, --plot and --set."""
        parser.add_argument("--rig", required=True, help="hardware profile (name or path)")
        parser.add_argument(
            "--delta", type=float, default=5.0, help="largest boundary box diameter, mm (default 5)"
        )
        parser.add_argument("--plot", type=Path, help="write a PNG with slices and a top view")
        parser.add_argument(
            "--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE"
        )

    def run(self, args: argparse.Namespace) -> int:
        """Cover, print a summary, plot if asked. ConfigError (exit 2) for bad input."""
        from armtree.loader.profile import load_profile

        if not (args.delta > 0 and math.isfinite(args.delta)):
            raise ConfigError(f"--delta must be a positive number of mm, got {args.delta}")
        profile = load_profile(args.rig, args.overrides, manager=getattr(args, "manager", None))
        model = arm_model(profile, getattr(args, "manager", None))
        scene = Scene.from_profile(profile)
        ws = ArmWorkspace(model)
        if not ws.has_covering:
            raise profile.error(
                "arm.type",
                f"arm {model.name!r} does not describe its workspace as constraints, so it "
                "cannot be covered: give its model workspace_shape() (docs/plugins.md, "
                "'The workspace')",
            )
        start = time.perf_counter()
        cov = ws.cover(args.delta)
        seconds = time.perf_counter() - start
        counts = cov.counts
        print(
            f"{model.name} workspace ({ws.kind}) to {args.delta:g} mm in {seconds:.2f} s: "
            f"{counts['inner']} inner, {counts['boundary']} boundary, {counts['outer']} outside boxes; "
            f"volume {cov.inner_measure / 1e3:.1f} to "
            f"{(cov.inner_measure + cov.boundary_measure) / 1e3:.1f} cm^3"
        )
        for name, place in scene.places.items():
            verdict = "reachable" if ws.reachable(place) else "NOT reachable"
            print(f"  place {name} {np.round(place, 1).tolist()} mm: {verdict}")
        if args.plot is not None:
            plot_workspace(cov, scene, model.name, args.plot)
            print(f"wrote {args.plot}")
        return 0


def _slice(lo: np.ndarray, hi: np.ndarray, axis: int, value: float) -> np.ndarray:
    return (lo[:, axis] <= value) & (hi[:, axis] >= value)


def _rects(lo: np.ndarray, hi: np.ndarray, a: int, b: int) -> np.ndarray:
    return np.stack(
        [
            np.stack([lo[:, a], lo[:, b]], 1),
            np.stack([hi[:, a], lo[:, b]], 1),
            np.stack([hi[:, a], hi[:, b]], 1),
            np.stack([lo[:, a], hi[:, b]], 1),
        ],
        axis=1,
    )


def plot_workspace(cov: Covering, scene: Scene, name: str, path: Path) -> None:
    """Write a PNG: top view, vertical slice y = 0, horizontal slice through the workspace."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    all_lo = np.concatenate([cov.inner_lo, cov.boundary_lo])
    all_hi = np.concatenate([cov.inner_hi, cov.boundary_hi])
    z_mid = 0.5 * (all_lo[:, 2].min() + all_hi[:, 2].max()) if len(all_lo) else 0.0
    if len(cov.inner_lo):
        z_mid = float(np.median(0.5 * (cov.inner_lo[:, 2] + cov.inner_hi[:, 2])))
    views = [
        ("top view (x-y, all heights)", 0, 1, None),
        (f"horizontal slice z = {z_mid:.0f} mm", 0, 1, (2, z_mid)),
        ("vertical slice y = 0 (x-z)", 0, 2, (1, 0.0)),
    ]
    fig, axes = plt.subplots(1, 3, figsize=(18, 6))
    for ax, (title, a, b, cut) in zip(axes, views, strict=True):
        # Inner boxes are drawn over boundary ones: in the top view a column with
        # any inner box is shown as reachable for certain.
        for lo, hi, colour, label in (
            (cov.boundary_lo, cov.boundary_hi, "#ffa500", "boundary"),
            (cov.inner_lo, cov.inner_hi, "#2e8b57", "inner"),
        ):
            keep = np.ones(len(lo), bool) if cut is None else _slice(lo, hi, *cut)
            polys = _rects(lo[keep], hi[keep], a, b)
            ax.add_collection(
                PolyCollection(
                    # matplotlib takes an (N, 4, 2) array as N polygons; its stub says Sequence
                    polys,  # type: ignore[arg-type]
                    facecolors=colour,
                    edgecolors="none",
                    alpha=0.8,
                    label=label,
                    rasterized=True,
                )
            )
        ax.plot([0], [0], marker="s", markersize=12, color="black", label="arm base")
        for pname, p in scene.places.items():
            if cut is None or abs(p[cut[0]] - cut[1]) < 50.0:
                ax.plot(p[a], p[b], "o", color="#1f4fd1")
                ax.annotate(pname, (p[a], p[b]), textcoords="offset points", xytext=(5, 5))
        if len(all_lo):
            pad = 20.0
            ax.set_xlim(all_lo[:, a].min() - pad, all_hi[:, a].max() + pad)
            ax.set_ylim(all_lo[:, b].min() - pad, all_hi[:, b].max() + pad)
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("xyz"[a] + " (mm)")
        ax.set_ylabel("xyz"[b] + " (mm)")
    axes[0].legend(loc="upper right")
    counts = cov.counts
    fig.suptitle(
        f"{name}: reachable workspace, boxes to {cov.delta:g} mm "
        f"({counts['inner']} inner, {counts['boundary']} boundary)"
    )
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
