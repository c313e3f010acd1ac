"""Least-squares kinematic calibration of an arm model (Showers 2016, "Model Validation", Fig. 6).

The report moved the Dobot's tool tip to known points, recorded the joint
angles, and fitted the model's parameters (tool offset ``d``, angle offsets,
angle scale factors; the link lengths held fixed against overfitting) with a
damped least-squares fit (MATLAB's ``lsqcurvefit``) so that the forward
kinematics (Showers 2016, eqs. 5-7) agree with the measured positions. This module
does the same for any :class:`~armtree.maths.motion.kinematics.KinematicModel`:

* structural parameters (link lengths, tool offset, ...) are set by a
  ``build(params) -> KinematicModel`` callable (for a plugin arm:
  ``lambda p: factory.model({**arm_config, **p})``);
* angle offsets and scale factors correct the reported joints,
  ``q_model = scale * q_reported + offset`` (degrees), for every model.

Units: joints in degrees, positions in mm at the interface; the fit works in
those units (residuals in mm). No plugin is imported here.
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from armtree.errors import ConfigError
from armtree.maths.motion.kinematics import KinematicModel

#: Builds a model from structural parameters (mm), e.g. ``{"tool_offset_mm": 53.4}``.
ModelBuilder = Callable[[Mapping[str, float]], KinematicModel]


@dataclass
class CalibrationPoints:
    """Reported joints ``(N, dof)`` in degrees and measured tool positions ``(N, 3)`` in mm."""

    joints_deg: np.ndarray
    measured_mm: np.ndarray
    source: str = ""


@dataclass
class KinematicFit:
    """Result of :func:`fit_kinematics`.

    ``params`` / ``initial`` map structural names to values (mm);
    ``joint_offsets_deg`` / ``joint_scales`` the reading correction;
    ``residuals_*_mm`` are ``(N, 3)`` model minus measurement, before
    (the initial model, no correction) and after the fit; ``rms_*_mm`` the
    root mean square of the residual distances.
    """

    initial: dict[str, float]
    params: dict[str, float]
    joint_offsets_deg: np.ndarray
    joint_scales: np.ndarray
    residuals_before_mm: np.ndarray
    residuals_after_mm: np.ndarray
    model: KinematicModel
    free: tuple[str, ...] = field(default_factory=tuple)
    #: One-sigma standard errors of the fitted unknowns (mm, degrees, factors), from the
    #: residual variance and the Jacobian at the solution: ``s^2 (J^T J)^-1``.
    std_errors: dict[str, float] = field(default_factory=dict)

    @property
    def rms_before_mm(self) -> float:
        """RMS distance between the initial model's positions and the measurements, mm."""
        return _rms(self.residuals_before_mm)

    @property
    def rms_after_mm(self) -> float:
        """RMS distance between the fitted model's positions and the measurements, mm."""
        return _rms(self.residuals_after_mm)

    def positions(self, joints_deg: np.ndarray) -> np.ndarray:
        """Tool positions ``(..., 3)`` mm of the fitted model for reported joints in degrees."""
        q = np.asarray(joints_deg, dtype=float) * self.joint_scales + self.joint_offsets_deg
        return self.model.position(q)


def _rms(residuals: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(residuals * residuals, axis=-1))))


def fit_kinematics(
    build: ModelBuilder,
    initial: Mapping[str, float],
    points: CalibrationPoints,
    *,
    free: Sequence[str] = (),
    fit_offsets: bool = True,
    fit_scales: bool = False,
) -> KinematicFit:
    """Fit ``free`` structural parameters and the joints' offsets / scales by least squares.

    Minimises ``sum |FK(scale * q + offset; params) - p_measured|^2`` over the
    points (Showers 2016, "Model Validation": the report's ``lsqcurvefit`` fit of
    eqs. 5-7), with scipy's trust-region reflective solver. Parameters not in
    ``free`` keep their ``initial`` value. Raises :class:`ConfigError` when there
    are fewer residuals than unknowns or the shapes disagree.
    """
    q = np.asarray(points.joints_deg, dtype=float)
    measured = np.asarray(points.measured_mm, dtype=float)
    base = {k: float(v) for k, v in initial.items()}
    free = tuple(free)
    unknown = [name for name in free if name not in base]
    if unknown:
        raise ConfigError(f"kinematic calibration: no initial value for {', '.join(unknown)}")
    model0 = build(base)
    dof = model0.dof
    if q.ndim != 2 or q.shape[1] != dof or measured.shape != (len(q), 3):
        raise ConfigError(
            f"kinematic calibration: need joints (N, {dof}) and positions (N, 3), "
            f"got {q.shape} and {measured.shape}",
            file=points.source or None,
        )
    n_unknown = len(free) + dof * (int(fit_offsets) + int(fit_scales))
    if 3 * len(q) < n_unknown or n_unknown == 0:
        raise ConfigError(
            f"kinematic calibration: {len(q)} points give {3 * len(q)} equations for "
            f"{n_unknown} unknowns; measure more points",
            file=points.source or None,
        )

    def unpack(x: np.ndarray) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
        params = dict(base)
        params.update(zip(free, x[: len(free)], strict=True))
        rest = x[len(free) :]
        offsets = rest[:dof] if fit_offsets else np.zeros(dof)
        rest = rest[dof:] if fit_offsets else rest
        scales = rest[:dof] if fit_scales else np.ones(dof)
        return params, offsets, scales

    def residuals(x: np.ndarray) -> np.ndarray:
        params, offsets, scales = unpack(x)
        # Showers 2016, eqs. 5-7 through the model, on the corrected angles
        return (build(params).position(q * scales + offsets) - measured).ravel()

    x0 = np.concatenate(
        [
            [base[name] for name in free],
            np.zeros(dof) if fit_offsets else [],
            np.ones(dof) if fit_scales else [],
        ]
    )
    # x_scale="jac": lengths (~100 mm), angles (~1 deg) and scales (~1) differ in size.
    # Imported here: scipy.optimize is slow to import and only a fit needs it.
    from scipy.optimize import least_squares

    solution = least_squares(residuals, x0, method="trf", x_scale="jac")
    params, offsets, scales = unpack(solution.x)
    model = build(params)
    names = (
        list(free)
        + ([f"joint_offset_{i}_deg" for i in range(dof)] if fit_offsets else [])
        + ([f"joint_scale_{i}" for i in range(dof)] if fit_scales else [])
    )
    return KinematicFit(
        initial=base,
        params={k: float(v) for k, v in params.items()},
        joint_offsets_deg=np.asarray(offsets, dtype=float),
        joint_scales=np.asarray(scales, dtype=float),
        residuals_before_mm=model0.position(q) - measured,
        residuals_after_mm=model.position(q * scales + offsets) - measured,
        model=model,
        free=free,
        std_errors=dict(zip(names, _std_errors(solution.jac, solution.fun), strict=True)),
    )


def _std_errors(jac: np.ndarray, fun: np.ndarray) -> list[float]:
    dof = max(1, fun.size - jac.shape[1])
    variance = float(fun @ fun) / dof
    cov = np.linalg.pinv(jac.T @ jac) * variance
    return [float(v) for v in np.sqrt(np.clip(np.diag(cov), 0.0, None))]


# ---------------------------------------------------------------------- input files

#: Column names of a points CSV (joints j0..j{dof-1} in degrees, then x, y, z in mm).
POSITION_COLUMNS = ("x", "y", "z")


def read_points(path: str | Path, dof: int) -> CalibrationPoints:
    """Read calibration points from a CSV or YAML file; ConfigError naming file and line.

    CSV: a header ``j0,...,j{dof-1},x,y,z`` (joints in degrees, measured tool
    position in mm), one point per row; ``#`` starts a comment line. YAML: a
    list of ``{joints: [deg, ...], position: [x, y, z]}`` mappings, or a mapping
    with such a list under ``points``.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError("no such calibration points file", file=str(path))
    if path.suffix.lower() in (".yaml", ".yml"):
        q, p = _read_yaml(path, dof)
    elif path.suffix.lower() == ".csv":
        q, p = _read_csv(path, dof)
    else:
        raise ConfigError("calibration points must be a .csv or .yaml file", file=str(path))
    if not q:
        raise ConfigError("no calibration points in this file", file=str(path))
    return CalibrationPoints(np.array(q), np.array(p), str(path))


def _read_csv(path: Path, dof: int) -> tuple[list[list[float]], list[list[float]]]:
    expected = [f"j{i}" for i in range(dof)] + list(POSITION_COLUMNS)
    joints: list[list[float]] = []
    positions: list[list[float]] = []
    header: list[str] | None = None
    with path.open(newline="") as handle:
        for line_no, row in enumerate(csv.reader(handle), start=1):
            if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
                continue
            cells = [c.strip() for c in row]
            if header is None:
                header = [c.lower() for c in cells]
                if header != expected:
                    raise ConfigError(
                        f"header must be {','.join(expected)} (joints deg, position mm), "
                        f"got {','.join(cells)}",
                        file=str(path),
                        line=line_no,
                    )
                continue
            if len(cells) != len(expected):
                raise ConfigError(
                    f"{len(cells)} values, expected {len(expected)}", file=str(path), line=line_no
                )
            values = _floats(cells, path, line_no)
            joints.append(values[:dof])
            positions.append(values[dof:])
    return joints, positions


def _floats(cells: Sequence[object], path: Path, line: int | None) -> list[float]:
    try:
        values = [float(c) for c in cells]  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ConfigError(f"not a number among {list(cells)}", file=str(path), line=line) from None
    if not np.all(np.isfinite(values)):
        raise ConfigError(f"not a finite number among {list(cells)}", file=str(path), line=line)
    return values


def _read_yaml(path: Path, dof: int) -> tuple[list[list[float]], list[list[float]]]:
    text = path.read_text()
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise ConfigError(
            f"not valid YAML: {getattr(exc, 'problem', exc)}",
            file=str(path),
            line=None if mark is None else mark.line + 1,
        ) from None
    if isinstance(data, Mapping):
        if not isinstance(node, yaml.MappingNode):
            raise ConfigError("expected a mapping", file=str(path))
        items = {k.value: v for k, v in node.value}
        data, node = data.get("points"), items.get("points")
    if not isinstance(data, list) or not isinstance(node, yaml.SequenceNode):
        raise ConfigError("expected a list of points (or points: [...])", file=str(path), line=1)
    joints: list[list[float]] = []
    positions: list[list[float]] = []
    for entry, entry_node in zip(data, node.value, strict=True):
        line = entry_node.start_mark.line + 1
        if not isinstance(entry, Mapping) or "joints" not in entry or "position" not in entry:
            raise ConfigError(
                "each point is {joints: [deg...], position: [x, y, z] mm}",
                file=str(path),
                line=line,
            )
        q, p = entry["joints"], entry["position"]
        if not isinstance(q, list) or len(q) != dof or not isinstance(p, list) or len(p) != 3:
            raise ConfigError(
                f"joints needs {dof} angles (deg) and position 3 coordinates (mm)",
                file=str(path),
                line=line,
            )
        values = _floats(list(q) + list(p), path, line)
        joints.append(values[:dof])
        positions.append(values[dof:])
    return joints, positions


def write_points(path: str | Path, points: CalibrationPoints) -> None:
    """Write points as the CSV :func:`read_points` reads (joints deg, position mm)."""
    dof = points.joints_deg.shape[1]
    with Path(path).open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow([f"j{i}" for i in range(dof)] + list(POSITION_COLUMNS))
        for q, p in zip(points.joints_deg, points.measured_mm, strict=True):
            writer.writerow([f"{v:.4f}" for v in q] + [f"{v:.4f}" for v in p])


def plot_residuals(fit: KinematicFit, path: str | Path) -> None:
    """PNG of the per-point residual distances (mm) before and after the fit, and in x-y."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    before = np.linalg.norm(fit.residuals_before_mm, axis=1)
    after = np.linalg.norm(fit.residuals_after_mm, axis=1)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    index = np.arange(len(before))
    ax1.bar(index - 0.2, before, 0.4, label=f"before (RMS {fit.rms_before_mm:.2f} mm)")
    ax1.bar(index + 0.2, after, 0.4, label=f"after (RMS {fit.rms_after_mm:.2f} mm)")
    ax1.set_xlabel("point")
    ax1.set_ylabel("|FK - measured| (mm)")
    ax1.set_title("residual distance per point")
    ax1.legend()
    for res, label in ((fit.residuals_before_mm, "before"), (fit.residuals_after_mm, "after")):
        ax2.scatter(res[:, 0], res[:, 1], s=14, label=label)
    ax2.axhline(0, color="grey", lw=0.5)
    ax2.axvline(0, color="grey", lw=0.5)
    ax2.set_aspect("equal", adjustable="datalim")
    ax2.set_xlabel("x residual (mm)")
    ax2.set_ylabel("y residual (mm)")
    ax2.set_title("residuals in the base x-y plane")
    ax2.legend()
    fig.suptitle("kinematic calibration (Showers 2016, least squares on eqs. 5-7)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
